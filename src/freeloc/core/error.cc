#include "freeloc/core/error.h"

#include <cstdlib>

namespace freeloc {

std::string FormatError(const std::string& input, const std::string& what, const std::string& todo) {
  std::string out = input.empty() ? what : input + ": " + what;
  if (!todo.empty()) out += "; " + todo;
  return out;
}

namespace internal {
void ThrowCheckFailure(const char* file, int line, const char* condition, const std::string& message) {
  // The user sees the message; the source location only in debug builds or with FREELOC_DEBUG_CHECKS set,
  // so messages stay one line and about the input, not the code.
  static const bool with_location = std::getenv("FREELOC_DEBUG_CHECKS") != nullptr;
  if (with_location) {
    throw Error(message + " [check `" + condition + "` failed at " + file + ":" + std::to_string(line) + "]");
  }
  throw Error(message.empty() ? std::string("internal check failed: ") + condition : message);
}
}  // namespace internal

}  // namespace freeloc
