// The hybrid depth-aware estimator (hybrid_pose.h) on seeded synthetic two-view data with depth: exact recovery,
// metric translation from the reference depth with a wrongly scaled query depth, noise + outliers, shifts,
// cheirality, random matches, no depth.
#include "freeloc/geometry/hybrid_pose.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>

namespace freeloc::geometry {
namespace {

struct DepthView {
  Camera ref{600, 600, 320, 240, 640, 480}, query{580, 585, 330, 235, 640, 480};
  Rigid3d truth;  // metric
  std::vector<Eigen::Vector2d> p1, p2;
  std::vector<double> d1, d2;  // true z-depths (outliers: a depth of their own)
};

DepthView MakeDepthView(uint32_t seed, int n, double outliers, double noise_px, double baseline = 0.8) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
  std::normal_distribution<double> g(0, noise_px);
  DepthView v;
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.25 * u(rng), axis));
  v.truth = Rigid3d(q, baseline * Eigen::Vector3d(u(rng), 0.3 * u(rng), 0.3 * u(rng)).normalized());
  while (static_cast<int>(v.p1.size()) < n) {
    Eigen::Vector2d a(320 + 320 * u(rng), 240 + 240 * u(rng));
    const double depth = 1.5 + 5 * u01(rng);
    const Eigen::Vector3d X = v.ref.Unproject(a.x(), a.y()) * depth;
    const Eigen::Vector3d Y = v.truth * X;
    if (Y.z() < 0.3) continue;
    Eigen::Vector2d b = v.query.Project(Y);
    if (b.x() < 0 || b.y() < 0 || b.x() > 640 || b.y() > 480) continue;
    if (u01(rng) < outliers) {
      v.p1.push_back(a);
      v.p2.push_back({320 + 320 * u(rng), 240 + 240 * u(rng)});
      v.d1.push_back(depth);
      v.d2.push_back(1.5 + 5 * u01(rng));
      continue;
    }
    v.p1.push_back(a + Eigen::Vector2d(g(rng), g(rng)));
    v.p2.push_back(b + Eigen::Vector2d(g(rng), g(rng)));
    v.d1.push_back(depth);
    v.d2.push_back(Y.z());
  }
  return v;
}

double RotErrDeg(const Eigen::Matrix3d& R, const Rigid3d& truth) {
  return Eigen::AngleAxisd(R.transpose() * truth.R()).angle() * 180 / M_PI;
}

TEST(HybridPose, ExactDataGiveTheExactMetricPose) {
  const DepthView v = MakeDepthView(1, 150, 0.0, 0.0);
  const HybridPoseResult r = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query);
  ASSERT_TRUE(r.status.success()) << ToString(r.status.outcome);
  EXPECT_LT(RotErrDeg(r.model.R, v.truth), 1e-5);
  EXPECT_LT((r.model.t - v.truth.translation).norm(), 1e-6);
  EXPECT_NEAR(r.model.scale, 1.0, 1e-6);
  EXPECT_EQ(r.status.num_inliers, 150);
  EXPECT_EQ(r.depth_inliers, 150);
  EXPECT_GT(r.samples_3pt + r.samples_5pt, 0);
}

TEST(HybridPose, ReferenceDepthAnchorsTheScaleWhenTheQueryDepthIsOff) {
  for (uint32_t seed = 2; seed < 7; ++seed) {
    DepthView v = MakeDepthView(seed, 300, 0.3, 0.5);
    for (double& d : v.d2) d *= 1.4;  // the query's depth map is 40 % too far
    const HybridPoseResult r = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query);
    ASSERT_TRUE(r.status.success()) << seed << " " << ToString(r.status.outcome);
    EXPECT_LT(RotErrDeg(r.model.R, v.truth), 0.3) << seed;
    EXPECT_LT((r.model.t - v.truth.translation).norm(), 0.02) << seed;  // metres, |t| = 0.8 m
    EXPECT_NEAR(r.model.scale, 1 / 1.4, 0.02) << seed;
    EXPECT_GT(r.status.num_inliers, 180) << seed;
    EXPECT_LT(r.status.num_inliers, 240) << seed;  // 30 % outliers are not inliers (a few fall in by chance)
  }
}

