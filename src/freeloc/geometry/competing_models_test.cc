// Competing models (competing_models.h) and weak support (relative_pose.h) on seeded synthetic pairs: a
// plane-dominated view whose twin must be rejected with depth and flagged without, a flat valley of near-equal
// support that depth resolves, and weak support returned as "weak-support" with its pose.
#include "freeloc/geometry/competing_models.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "freeloc/geometry/relative_pose.h"

namespace freeloc::geometry {
namespace {

struct PlanarPair {
  Rigid3d truth;                        // query_from_ref
  std::vector<Eigen::Vector2d> p1, p2;  // reference and query pixels
  DepthSamples depth;                   // exact
  const Camera ref{500, 500, 320, 240, 640, 480};
  const Camera query = ref;
};

// A textured wall 3–5 m away filling the view (all of `n` points on it, `off_plane` of them up to 0.3 m in front),
// seen from two cameras 0.4–1 m apart with a rotation of ≤ 10°, 0.5 px noise. A plane's 5-point problem has two
// answers that explain its matches alike (the homography's two decompositions).
PlanarPair MakePlanarPair(uint32_t seed, int n, double off_plane_fraction) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> g(0, 0.5);
  PlanarPair pp;
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.17 * u(rng), axis));
  const Eigen::Vector3d centre =
      Eigen::Vector3d(u(rng), 0.3 * u(rng), 0.3 * u(rng)).normalized() * (0.7 + 0.3 * u(rng));
  pp.truth = Rigid3d(q, -(q * centre));
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3 * u(rng), 0.3 * u(rng), -1).normalized();
  const double dist = 4 + u(rng);
  while (static_cast<int>(pp.p1.size()) < n) {
    const Eigen::Vector2d a(320 + 310 * u(rng), 240 + 230 * u(rng));
    const Eigen::Vector3d ray = pp.ref.Unproject(a.x(), a.y());
    double z = dist / std::abs(normal.dot(ray));  // the ray meets the wall
    if (0.5 + 0.5 * u(rng) < off_plane_fraction) z -= 0.3 * (0.5 + 0.5 * u(rng));
    const Eigen::Vector3d X = ray * z;
    const Eigen::Vector3d Y = pp.truth * X;
    if (Y.z() < 0.5) continue;
    const Eigen::Vector2d b = pp.query.Project(Y);
    if (b.x() < 0 || b.y() < 0 || b.x() > 640 || b.y() > 480) continue;
    pp.p1.push_back(a + Eigen::Vector2d(g(rng), g(rng)));
    pp.p2.push_back(b + Eigen::Vector2d(g(rng), g(rng)));
    pp.depth.ref.push_back(X.z());
    pp.depth.query.push_back(Y.z());
  }
  return pp;
}

double Err(const Rigid3d& a, const Rigid3d& b) { return RotationAngleDeg(a.rotation, b.rotation); }

// The twin of a planar configuration: depth tells it apart (the truth is returned); without depth a returned
// twin is never left unflagged — its runner-up (the truth) stays plausible.
TEST(CompetingModels, PlanarTwinRejectedWithDepthAndFlaggedWithout) {
  int twins_seen = 0, resolved_with_depth = 0, wrong_without_depth = 0, wrong_unflagged = 0;
  for (uint32_t seed = 100; seed < 130; ++seed) {
    const PlanarPair pp = MakePlanarPair(seed, 150, 0.0);
    RelativePoseOptions o;
    o.threshold_px = 2.0;
    o.ransac.seed = seed;
    const RelativePoseResult nd = EstimateRelativePose(pp.p1, pp.p2, pp.ref, pp.query, o);
    const RelativePoseResult wd = EstimateRelativePose(pp.p1, pp.p2, pp.ref, pp.query, o, pp.depth);
    SCOPED_TRACE(seed);
    ASSERT_FALSE(nd.query_from_ref.translation.hasNaN());
    if (wd.status.competitors > 0 || nd.status.competitors > 0) ++twins_seen;
    // With exact depth: the truth, every time.
    ASSERT_TRUE(wd.status.outcome == EstimatorOutcome::kOk || wd.status.outcome == EstimatorOutcome::kWeakSupport)
        << ToString(wd.status.outcome);
    EXPECT_LT(Err(wd.query_from_ref, pp.truth), 1.0) << "decided by " << ToString(wd.status.decided_by);
    resolved_with_depth += Err(wd.query_from_ref, pp.truth) < 1.0 && wd.status.competitors > 0;
    // Without depth: a wrong answer must carry a plausible runner-up near the truth.
    if (nd.status.outcome != EstimatorOutcome::kOk && nd.status.outcome != EstimatorOutcome::kWeakSupport) continue;
    if (Err(nd.query_from_ref, pp.truth) > 1.0) {
      ++wrong_without_depth;
      const bool flagged =
          nd.status.competitors > 0 && nd.status.runner_up_plausibility > 0.5 && Err(nd.runner_up, pp.truth) < 1.0;
      wrong_unflagged += !flagged;
    }
  }
  std::printf(
      "planar pairs: %d with a competing model, %d resolved by depth; without depth %d wrong twins, %d "
      "unflagged\n",
      twins_seen, resolved_with_depth, wrong_without_depth, wrong_unflagged);
  EXPECT_GE(twins_seen, 20);  // a plane gives a twin nearly always: the search must find it
  EXPECT_EQ(wrong_unflagged, 0);
}

