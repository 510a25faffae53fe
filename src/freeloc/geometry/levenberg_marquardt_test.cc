// The geometry vocabulary: the one LM loop on seeded synthetic problems (a robust fit that plain least squares gets
// wrong, a rejected step, the stopping rules), the Lie helpers against their definitions, the shared RANSAC
// options' validation and the typed outcomes' string tables.
#include "freeloc/geometry/levenberg_marquardt.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

#include "freeloc/core/error.h"
#include "freeloc/geometry/estimator_status.h"
#include "freeloc/geometry/lie.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/ransac.h"
#include "freeloc/geometry/robust_loss.h"

namespace freeloc::geometry {
namespace {

// y = a·exp(b·x): a 2-parameter curve fit with a loss object, and an optional domain (a > 0).
template <class Loss>
class ExpFit {
 public:
  using Params = Eigen::Vector2d;
  static constexpr int kNumParams = 2;
  ExpFit(std::vector<double> x, std::vector<double> y, Loss loss, bool positive_a = false)
      : x_(std::move(x)), y_(std::move(y)), loss_(loss), positive_a_(positive_a) {}
  int num_params() const { return 2; }
  double Cost(const Params& p) const {
    double c = 0;
    for (size_t i = 0; i < x_.size(); ++i) {
      const double r = p(0) * std::exp(p(1) * x_[i]) - y_[i];
      c += loss_.Cost(r * r);
    }
    return c;
  }
  void Linearize(const Params& p, Eigen::Matrix2d* H, Eigen::Vector2d* g) const {
    for (size_t i = 0; i < x_.size(); ++i) {
      const double e = std::exp(p(1) * x_[i]);
      const double r = p(0) * e - y_[i];
      const Eigen::Vector2d J(e, p(0) * x_[i] * e);
      const double w = loss_.Weight(r * r);
      *H += w * J * J.transpose();
      *g += w * r * J;
    }
  }
  bool Step(const Params& p, const Eigen::Vector2d& d, Params* out) const {
    *out = p + d;
    ++steps;
    const bool inside = !positive_a_ || (*out)(0) > 0;
    refused += !inside;
    return inside;
  }
  mutable int steps = 0, refused = 0;

 private:
  std::vector<double> x_, y_;
  Loss loss_;
  bool positive_a_;
};

void Samples(uint64_t seed, int outliers, std::vector<double>* x, std::vector<double>* y) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, 0.01);
  for (int i = 0; i < 60; ++i) {
    x->push_back(i / 30.0);
    y->push_back(2.0 * std::exp(-0.7 * x->back()) + noise(rng));
  }
  for (int k = 0; k < outliers; ++k) (*y)[static_cast<size_t>(7 * k + 3)] += 3.0;
}

TEST(LevenbergMarquardt, ConvergesOnAnExponentialFit) {
  for (uint64_t seed : {11u, 12u, 13u}) {
    std::vector<double> x, y;
    Samples(seed, 0, &x, &y);
    Eigen::Vector2d p(1.0, 0.0);
    LMOptions o;
    o.max_iterations = 100;
    const LMSummary s = MinimizeLM(ExpFit<TrivialLoss>(x, y, {}), &p, o);
    EXPECT_TRUE(s.converged) << seed;
    EXPECT_LT(s.final_cost, s.initial_cost);
    EXPECT_NEAR(p(0), 2.0, 0.02) << seed;
    EXPECT_NEAR(p(1), -0.7, 0.02) << seed;
  }
}

TEST(LevenbergMarquardt, TheCauchyLossIgnoresOutliersThatPullPlainLeastSquares) {
  std::vector<double> x, y;
  Samples(21, 6, &x, &y);
  LMOptions o;
  o.max_iterations = 100;
  Eigen::Vector2d plain(1.0, 0.0), robust(1.0, 0.0);
  MinimizeLM(ExpFit<TrivialLoss>(x, y, {}), &plain, o);
  MinimizeLM(ExpFit<CauchyLoss>(x, y, CauchyLoss(0.05)), &robust, o);
  EXPECT_GT(std::abs(plain(0) - 2.0) + std::abs(plain(1) + 0.7), 0.1);  // the outliers pull plain least squares
  EXPECT_NEAR(robust(0), 2.0, 0.02);
  EXPECT_NEAR(robust(1), -0.7, 0.02);
}

// The minimum of (a + 1)² lies outside the domain a > 0.
struct Bounded {
  using Params = Eigen::Matrix<double, 1, 1>;
  static constexpr int kNumParams = 1;
  int num_params() const { return 1; }
  double Cost(const Params& a) const { return (a(0) + 1) * (a(0) + 1); }
  void Linearize(const Params& a, Params* H, Params* g) const {
    (*H)(0) += 1;
    (*g)(0) += a(0) + 1;
  }
  bool Step(const Params& a, const Params& d, Params* out) const {
    *out = a + d;
    refused += !((*out)(0) > 0);
    return (*out)(0) > 0;
  }
  mutable int refused = 0;
};

