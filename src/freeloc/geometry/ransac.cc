#include "freeloc/geometry/ransac.h"

#include <exception>

#include "freeloc/core/error.h"

namespace freeloc::geometry {

void RansacOptions::Validate(const char* estimator) const {
  FREELOC_CHECK(success_prob > 0 && success_prob < 1, estimator << ": success_prob must be in (0, 1)");
  FREELOC_CHECK(min_iterations >= 0 && max_iterations >= 1 && min_iterations <= max_iterations,
                estimator << ": need 0 <= min_iterations <= max_iterations and max_iterations >= 1");
  FREELOC_CHECK(max_seconds >= 0 && std::isfinite(max_seconds), estimator << ": max_seconds must be >= 0");
  FREELOC_CHECK(sprt_min_data >= 0, estimator << ": sprt_min_data must be >= 0 (0: no sequential test)");
  FREELOC_CHECK(min_inlier_ratio > 0 && min_inlier_ratio < 1, estimator << ": min_inlier_ratio must be in (0, 1)");
  FREELOC_CHECK(give_up_prob > 0 && give_up_prob < 1, estimator << ": give_up_prob must be in (0, 1)");
}

ConcurrentSearch::ConcurrentSearch(std::function<void(RansacTrace*)> search) : search_(std::move(search)) {
  if (std::thread::hardware_concurrency() > 1) {
    thread_ = std::thread([this] {
      try {
        search_(&trace_);
      } catch (...) {
        error_ = std::current_exception();
      }
    });
  }
}

ConcurrentSearch::~ConcurrentSearch() {
  if (thread_.joinable()) {
    trace_.limit.store(0, std::memory_order_relaxed);
    thread_.join();
  }
}

int ConcurrentSearch::BestInliersAfter(int k) {
  if (thread_.joinable()) {
    // Never lower than it is: iterations past k that already ran are cut from the trace below.
    int cur = trace_.limit.load(std::memory_order_relaxed);
    while (k < cur && !trace_.limit.compare_exchange_weak(cur, k, std::memory_order_relaxed)) {
    }
    thread_.join();
  } else if (search_) {
    trace_.limit.store(k, std::memory_order_relaxed);
    search_(&trace_);
    search_ = nullptr;
  }
  if (error_) std::rethrow_exception(error_);
  int best = 0;
  for (const auto& [iteration, inliers] : trace_.improvements)
    if (iteration < std::min(k, trace_.iterations)) best = inliers;
  return best;
}

}  // namespace freeloc::geometry
