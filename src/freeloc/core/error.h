// freeloc's one error policy (docs/architecture.md §2): the library throws freeloc::Error whose message says which
// input, what is wrong and what to do; expected estimator failures are results, not exceptions.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace freeloc {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// An option out of range or unreadable. `field` is the option's registry name (pipeline/options.h: "solver",
// "threshold_px", …; or a run field: "data", "out", "log", "shard"), `detail` the rest of the message (it starts with
// ": " or " "). what() reads field + detail — the name C++ and Python callers use; the command line shows the
// field's flag instead (cli/common.h FlagMessage), looked up in the option registry, never rewritten from text.
class OptionError : public Error {
 public:
  OptionError(std::string field, std::string detail)
      : Error(field + detail), field_(std::move(field)), detail_(std::move(detail)) {}
  const std::string& field() const { return field_; }
  const std::string& detail() const { return detail_; }

 private:
  std::string field_, detail_;
};

// An input that means something else than it is read as (inputs/input_checks.h), whose fix is an option's value:
// the message names the option as `field=value` ("set depth_unit=m"); the CLI adds the flag that sets it.
class InputFixError : public Error {
 public:
  InputFixError(const std::string& message, std::string field, std::string value)
      : Error(message), field_(std::move(field)), value_(std::move(value)) {}
  const std::string& field() const { return field_; }
  const std::string& value() const { return value_; }

 private:
  std::string field_, value_;
};

// Formats "<input>: <what is wrong>; <what to do>" — the shape every user-facing error takes.
std::string FormatError(const std::string& input, const std::string& what, const std::string& todo = "");

// Text from a file made safe to print on a terminal: control characters (escape codes, newlines) become \xNN and
// anything beyond `max_len` bytes is cut with "…".
std::string SafeText(const std::string& text, size_t max_len = 200);

namespace internal {
[[noreturn]] void ThrowCheckFailure(const char* file, int line, const char* condition, const std::string& message);
}  // namespace internal

}  // namespace freeloc

// FREELOC_CHECK(cond, msg): throws freeloc::Error with `msg` (a stream expression) when `cond` is false.
// The message should name the input, say what is wrong and what to do, e.g.
//   FREELOC_CHECK(w > 0, path << ": image has zero width; re-export the file");
#define FREELOC_CHECK(cond, msg)                                                                  \
  do {                                                                                            \
    if (!(cond)) {                                                                                \
      std::ostringstream freeloc_check_os_;                                                       \
      freeloc_check_os_ << msg;                                                                   \
      ::freeloc::internal::ThrowCheckFailure(__FILE__, __LINE__, #cond, freeloc_check_os_.str()); \
    }                                                                                             \
  } while (0)

#define FREELOC_CHECK_OP_(a, b, op, msg) \
  FREELOC_CHECK((a)op(b), msg << " (expected " #a " " #op " " #b ", got " << (a) << " vs " << (b) << ")")
#define FREELOC_CHECK_EQ(a, b, msg) FREELOC_CHECK_OP_(a, b, ==, msg)
#define FREELOC_CHECK_NE(a, b, msg) FREELOC_CHECK_OP_(a, b, !=, msg)
#define FREELOC_CHECK_LT(a, b, msg) FREELOC_CHECK_OP_(a, b, <, msg)
#define FREELOC_CHECK_LE(a, b, msg) FREELOC_CHECK_OP_(a, b, <=, msg)
#define FREELOC_CHECK_GT(a, b, msg) FREELOC_CHECK_OP_(a, b, >, msg)
#define FREELOC_CHECK_GE(a, b, msg) FREELOC_CHECK_OP_(a, b, >=, msg)

// FREELOC_OPTION_CHECK(field, cond, detail): throws OptionError(field, detail) when `cond` is false; `detail` (a stream
// expression) continues the message after the field's name: FREELOC_OPTION_CHECK("frames", f <= 9, ": " << f << …).
#define FREELOC_OPTION_CHECK(field, cond, detail)                      \
  do {                                                                 \
    if (!(cond)) {                                                     \
      std::ostringstream freeloc_option_os_;                           \
      freeloc_option_os_ << detail;                                    \
      throw ::freeloc::OptionError((field), freeloc_option_os_.str()); \
    }                                                                  \
  } while (0)

// FREELOC_THROW(msg): unconditional error with the same formatting.
#define FREELOC_THROW(msg)                           \
  do {                                               \
    std::ostringstream freeloc_throw_os_;            \
    freeloc_throw_os_ << msg;                        \
    throw ::freeloc::Error(freeloc_throw_os_.str()); \
  } while (0)