TEST(HybridPose, FinalRefinementReducesTheError) {
  double before = 0, after = 0;
  for (uint32_t seed = 30; seed < 36; ++seed) {
    const DepthView v = MakeDepthView(seed, 300, 0.2, 1.0);
    HybridPoseOptions o;
    o.refinement_iterations = 0;
    const HybridPoseResult r0 = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query, o);
    o.refinement_iterations = 30;
    const HybridPoseResult r1 = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query, o);
    ASSERT_TRUE(r0.status.success() && r1.status.success()) << seed;
    before += (r0.model.t - v.truth.translation).norm() + 0.01 * RotErrDeg(r0.model.R, v.truth);
    after += (r1.model.t - v.truth.translation).norm() + 0.01 * RotErrDeg(r1.model.R, v.truth);
    EXPECT_LT(RotErrDeg(r1.model.R, v.truth), 0.3) << seed;
  }
  EXPECT_LT(after, before);
}

TEST(HybridPose, ShiftedDepthsWithTheShiftSolver) {
  DepthView v = MakeDepthView(8, 300, 0.2, 0.3);
  for (double& d : v.d1) d -= 0.3;  // reference depth 0.3 m short
  for (double& d : v.d2) d = 0.7 * d + 0.5;
  HybridPoseOptions o;
  o.shifts = true;
  const HybridPoseResult r = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query, o);
  ASSERT_TRUE(r.status.success()) << ToString(r.status.outcome);
  EXPECT_LT(RotErrDeg(r.model.R, v.truth), 0.2);
  EXPECT_LT((r.model.t - v.truth.translation).norm(), 0.02);
  EXPECT_NEAR(r.model.shift_ref, 0.3, 0.03);
  EXPECT_NEAR(r.model.scale, 1 / 0.7, 0.03);
}

TEST(HybridPose, PointsBehindTheCamerasAreNotInliers) {
  DepthView v = MakeDepthView(9, 200, 0.0, 0.0);
  // 40 twisted matches: points behind both cameras project to valid pixels and satisfy the epipolar constraint.
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> u(-1, 1);
  int added = 0;
  while (added < 40) {
    const Eigen::Vector3d X(u(rng), u(rng), -2 - 2 * u(rng) * u(rng));
    const Eigen::Vector3d Y = v.truth * X;
    if (Y.z() > -0.3) continue;
    const Eigen::Vector2d a = v.ref.Project(X), b = v.query.Project(Y);
    if (a.x() < 0 || a.y() < 0 || a.x() > 640 || a.y() > 480 || b.x() < 0 || b.y() < 0 || b.x() > 640 || b.y() > 480)
      continue;
    v.p1.push_back(a);
    v.p2.push_back(b);
    v.d1.push_back(-X.z());
    v.d2.push_back(-Y.z());
    ++added;
  }
  const HybridPoseResult r = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query);
  ASSERT_TRUE(r.status.success()) << ToString(r.status.outcome);
  EXPECT_LT((r.model.t - v.truth.translation).norm(), 1e-4);
  for (size_t i = 200; i < v.p1.size(); ++i) EXPECT_FALSE(r.inliers[i]) << i;
  EXPECT_EQ(r.status.num_inliers, 200);
}

// `n` unrelated matches over a 640×480 pair, each with its own random depths (1–8 m).
DepthView RandomMatches(uint32_t seed, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0, 640), uy(0, 480), ud(1, 8);
  DepthView v;
  v.query = v.ref;
  for (int i = 0; i < n; ++i) {
    v.p1.emplace_back(ux(rng), uy(rng));
    v.p2.emplace_back(ux(rng), uy(rng));
    v.d1.push_back(ud(rng));
    v.d2.push_back(ud(rng));
  }
  return v;
}

TEST(HybridPose, RandomMatchesAreNoConsensus) {
  const DepthView v = RandomMatches(5, 200);
  const HybridPoseResult r = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query);
  EXPECT_FALSE(r.status.success());
  EXPECT_EQ(r.status.outcome, EstimatorOutcome::kNoConsensus);
}

// A dense set of random matches with random depths: the sequential test drops every hypothesis after a few data
// and the search gives up after the samples that would have found a model holding a fifth of them.
TEST(HybridPose, RandomDenseSetsGiveUpQuickly) {
  const DepthView v = RandomMatches(8, 40000);
  const HybridPoseResult r = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query);
  EXPECT_EQ(r.status.outcome, EstimatorOutcome::kNoConsensus);
  EXPECT_TRUE(r.status.stop == RansacStop::kGaveUp || r.status.stop == RansacStop::kNoModel) << ToString(r.status.stop);
  // Both families together meet the give-up requirement: well under the 10 000-sample cap the search ran to before.
  EXPECT_LT(r.samples_3pt + r.samples_5pt, 3000);
}

