// The sequential probability ratio test (sprt.h) on seeded Bernoulli data: wrong models are dropped after a few
// dozen data, models holding ε survive with probability about 1 − 1/A, and A solves Chum and Matas's equation.
#include "freeloc/geometry/sprt.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace freeloc::geometry {
namespace {

// `trials` hypotheses whose data are consistent with probability `share` (each datum fixed per hypothesis).
struct Outcome {
  int accepted = 0;
  double mean_checked = 0;
};
Outcome RunHypotheses(SprtTest* test, size_t n, double share, int trials, uint32_t seed) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution fits(share);
  Outcome o;
  std::vector<char> data(n);
  for (int t = 0; t < trials; ++t) {
    for (auto& d : data) d = fits(rng);
    size_t checked = 0;
    o.accepted += test->Accept([&](size_t i) { return data[i] != 0; }, &checked);
    o.mean_checked += static_cast<double>(checked) / trials;
  }
  return o;
}

TEST(Sprt, WrongModelsAreDroppedAfterAFewDozenData) {
  const size_t n = 40000;
  SprtTest test(n, 1, 0.25, 500);
  const Outcome o = RunHypotheses(&test, n, 0.02, 300, 2);
  EXPECT_EQ(o.accepted, 0);
  EXPECT_LT(o.mean_checked, 100) << "a wrong model should cost a few dozen evaluations, not " << n;
  // δ is learnt from the dropped hypotheses: near their true share, and below ε.
  EXPECT_NEAR(test.delta(), 0.02, 0.015);
  EXPECT_LT(test.delta(), test.epsilon());
}

TEST(Sprt, GoodModelsSurviveAsOftenAsTheThresholdPromises) {
  const size_t n = 5000;
  for (const double eps : {0.15, 0.25, 0.5}) {
    SprtTest test(n, 3, eps, 500);
    RunHypotheses(&test, n, 0.02, 200, 4);  // learn δ
    const int trials = 400;
    const Outcome good = RunHypotheses(&test, n, eps, trials, 5);
    // Wald: a model as good as ε is dropped with probability at most about 1/A; allow sampling noise.
    const double dropped = 1.0 - static_cast<double>(good.accepted) / trials;
    EXPECT_LE(dropped, 1.0 / test.threshold() + 3 * std::sqrt((1.0 / test.threshold()) / trials) + 0.005)
        << "ε " << eps << ", A " << test.threshold();
    EXPECT_NEAR(test.SampleSuccessFactor(), 1.0 - 1.0 / test.threshold(), 1e-12);
    // Models holding more than ε survive; chance models are dropped.
    EXPECT_EQ(RunHypotheses(&test, n, std::min(0.99, eps + 0.1), 50, 6).accepted, 50);
    EXPECT_EQ(RunHypotheses(&test, n, 0.02, 50, 7).accepted, 0);
  }
}

TEST(Sprt, ThresholdSolvesChumAndMatasEquation) {
  SprtTest test(1000, 9, 0.3, 400);
  RunHypotheses(&test, 1000, 0.05, 100, 10);
  const double eps = test.epsilon(), delta = test.delta(), a = test.threshold();
  const double c = (1 - delta) * std::log((1 - delta) / (1 - eps)) + delta * std::log(delta / eps);
  EXPECT_NEAR(a, 400 * c + 1 + std::log(a), 1e-6 * a);
  EXPECT_GT(a, 1);
  EXPECT_DOUBLE_EQ(eps, 0.3);  // ε is the minimum share asked for
}

}  // namespace
}  // namespace freeloc::geometry
