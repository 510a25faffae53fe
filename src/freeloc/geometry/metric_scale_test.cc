#include "freeloc/geometry/metric_scale.h"

#include <gtest/gtest.h>

#include "freeloc/core/error.h"
#include "testing/synthetic_scene.h"

namespace freeloc::geometry {
namespace {

struct Case {
  testing::SyntheticScene scene;
  std::vector<Eigen::Vector2d> p1, p2;
  Rigid3d unit;  // true rotation, unit translation direction
  double true_scale;
};

Case MakeCase(uint32_t seed, double baseline = 0.5) {
  Case c{testing::MakeRoomScene(seed, baseline), {}, {}, {}, 0};
  c.scene.Correspondences(400, 0.3, seed + 1, &c.p1, &c.p2);
  c.true_scale = c.scene.query_from_ref.translation.norm();
  c.unit = c.scene.query_from_ref;
  c.unit.translation.normalize();
  return c;
}

TEST(MetricScale, ExactDepthBothMethods) {
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    const Case c = MakeCase(seed);
    ASSERT_GT(c.p1.size(), 300u);
    ScaleOptions o;
    o.method = ScaleMethod::kRobust;
    const ScaleResult r =
        EstimateMetricScale(c.p1, c.p2, c.unit, c.scene.depth_ref, c.scene.depth_query, c.scene.ref, c.scene.query, o);
    ASSERT_TRUE(r.success());
    EXPECT_NEAR(r.scale / c.true_scale, 1.0, 0.02) << seed;
    EXPECT_GT(r.num_inliers, 0.8 * r.num_candidates);
    o.method = ScaleMethod::kOfficial;
    const ScaleResult off =
        EstimateMetricScale(c.p1, c.p2, c.unit, c.scene.depth_ref, c.scene.depth_query, c.scene.ref, c.scene.query, o);
    ASSERT_TRUE(off.success());
    EXPECT_NEAR(off.scale / c.true_scale, 1.0, 0.2) << seed;  // int-truncated pixels cost accuracy
    EXPECT_EQ(off.confidence, off.num_inliers);
  }
}

TEST(MetricScale, RobustToDegradedDepthWithOutliersAndHoles) {
  int good = 0;
  for (uint32_t seed = 10; seed < 20; ++seed) {
    const Case c = MakeCase(seed, 0.8);
    const DepthMap dr = testing::DegradeDepth(c.scene.depth_ref, seed * 3, 0.0, 0.03, 0.2, 0.05);
    const DepthMap dq = testing::DegradeDepth(c.scene.depth_query, seed * 7, 0.0, 0.03, 0.2, 0.05);
    const ScaleResult r = EstimateMetricScale(c.p1, c.p2, c.unit, dr, dq, c.scene.ref, c.scene.query);
    ASSERT_TRUE(r.success());
    good += std::abs(r.scale / c.true_scale - 1) < 0.15;
  }
  EXPECT_GE(good, 9);
}

TEST(MetricScale, OfficialTieBreakKeepsFirstHypothesis) {
  // Two equal clusters of candidates: the first (in input order) wins, as in the official loop with '>'.
  Camera cam{100, 100, 50, 50, 101, 101};
  DepthMap dr(101, 101), dq(101, 101);
  std::fill(dr.data.begin(), dr.data.end(), 2.0f);
  std::fill(dq.data.begin(), dq.data.end(), 2.0f);
  // Identity rotation, t̂ = z: s = d_q − d_r, constant 0 everywhere → a single cluster.
  std::vector<Eigen::Vector2d> p = {{10, 10}, {20, 20}, {30, 30}};
  ScaleOptions o;
  o.method = ScaleMethod::kOfficial;
  const ScaleResult r =
      EstimateMetricScale(p, p, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d::UnitZ()), dr, dq, cam, cam, o);
  EXPECT_TRUE(r.success());
  EXPECT_EQ(r.scale, 0.0);
  EXPECT_EQ(r.num_inliers, 3);
}

TEST(MetricScale, NoValidDepthIsAStatus) {
  Camera cam{100, 100, 50, 50, 100, 100};
  DepthMap zero(100, 100);
  std::vector<Eigen::Vector2d> p = {{10, 10}, {20, 20}};
  const ScaleResult r = EstimateMetricScale(p, p, Rigid3d(), zero, zero, cam, cam);
  EXPECT_FALSE(r.success());
  EXPECT_EQ(r.outcome, ScaleOutcome::kNoValidDepth);
  EXPECT_THROW(EstimateMetricScale(p, {p[0]}, Rigid3d(), zero, zero, cam, cam), Error);
  EXPECT_THROW(ParseEnum<ScaleMethod>("median"), Error);
}

// A robust scale two correspondences agree on is no consensus (random matches once gave "ok" poses from a single
// agreeing point); three exact ones are enough, and the official vote keeps the benchmark's rule.
TEST(MetricScale, RobustScaleNeedsThreeAgreeingCorrespondences) {
  const Case c = MakeCase(7);
  for (size_t n : {size_t{2}, size_t{3}}) {
    const std::vector<Eigen::Vector2d> a(c.p1.begin(), c.p1.begin() + static_cast<std::ptrdiff_t>(n));
    const std::vector<Eigen::Vector2d> b(c.p2.begin(), c.p2.begin() + static_cast<std::ptrdiff_t>(n));
    ScaleOptions o;
    const ScaleResult r =
        EstimateMetricScale(a, b, c.unit, c.scene.depth_ref, c.scene.depth_query, c.scene.ref, c.scene.query, o);
    EXPECT_EQ(r.success(), n == 3) << n << ": " << ToString(r.outcome);
    if (n == 2) {
      EXPECT_EQ(r.outcome, ScaleOutcome::kNoConsensus);
    }
    o.method = ScaleMethod::kOfficial;
    EXPECT_TRUE(EstimateMetricScale(a, b, c.unit, c.scene.depth_ref, c.scene.depth_query, c.scene.ref, c.scene.query, o)
                    .success());
  }
}

TEST(MetricScale, BilinearDepth) {
  DepthMap d(2, 2);
  d.at(0, 0) = 1;
  d.at(1, 0) = 2;
  d.at(0, 1) = 3;
  d.at(1, 1) = 4;
  EXPECT_FLOAT_EQ(BilinearDepth(d, 0.5, 0.5), 2.5f);
  EXPECT_FLOAT_EQ(BilinearDepth(d, 1, 1), 4.f);
  EXPECT_EQ(BilinearDepth(d, 1.5, 0), 0.f);
  d.at(1, 1) = 0;
  EXPECT_EQ(BilinearDepth(d, 0.5, 0.5), 0.f);
}

}  // namespace
}  // namespace freeloc::geometry