TEST(LevenbergMarquardt, RejectedStepsRaiseTheDampingAndTheIterationLimitHolds) {
  std::vector<double> x, y;
  Samples(31, 0, &x, &y);
  // The minimum of (a + 1)² outside the domain a > 0: from a = 1 the undamped step lands on a = −1 and is refused;
  // the damping grows ×10 per refusal until a step stays inside (λ = 10: a = 1 − 2/11), and a never leaves it.
  Bounded bounded;
  Eigen::Matrix<double, 1, 1> a(1.0);
  LMOptions first;
  first.max_iterations = 1;
  MinimizeLM(bounded, &a, first);
  EXPECT_EQ(bounded.refused, 5);  // λ = 1e-4 … 1 refused
  EXPECT_NEAR(a(0), 1 - 2.0 / 11, 1e-12);
  LMOptions more;
  more.max_iterations = 50;
  MinimizeLM(bounded, &a, more);
  EXPECT_GT(a(0), 0);
  EXPECT_LT(a(0), 1 - 2.0 / 11);
  // One iteration: at most max_tries steps tried, at most one accepted.
  Eigen::Vector2d q(1.0, 0.0);
  LMOptions one;
  one.max_iterations = 1;
  ExpFit<TrivialLoss> fit1(x, y, {});
  const LMSummary s = MinimizeLM(fit1, &q, one);
  EXPECT_LE(s.iterations, 1);
  EXPECT_LE(fit1.steps, one.max_tries);
}

TEST(Lie, ExpSO3IsTheRotationAboutTheAxisAndSkewIsTheCrossProduct) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0, 1);
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d w(n(rng), n(rng), n(rng)), v(n(rng), n(rng), n(rng));
    const Eigen::Matrix3d R = ExpSO3(w);
    EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
    EXPECT_LT((R * w - w).norm(), 1e-12);  // the axis is fixed
    EXPECT_LT((R - Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()).norm(), 1e-12);
    EXPECT_LT((Skew(w) * v - w.cross(v)).norm(), 1e-12);
    Eigen::Vector3d b1, b2;
    const Eigen::Vector3d t = v.normalized();
    TangentBasis(t, &b1, &b2);
    EXPECT_NEAR(b1.dot(t), 0, 1e-12);
    EXPECT_NEAR(b2.dot(t), 0, 1e-12);
    EXPECT_NEAR(b1.dot(b2), 0, 1e-12);
    EXPECT_NEAR(b1.norm(), 1, 1e-12);
  }
  const Eigen::Vector3d tiny(1e-14, -2e-14, 3e-14);
  EXPECT_LT((ExpSO3(tiny) - (Eigen::Matrix3d::Identity() + Skew(tiny))).norm(), 1e-20);
}

TEST(RansacOptions, ValidateNamesTheEstimatorAndTheField) {
  RansacOptions ok;
  EXPECT_NO_THROW(ok.Validate("relative pose"));
  auto message = [](const RansacOptions& o) {
    try {
      o.Validate("PnP");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  RansacOptions p = ok;
  p.success_prob = 1.0;
  EXPECT_EQ(message(p).rfind("PnP: success_prob", 0), 0u) << message(p);
  RansacOptions m = ok;
  m.min_iterations = m.max_iterations + 1;
  EXPECT_NE(message(m).find("min_iterations"), std::string::npos);
  RansacOptions s = ok;
  s.max_seconds = -1;
  EXPECT_NE(message(s).find("max_seconds"), std::string::npos);
}

TEST(EstimatorOutcome, EveryOutcomeHasOneTextForm) {
  for (const auto& e : EnumTable<EstimatorOutcome>::kEntries) EXPECT_EQ(ParseEnum<EstimatorOutcome>(e.name), e.value);
  for (const auto& e : EnumTable<RansacStop>::kEntries) EXPECT_EQ(ParseEnum<RansacStop>(e.name), e.value);
  for (const auto& e : EnumTable<ScaleOutcome>::kEntries) EXPECT_EQ(ParseEnum<ScaleOutcome>(e.name), e.value);
  EXPECT_EQ(ToString(EstimatorOutcome::kWeakSupport), "weak-support");
  EXPECT_EQ(ToString(ScaleOutcome::kNoValidDepth), "no-valid-depth");
  EstimatorStatus st;
  EXPECT_FALSE(st.success());
  st.outcome = EstimatorOutcome::kOk;
  EXPECT_TRUE(st.success());
}

}  // namespace
}  // namespace freeloc::geometry