TEST(HybridPose, DenseSetsGiveThePlainSearchsAnswer) {
  const DepthView v = MakeDepthView(61, 20000, 0.5, 0.5);
  HybridPoseOptions dense, plain;
  plain.ransac.sprt_min_data = 0;
  const HybridPoseResult a = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query, dense);
  const HybridPoseResult b = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query, plain);
  ASSERT_TRUE(a.status.success()) << ToString(a.status.outcome);
  ASSERT_TRUE(b.status.success()) << ToString(b.status.outcome);
  EXPECT_LT(RotErrDeg(a.model.R, v.truth), 0.05);
  EXPECT_LT(Eigen::AngleAxisd(a.model.R.transpose() * b.model.R).angle() * 180 / M_PI, 0.01);
  EXPECT_NEAR(a.model.t.norm(), v.truth.translation.norm(), 0.01 * v.truth.translation.norm());
  EXPECT_NEAR(a.model.t.norm(), b.model.t.norm(), 0.002 * b.model.t.norm());
  EXPECT_NEAR(a.status.num_inliers, b.status.num_inliers, 0.005 * b.status.num_inliers);
}

TEST(HybridPose, WithoutDepthThereIsNoMetricModel) {
  const DepthView v = MakeDepthView(10, 100, 0.0, 0.3);
  const std::vector<double> none(v.p1.size(), 0.0);
  const HybridPoseResult r = EstimateHybridPose(v.p1, v.p2, none, none, v.ref, v.query);
  EXPECT_FALSE(r.status.success());
  EXPECT_EQ(r.depth_candidates, 0);
  EXPECT_EQ(r.depth_inliers, 0);
  EXPECT_EQ(r.samples_3pt, 0);
}

// Hostile depth values (NaN, ±inf, negative, absurdly large) and duplicated matches: no crash, no non-finite pose,
// never an ok status without support.
TEST(HybridPose, HostileDepthsAndDuplicatesStayFiniteAndSafe) {
  DepthView v = MakeDepthView(40, 200, 0.1, 0.5);
  const double bad[] = {
      std::nan(""), std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(), -3.0, 0.0, 1e300,
      1e-300};
  for (size_t i = 0; i < v.d1.size(); i += 3) v.d1[i] = bad[i % 7];
  for (size_t i = 1; i < v.d2.size(); i += 3) v.d2[i] = bad[(i + 2) % 7];
  HybridPoseResult r = EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query);
  ASSERT_TRUE(r.status.success()) << ToString(r.status.outcome);  // a third of each map broken: still a metric pose
  EXPECT_TRUE(r.model.R.allFinite() && r.model.t.allFinite() && std::isfinite(r.model.scale));
  EXPECT_LT((r.model.t - v.truth.translation).norm(), 0.05);
  // One match repeated 50 times: no geometry.
  std::vector<Eigen::Vector2d> a(50, v.p1[0]), b(50, v.p2[0]);
  std::vector<double> da(50, 3.0), db(50, 3.0);
  r = EstimateHybridPose(a, b, da, db, v.ref, v.query);
  EXPECT_FALSE(r.status.success());
  // Every depth broken.
  std::vector<double> nan(v.p1.size(), std::nan(""));
  r = EstimateHybridPose(v.p1, v.p2, nan, nan, v.ref, v.query);
  EXPECT_FALSE(r.status.success());
  EXPECT_EQ(r.depth_candidates, 0);
}

TEST(HybridPose, TooFewMatchesAndBadInputs) {
  const DepthView v = MakeDepthView(11, 8, 0.0, 0.0);
  EXPECT_EQ(EstimateHybridPose(v.p1, v.p2, v.d1, v.d2, v.ref, v.query).status.outcome,
            EstimatorOutcome::kTooFewMatches);
  std::vector<double> short_depth(3, 1.0);
  EXPECT_ANY_THROW(EstimateHybridPose(v.p1, v.p2, short_depth, v.d2, v.ref, v.query));
  HybridPoseOptions o;
  o.reprojection_px = 0;
  EXPECT_ANY_THROW(o.Validate());
}

}  // namespace
}  // namespace freeloc::geometry