// Off-plane points break the tie: the truth explains them, the twin does not — chosen without depth too.
TEST(CompetingModels, OffPlanePointsDecideWithoutDepth) {
  int right = 0;
  for (uint32_t seed = 200; seed < 215; ++seed) {
    const PlanarPair pp = MakePlanarPair(seed, 200, 0.3);
    RelativePoseOptions o;
    o.threshold_px = 2.0;
    const RelativePoseResult r = EstimateRelativePose(pp.p1, pp.p2, pp.ref, pp.query, o);
    ASSERT_TRUE(r.status.success()) << ToString(r.status.outcome);
    right += Err(r.query_from_ref, pp.truth) < 1.0;
  }
  EXPECT_EQ(right, 15);
}

TEST(CompetingModels, EvidenceOfTheTruthBeatsTheTwin) {
  const PlanarPair pp = MakePlanarPair(7, 200, 0.0);
  const PoseRt truth{pp.truth.R(), pp.truth.translation.normalized()};
  std::vector<int> all(pp.p1.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  std::vector<Eigen::Vector3d> x1, x2;
  for (size_t i = 0; i < pp.p1.size(); ++i) {
    x1.push_back(pp.ref.Unproject(pp.p1[i].x(), pp.p1[i].y()));
    x2.push_back(pp.query.Unproject(pp.p2[i].x(), pp.p2[i].y()));
  }
  const double th = 2.0 / 500;
  const auto rivals = FindCompetingRelativeModels(x1, x2, truth, all, th * th, th, 1);
  ASSERT_FALSE(rivals.empty()) << "the planar twin was not found";
  const ModelEvidence et = EvaluateRelativeModel(x1, x2, truth, th * th, pp.depth, 1.0 / 500);
  const ModelEvidence ew = EvaluateRelativeModel(x1, x2, rivals[0].pose, th * th, pp.depth, 1.0 / 500);
  EXPECT_GT(rivals[0].inliers, 0.7 * et.inliers);  // near-equal support: the matches cannot tell
  EXPECT_TRUE(DistinctModels(truth, rivals[0].pose));
  EXPECT_GT(et.depth_reprojection_inliers, 1.1 * ew.depth_reprojection_inliers + 2);  // the depths can
  EXPECT_GE(et.depth_reprojection_inliers, 0.9 * et.depth_samples);
}

// Weak support: few inliers among many matches fail the chance tests, but a real model is an answer —
// "weak-support" with its pose — never the prior; random matches stay "no-consensus".
TEST(WeakSupport, RealButWeakModelIsReturnedRandomIsNot) {
  int weak = 0, ok = 0, close = 0, random_models = 0;
  for (uint32_t seed = 300; seed < 320; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    const PlanarPair base = MakePlanarPair(seed, 18, 0.5);
    std::vector<Eigen::Vector2d> p1 = base.p1, p2 = base.p2;
    for (int k = 0; k < 42; ++k) {  // 18 inliers of 60
      p1.emplace_back(320 + 310 * u(rng), 240 + 230 * u(rng));
      p2.emplace_back(320 + 310 * u(rng), 240 + 230 * u(rng));
    }
    RelativePoseOptions o;
    o.threshold_px = 2.0;
    o.ransac.max_seconds = 0.25;  // random sets search to the budget; keep the test short
    const RelativePoseResult r = EstimateRelativePose(p1, p2, base.ref, base.query, o);
    if (r.status.outcome == EstimatorOutcome::kWeakSupport) {
      ++weak;
      EXPECT_FALSE(r.status.success());
      close += Err(r.query_from_ref, base.truth) < 5.0;
    }
    ok += r.status.outcome == EstimatorOutcome::kOk;
    // The same number of random matches.
    std::vector<Eigen::Vector2d> q1, q2;
    for (int k = 0; k < 60; ++k) {
      q1.emplace_back(320 + 310 * u(rng), 240 + 230 * u(rng));
      q2.emplace_back(320 + 310 * u(rng), 240 + 230 * u(rng));
    }
    const RelativePoseResult rr = EstimateRelativePose(q1, q2, base.ref, base.query, o);
    EXPECT_NE(rr.status.outcome, EstimatorOutcome::kOk);
    random_models += rr.status.outcome == EstimatorOutcome::kWeakSupport;
  }
  std::printf("18 of 60: %d ok, %d weak-support (%d within 5°); random 60: %d weak-support of 20\n", ok, weak, close,
              random_models);
  EXPECT_GE(weak + ok, 16);  // the real model is answered, not dropped to the prior
  EXPECT_GE(close, weak * 3 / 4);
  EXPECT_LE(random_models, 4);  // chance-level support is no model
}

}  // namespace
}  // namespace freeloc::geometry
