#include "freeloc/geometry/five_point.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "freeloc/geometry/polynomial.h"

namespace freeloc::geometry {
namespace {

struct Problem {
  PoseRt truth;
  Eigen::Vector3d x1[5], x2[5];
};

// Random points 1–10 m in front of both cameras, generic relative motion; t unit norm.
Problem MakeProblem(std::mt19937& rng, double baseline = 1.0, bool planar = false, bool forward = false) {
  std::uniform_real_distribution<double> u(-1, 1);
  Problem p;
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  p.truth.R = Eigen::AngleAxisd(0.3 * u(rng), axis).toRotationMatrix();
  p.truth.t = forward ? Eigen::Vector3d(0.01 * u(rng), 0.01 * u(rng), 1).normalized() * baseline
                      : Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * baseline;
  for (int i = 0; i < 5;) {
    Eigen::Vector3d X(2 * u(rng), 2 * u(rng), planar ? 5.0 + 0.5 * u(rng) * 0 : 5.5 + 4.5 * u(rng));
    if (planar) X.z() = 5.0 + 0.3 * X.x();  // a tilted plane
    const Eigen::Vector3d Y = p.truth.R * X + p.truth.t;
    if (Y.z() < 0.5) continue;
    p.x1[i] = X / X.z();
    p.x2[i] = Y / Y.z();
    ++i;
  }
  p.truth.t.normalize();
  return p;
}

double PoseDistance(const PoseRt& a, const PoseRt& b) { return (a.R - b.R).norm() + (a.t - b.t).norm(); }

TEST(Polynomial, RealRootsOfKnownPolynomials) {
  // (x−1)(x+2)(x−3.5)(x²+1)
  Poly p = PolyMul(PolyMul(PolyMul({-1, 1}, {2, 1}), {-3.5, 1}), {1, 0, 1});
  auto r = RealRoots(p);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_NEAR(r[0], -2, 1e-12);
  EXPECT_NEAR(r[1], 1, 1e-12);
  EXPECT_NEAR(r[2], 3.5, 1e-12);
  // Degree 10 with 10 close real roots.
  Poly q = {1};
  for (int k = 0; k < 10; ++k) q = PolyMul(q, {-(0.1 * k + 0.05), 1});
  r = RealRoots(q);
  ASSERT_EQ(r.size(), 10u);
  for (int k = 0; k < 10; ++k) EXPECT_NEAR(r[k], 0.1 * k + 0.05, 1e-8);
  EXPECT_TRUE(RealRoots({1, 0, 1}).empty());
}

// Every root the Sturm bisection and safeguarded Newton report is a root (residual at the rounding level of the
// polynomial's terms), none twice; seeded random degree-10 polynomials with coefficients over many magnitudes, as
// the 5-point solver's determinant produces.
TEST(Polynomial, RandomDegreeTenRootsAreRootsAndDistinct) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0, 1);
  int roots = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Poly p(11);
    for (double& c : p) c = g(rng) * std::pow(10.0, g(rng));
    const std::vector<double> r = RealRoots(p);
    roots += static_cast<int>(r.size());
    for (size_t k = 0; k < r.size(); ++k) {
      double terms = 0;
      for (size_t i = 0; i < p.size(); ++i) terms += std::abs(p[i]) * std::pow(std::abs(r[k]), static_cast<double>(i));
      ASSERT_LE(std::abs(PolyEval(p, r[k])), 1e-9 * terms) << "trial " << trial << " root " << r[k];
      if (k > 0) {
        ASSERT_GT(r[k] - r[k - 1], 1e-9 * std::max(1.0, std::abs(r[k]))) << "trial " << trial;
      }
    }
  }
  EXPECT_GT(roots, 20000);  // some real roots on average, so the checks above ran
}

