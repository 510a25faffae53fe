// Levelled logging to stderr. The CLI sets the level from --quiet / --verbose.
#pragma once

#include <sstream>
#include <string>

namespace freeloc {

enum class LogLevel { kError = 0, kWarning = 1, kInfo = 2, kDebug = 3 };

void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();
bool LogEnabled(LogLevel level);
void LogMessage(LogLevel level, const std::string& message);

namespace internal {
class LogLine {
 public:
  explicit LogLine(LogLevel level) : level_(level) {}
  ~LogLine() { LogMessage(level_, os_.str()); }
  template <typename T>
  LogLine& operator<<(const T& v) {
    os_ << v;
    return *this;
  }

 private:
  LogLevel level_;
  std::ostringstream os_;
};
}  // namespace internal

}  // namespace freeloc

// FREELOC_LOG(INFO) << "…"; the stream is not evaluated when the level is disabled.
#define FREELOC_LOG_LEVEL_ERROR ::freeloc::LogLevel::kError
#define FREELOC_LOG_LEVEL_WARNING ::freeloc::LogLevel::kWarning
#define FREELOC_LOG_LEVEL_INFO ::freeloc::LogLevel::kInfo
#define FREELOC_LOG_LEVEL_DEBUG ::freeloc::LogLevel::kDebug
// (A one-shot `for` rather than `if`/`else`, so the macro nests safely under an unbraced `if`.)
#define FREELOC_LOG(level)                                                                           \
  for (bool freeloc_log_once_ = ::freeloc::LogEnabled(FREELOC_LOG_LEVEL_##level); freeloc_log_once_; \
       freeloc_log_once_ = false)                                                                    \
  ::freeloc::internal::LogLine(FREELOC_LOG_LEVEL_##level)
