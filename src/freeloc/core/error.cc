#include "freeloc/core/error.h"

#include <cstdlib>

#include "freeloc/core/env.h"

namespace freeloc {

std::string FormatError(const std::string& input, const std::string& what, const std::string& todo) {
  std::string out = input.empty() ? what : input + ": " + what;
  if (!todo.empty()) out += "; " + todo;
  return out;
}

std::string SafeText(const std::string& text, size_t max_len) {
  static const char* kHex = "0123456789abcdef";
  std::string out;
  for (size_t k = 0; k < text.size(); ++k) {
    if (out.size() >= max_len) return out + "…";
    const unsigned char c = static_cast<unsigned char>(text[k]);
    if (c < 0x20 || c == 0x7f) {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    } else {
      out += static_cast<char>(c);
    }
  }
  return out;
}

namespace internal {
void ThrowCheckFailure(const char* file, int line, const char* condition, const std::string& message) {
  // The user sees the message; the source location only in debug builds or with FREELOC_DEBUG_CHECKS set,
  // so messages stay one line and about the input, not the code.
  static const bool with_location = EnvSwitch("FREELOC_DEBUG_CHECKS") != nullptr;
  if (with_location) {
    throw Error(message + " [check `" + condition + "` failed at " + file + ":" + std::to_string(line) + "]");
  }
  throw Error(message.empty() ? std::string("internal check failed: ") + condition : message);
}
}  // namespace internal

}  // namespace freeloc
