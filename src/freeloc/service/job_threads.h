// A fixed set of threads that run jobs, for the service: the workers (Run: a job handed over and waited for, so that
// the libraries' per-thread state exists once per worker) and the transport's handler threads (TryPost: refused when
// every thread is taken, never queued without bound).
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

namespace freeloc::service {

class JobThreads {
 public:
  explicit JobThreads(int n) {
    for (int i = 0; i < n; ++i)
      threads_.emplace_back([this] {
        while (true) {
          std::function<void()> job;
          {
            std::unique_lock<std::mutex> lock(mu_);
            cv_.wait(lock, [&] { return stop_ || !jobs_.empty(); });
            if (jobs_.empty()) return;
            job = std::move(jobs_.front());
            jobs_.pop_front();
          }
          job();
          std::lock_guard<std::mutex> lock(mu_);
          --taken_;
        }
      });
  }
  ~JobThreads() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_) t.join();
  }
  JobThreads(const JobThreads&) = delete;
  JobThreads& operator=(const JobThreads&) = delete;

  // Queues `job` unless every thread is taken (running or about to run a job): false, nothing queued.
  bool TryPost(std::function<void()> job) { return Post(std::move(job), true); }
  // Runs `job` on one of the threads and returns when it has run (`job` must not throw).
  void Run(const std::function<void()>& job) {
    std::promise<void> done;
    std::future<void> f = done.get_future();
    Post(
        [&] {
          job();
          done.set_value();
        },
        false);
    f.get();
  }

 private:
  bool Post(std::function<void()> job, bool bounded) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (bounded && taken_ >= static_cast<int>(threads_.size())) return false;
      ++taken_;
      jobs_.push_back(std::move(job));
    }
    cv_.notify_one();
    return true;
  }

  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> jobs_;
  std::vector<std::thread> threads_;
  int taken_ = 0;  // jobs queued or running
  bool stop_ = false;
};

}  // namespace freeloc::service
