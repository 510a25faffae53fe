#include "freeloc/geometry/absolute_pose.h"

#include <gtest/gtest.h>

#include <random>

#include "freeloc/core/error.h"
#include "freeloc/geometry/p3p.h"
#include "testing/synthetic_scene.h"

namespace freeloc::geometry {
namespace {

TEST(P3P, RecoversPoseOnRandomProblems) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int ok = 0;
  for (int trial = 0; trial < 500; ++trial) {
    PoseRt truth;
    truth.R = Eigen::AngleAxisd(u(rng) * 3, Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    truth.t = Eigen::Vector3d(u(rng), u(rng), u(rng));
    Eigen::Vector3d X[3], b[3];
    for (int i = 0; i < 3;) {
      const Eigen::Vector3d Yc(2 * u(rng), 2 * u(rng), 3 + 2 * u(rng));  // in camera
      X[i] = truth.R.transpose() * (Yc - truth.t);
      b[i] = Yc;
      ++i;
    }
    std::vector<PoseRt> poses;
    P3P(X, b, &poses);
    double best = 1e9;
    for (const auto& p : poses) best = std::min(best, (p.R - truth.R).norm() + (p.t - truth.t).norm());
    ok += best < 1e-6;
  }
  EXPECT_GE(ok, 495);
}

TEST(RigidAlign, ExactOnNoiseFreePoints) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1, 1);
  PoseRt truth;
  truth.R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  truth.t = {0.3, -1, 2};
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 10; ++i) {
    a.emplace_back(u(rng), u(rng), u(rng));
    b.push_back(truth.R * a.back() + truth.t);
  }
  const PoseRt p = RigidAlign(a, b);
  EXPECT_LT((p.R - truth.R).norm(), 1e-12);
  EXPECT_LT((p.t - truth.t).norm(), 1e-12);
}

struct Case {
  testing::SyntheticScene s;
  std::vector<Eigen::Vector2d> p1, p2;
};

Case MakeCase(uint32_t seed, double outliers) {
  Case c{testing::MakeRoomScene(seed, 0.6, 320, 240), {}, {}};
  c.s.Correspondences(500, 0.5, seed, &c.p1, &c.p2);
  std::mt19937 rng(seed + 99);
  std::uniform_real_distribution<double> ux(0, 319), uy(0, 239);
  const int n_out = static_cast<int>(outliers * c.p1.size());
  for (int i = 0; i < n_out; ++i) c.p2[i] = {ux(rng), uy(rng)};
  return c;
}

TEST(PnP, RecoversMetricPoseWithOutliers) {
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    const Case c = MakeCase(seed, 0.5);
    const MetricPoseResult r = EstimatePnP(c.p1, c.p2, c.s.depth_ref, c.s.ref, c.s.query);
    ASSERT_TRUE(r.status.success()) << ToString(r.status.outcome);
    EXPECT_LT(RotationAngleDeg(r.query_from_ref.rotation, c.s.query_from_ref.rotation), 0.5);
    EXPECT_LT((r.query_from_ref.Center() - c.s.query_from_ref.Center()).norm(), 0.03);
    EXPECT_EQ(r.confidence, r.status.num_inliers);
    EXPECT_GT(r.status.num_inliers, 200);
  }
}

TEST(Procrustes, RecoversMetricPoseWithOutliers) {
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    const Case c = MakeCase(seed, 0.5);
    const MetricPoseResult r = EstimateProcrustes(c.p1, c.p2, c.s.depth_ref, c.s.depth_query, c.s.ref, c.s.query);
    ASSERT_TRUE(r.status.success()) << ToString(r.status.outcome);
    EXPECT_LT(RotationAngleDeg(r.query_from_ref.rotation, c.s.query_from_ref.rotation), 0.5);
    EXPECT_LT((r.query_from_ref.Center() - c.s.query_from_ref.Center()).norm(), 0.03);
  }
}

TEST(PnP, FailureRules) {
  const Case c = MakeCase(7, 0.0);
  // Only 5 points: fewer than the 6 inliers the official rules require.
  std::vector<Eigen::Vector2d> a(c.p1.begin(), c.p1.begin() + 5), b(c.p2.begin(), c.p2.begin() + 5);
  const MetricPoseResult r = EstimatePnP(a, b, c.s.depth_ref, c.s.ref, c.s.query);
  EXPECT_FALSE(r.status.success());
  DepthMap none(320, 240);
  EXPECT_EQ(EstimatePnP(c.p1, c.p2, none, c.s.ref, c.s.query).status.outcome, EstimatorOutcome::kTooFewMatches);
  EXPECT_EQ(EstimateProcrustes(c.p1, c.p2, none, none, c.s.ref, c.s.query).status.outcome,
            EstimatorOutcome::kTooFewMatches);
  EXPECT_THROW(EstimatePnP(c.p1, a, c.s.depth_ref, c.s.ref, c.s.query), Error);
}

}  // namespace
}  // namespace freeloc::geometry
