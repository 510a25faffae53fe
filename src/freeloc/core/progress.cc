#include "freeloc/core/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "freeloc/core/logging.h"

namespace freeloc {

ProgressBar::ProgressBar(std::string label, int64_t total, int enabled)
    : label_(std::move(label)), total_(std::max<int64_t>(total, 0)) {
  if (enabled < 0) {
    enabled_ = ::isatty(STDERR_FILENO) && LogEnabled(LogLevel::kInfo);
  } else {
    enabled_ = enabled > 0;
  }
  start_ = std::chrono::steady_clock::now();
  last_draw_ = start_ - std::chrono::seconds(1);
}

ProgressBar::~ProgressBar() { Finish(); }

std::string ProgressBar::FormatDuration(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  char buf[32];
  const long t = std::lround(s);
  if (t < 60) {
    std::snprintf(buf, sizeof(buf), "%lds", t);
  } else if (t < 3600) {
    std::snprintf(buf, sizeof(buf), "%ldm%02lds", t / 60, t % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%ldh%02ldm", t / 3600, (t % 3600) / 60);
  }
  return buf;
}

std::string ProgressBar::Render(const std::string& label, int64_t done, int64_t total, double elapsed_s, int width) {
  const double frac = total > 0 ? std::clamp(static_cast<double>(done) / total, 0.0, 1.0) : 0.0;
  const int filled = static_cast<int>(std::floor(frac * width));
  std::string bar(filled, '#');
  bar += std::string(width - filled, '.');
  const double rate = elapsed_s > 0 ? done / elapsed_s : 0.0;
  char rate_buf[32];
  if (rate >= 1.0 || rate == 0.0) {
    std::snprintf(rate_buf, sizeof(rate_buf), "%.1f/s", rate);
  } else {
    std::snprintf(rate_buf, sizeof(rate_buf), "%.1fs/it", 1.0 / rate);
  }
  std::string eta = (rate > 0 && total > 0) ? FormatDuration((total - done) / rate) : "?";
  if (total > 0 && done >= total) eta = "done in " + FormatDuration(elapsed_s);
  return label + " [" + bar + "] " + std::to_string(done) + "/" + std::to_string(total) + " " + rate_buf + " ETA " +
         eta;
}

void ProgressBar::Update(int64_t done) {
  done_ = std::min(done, total_);
  if (!enabled_ || finished_) return;
  const auto now = std::chrono::steady_clock::now();
  // Redraw at most ~10 times a second, and always at the end.
  if (done_ < total_ && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  std::fprintf(stderr, "\r%s\033[K", Render(label_, done_, total_, elapsed).c_str());
  std::fflush(stderr);
}

void ProgressBar::Finish() {
  if (finished_) return;
  if (enabled_) {
    last_draw_ = start_ - std::chrono::seconds(1);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::fprintf(stderr, "\r%s\033[K\n", Render(label_, done_, total_, elapsed).c_str());
    std::fflush(stderr);
  }
  finished_ = true;
}

}  // namespace freeloc