// The SVD-free factorisation (Horn) gives the true pose among its four candidates, each a rotation whose [t]×R
// reproduces E up to sign; an E that is not essential (the fallback) still gives rotations.
TEST(Essential, DecompositionContainsTheTruePoseAndOnlyRotations) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 500; ++trial) {
    PoseRt truth;
    truth.R = Eigen::AngleAxisd(3 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    truth.t = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    Eigen::Matrix3d E = EssentialFromPose(truth);
    E *= (trial % 2 ? -1.0 : 1.0) * (0.1 + 10 * std::abs(u(rng)));  // any scale and sign
    PoseRt cand[4];
    DecomposeEssential(E, cand);
    double best = 1e9;
    for (const PoseRt& c : cand) {
      ASSERT_LT((c.R * c.R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
      ASSERT_NEAR(c.R.determinant(), 1.0, 1e-12);
      const Eigen::Matrix3d Ec = EssentialFromPose(c);
      const double s = Ec.norm() / E.norm();
      ASSERT_LT(std::min((Ec - s * E).norm(), (Ec + s * E).norm()), 1e-10 * Ec.norm());
      best = std::min(best, PoseDistance(c, truth));
    }
    EXPECT_LT(best, 1e-10) << "trial " << trial;
    // Not essential (singular values 1, 0.5, 0.1): rotations still, from the SVD projection.
    const Eigen::Matrix3d N = E + 0.3 * E.norm() * Eigen::Matrix3d::Identity();
    DecomposeEssential(N, cand);
    for (const PoseRt& c : cand) ASSERT_LT((c.R * c.R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  }
}

TEST(FivePoint, RecoversTruePoseOnRandomProblems) {
  std::mt19937 rng(1);
  int solved = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const Problem p = MakeProblem(rng);
    std::vector<PoseRt> poses;
    FivePointRelativePose(p.x1, p.x2, &poses);
    double best = 1e9;
    for (const auto& c : poses) best = std::min(best, PoseDistance(c, p.truth));
    solved += best < 1e-8;
  }
  // Every generic configuration is solved to 1e-8.
  EXPECT_EQ(solved, 1000);
}

TEST(FivePoint, EssentialMatricesSatisfyConstraints) {
  std::mt19937 rng(2);
  const Problem p = MakeProblem(rng);
  std::vector<Eigen::Matrix3d> es;
  const int n = FivePointEssential(p.x1, p.x2, &es);
  ASSERT_GT(n, 0);
  EXPECT_LE(n, 10);
  for (const auto& E : es) {
    for (int i = 0; i < 5; ++i) EXPECT_NEAR(p.x2[i].dot(E * p.x1[i]), 0, 1e-10);
    EXPECT_NEAR(E.determinant(), 0, 1e-10);
    const Eigen::Matrix3d c = 2 * E * E.transpose() * E - (E * E.transpose()).trace() * E;
    EXPECT_LT(c.norm(), 1e-9);
  }
}

TEST(FivePoint, NearDegenerateConfigurationsStayFinite) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    for (int kind = 0; kind < 3; ++kind) {
      const Problem p = kind == 0   ? MakeProblem(rng, 1e-4)
                        : kind == 1 ? MakeProblem(rng, 1.0, true)
                                    : MakeProblem(rng, 1.0, false, true);
      std::vector<PoseRt> poses;
      FivePointRelativePose(p.x1, p.x2, &poses);
      for (const auto& c : poses) {
        ASSERT_TRUE(c.R.allFinite());
        ASSERT_TRUE(c.t.allFinite());
      }
    }
  }
  // All five points identical: no solution, no NaN.
  Eigen::Vector3d same[5];
  for (auto& v : same) v = {0.1, 0.2, 1};
  std::vector<PoseRt> poses;
  FivePointRelativePose(same, same, &poses);
  for (const auto& c : poses) EXPECT_TRUE(c.R.allFinite() && c.t.allFinite());
}

TEST(FivePoint, PlanarAndForwardStillContainTruth) {
  std::mt19937 rng(4);
  int ok_planar = 0, ok_forward = 0;
  for (int trial = 0; trial < 200; ++trial) {
    for (int kind = 0; kind < 2; ++kind) {
      const Problem p = MakeProblem(rng, 1.0, kind == 0, kind == 1);
      std::vector<PoseRt> poses;
      FivePointRelativePose(p.x1, p.x2, &poses);
      double best = 1e9;
      for (const auto& c : poses) best = std::min(best, PoseDistance(c, p.truth));
      (kind == 0 ? ok_planar : ok_forward) += best < 1e-6;
    }
  }
  EXPECT_GE(ok_planar, 190);
  EXPECT_GE(ok_forward, 190);
}

}  // namespace
}  // namespace freeloc::geometry
