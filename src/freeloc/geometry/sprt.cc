#include "freeloc/geometry/sprt.h"

#include <algorithm>

namespace freeloc::geometry {

namespace {

// What a wrong model is assumed to explain before any has been dropped, and how many data that guess weighs.
constexpr double kDeltaPrior = 0.05;
constexpr double kDeltaPriorWeight = 200;

}  // namespace

SprtTest::SprtTest(size_t n, uint64_t seed, double min_inlier_ratio, double solve_cost)
    : order_(n),
      rng_(seed ^ 0x5350525454455354ull),
      solve_cost_(std::max(solve_cost, 1.0)),
      eps_(std::clamp(min_inlier_ratio, 0.01, 0.95)),
      delta_(kDeltaPrior),
      seen_in_(kDeltaPrior * kDeltaPriorWeight),
      seen_(kDeltaPriorWeight) {
  std::iota(order_.begin(), order_.end(), 0u);
  for (size_t i = n; i > 1; --i) std::swap(order_[i - 1], order_[rng_.Below(static_cast<uint32_t>(i))]);
  Update();
}

void SprtTest::Rejected(size_t in, size_t seen) {
  seen_in_ += static_cast<double>(in);
  seen_ += static_cast<double>(seen);
  Update();
}

void SprtTest::Update() {
  // δ: the consistent share of the data the dropped hypotheses were checked on, kept well below ε (the test needs
  // δ < ε to tell the two apart).
  delta_ = std::clamp(seen_in_ / seen_, 1e-4, 0.5 * eps_);
  log_in_ = std::log(delta_ / eps_);
  log_out_ = std::log((1.0 - delta_) / (1.0 - eps_));
  // Chum & Matas's optimal threshold: A = K + ln A with K = t_M·C / m_S + 1, where C is the expected evidence a
  // wrong model gives per datum (its Kullback–Leibler divergence) and t_M / m_S the solve's cost per model —
  // solved by fixed-point iteration from A = K.
  const double c = (1.0 - delta_) * log_out_ + delta_ * std::log(delta_ / eps_);
  const double k = solve_cost_ * c + 1.0;
  double a = std::max(k, 2.0);
  for (int i = 0; i < 20; ++i) {
    const double next = k + std::log(a);
    if (std::abs(next - a) < 1e-9 * a) break;
    a = next;
  }
  log_a_ = std::log(std::max(a, 2.0));
}

}  // namespace freeloc::geometry
