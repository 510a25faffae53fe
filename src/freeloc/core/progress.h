// Progress bar for long loops: "label [#####.....] 12/40 3.1/s ETA 9s" on stderr, redrawn in place.
// Silent when stderr is not a terminal or the log level is below info (--quiet).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace freeloc {

class ProgressBar {
 public:
  // `enabled`: -1 = auto (stderr is a TTY and logging at info or more), 0 = never, 1 = always.
  ProgressBar(std::string label, int64_t total, int enabled = -1);
  ~ProgressBar();

  void Update(int64_t done);  // absolute progress
  void Increment(int64_t n = 1) { Update(done_ + n); }
  void Finish();
  void SetLabel(std::string label) { label_ = std::move(label); }  // shown from the next redraw
  bool enabled() const { return enabled_; }

  // The line drawn for `done` of `total` after `elapsed_s` seconds, `width` characters for the bar.
  static std::string Render(const std::string& label, int64_t done, int64_t total, double elapsed_s, int width = 30);
  static std::string FormatDuration(double seconds);

 private:
  std::string label_;
  int64_t total_;
  int64_t done_ = 0;
  bool enabled_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

// The stage a command is in ("query: matching"), set by the Relocalizer as each stage starts (a string literal: it
// is kept by pointer). Logged at debug level (--verbose) as it is set; shown by a StageTicker. Process-wide.
void SetStage(const char* stage);
const char* CurrentStage();

// A one-line progress for a single long piece of work: from 2 s on, "label: <stage>… 3.4 s" redrawn on stderr every
// quarter second (a terminal at info level only), cleared when stopped or destroyed.
class StageTicker {
 public:
  explicit StageTicker(std::string label, int enabled = -1);
  ~StageTicker();
  void Stop();
  StageTicker(const StageTicker&) = delete;
  StageTicker& operator=(const StageTicker&) = delete;

 private:
  std::string label_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false, drawn_ = false;
  std::thread thread_;
};

}  // namespace freeloc
