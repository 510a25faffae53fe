#include "freeloc/core/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "freeloc/core/logging.h"
#include "freeloc/core/timing.h"

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

namespace {
std::atomic<const char*> g_stage{""};
// The process's start from /proc/self/stat (field 22, clock ticks after boot) on the steady clock — the exec and the
// dynamic loading before any library code ran included; the moment this library was loaded where that is unreadable.
std::chrono::steady_clock::time_point StartOfProcess() {
  const auto loaded = std::chrono::steady_clock::now();
  std::FILE* f = std::fopen("/proc/self/stat", "r");
  if (!f) return loaded;
  char buf[1024];
  const size_t n = std::fread(buf, 1, sizeof(buf) - 1, f);
  std::fclose(f);
  buf[n] = 0;
  const char* p = std::strrchr(buf, ')');  // the command name may hold spaces; the fields follow its ')'
  unsigned long long ticks = 0;
  for (int field = 2; p && *p && field < 22; ++p)
    if (*p == ' ') ++field;
  timespec boot{};
  if (!p || std::sscanf(p, "%llu", &ticks) != 1 || clock_gettime(CLOCK_BOOTTIME, &boot) != 0) return loaded;
  const double since_boot = boot.tv_sec + boot.tv_nsec * 1e-9, started = ticks / double(sysconf(_SC_CLK_TCK));
  const double age = since_boot - started;
  if (!(age >= 0 && age < 60)) return loaded;  // not a fresh process (a long-lived one loading us late): no claim
  return loaded - std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(age));
}
const std::chrono::steady_clock::time_point g_process_start = StartOfProcess();
}  // namespace

std::chrono::steady_clock::time_point ProcessStart() { return g_process_start; }

void SetStage(const char* stage) {
  g_stage.store(stage ? stage : "");
  FREELOC_LOG(DEBUG) << "stage: " << (stage ? stage : "");
}

const char* CurrentStage() { return g_stage.load(); }

StageTicker::StageTicker(std::string label, int enabled) : label_(std::move(label)) {
  const bool on = enabled < 0 ? ::isatty(STDERR_FILENO) && LogEnabled(LogLevel::kInfo) : enabled > 0;
  if (!on) return;
  thread_ = std::thread([this] {
    const auto start = std::chrono::steady_clock::now();
    std::unique_lock<std::mutex> lock(mu_);
    if (cv_.wait_for(lock, std::chrono::seconds(2), [this] { return stop_; })) return;
    while (!stop_) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::fprintf(stderr, "\r\033[K%s: %s… %.1f s", label_.c_str(), CurrentStage(), s);
      std::fflush(stderr);
      drawn_ = true;
      cv_.wait_for(lock, std::chrono::milliseconds(250), [this] { return stop_; });
    }
  });
}

void StageTicker::Stop() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (drawn_) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
    drawn_ = false;
  }
}

StageTicker::~StageTicker() { Stop(); }

}  // namespace freeloc
