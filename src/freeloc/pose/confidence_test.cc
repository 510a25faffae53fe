#include "freeloc/pose/confidence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "testing/confidence_study.h"

namespace freeloc::pose {
namespace {

PoseEvidence Typical() {
  PoseEvidence e;
  e.matches = 500;
  e.inliers = 400;
  e.residual_px = 1.0;
  e.focal_px = 500;
  e.mean_depth_m = 3;
  e.scale_candidates = 380;
  e.scale_inliers = 300;
  e.scale_std_error_m = 0.01;
  return e;
}

TEST(Confidence, PredictedErrorFollowsTheEvidence) {
  const PredictedError base = PredictPoseError(Typical());
  // σ = 1/500 rad, n = 400: R ≈ 0.1 mrad / agreement; t from the direction ≈ 0.3 mm, the scale 1 cm dominates.
  const double agree = std::sqrt(0.8 * 300.0 / 380.0) * (400.0 / 430.0);  // × the support term n / (n + 30)
  EXPECT_NEAR(base.rotation_deg, (1.0 / 500 / 20) * 180 / M_PI / agree, 1e-12);
  EXPECT_NEAR(base.translation_m, std::hypot(1.0 / 500 * 3 / 20, 0.01) / agree, 1e-12);
  auto worse = [&](auto change) {
    PoseEvidence e = Typical();
    change(e);
    const PredictedError p = PredictPoseError(e);
    return ConfidenceFromPredictedError(p) < ConfidenceFromPredictedError(base);
  };
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.inliers = 40; }));
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.inliers = 40, e.matches = 50; }));  // few inliers, even if most agree
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.residual_px = 3; }));
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.scale_std_error_m = 0.05; }));
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.matches = 2000; }));      // a lower inlier ratio
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.scale_inliers = 60; }));  // a split scale vote
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.mean_depth_m = 30; }));   // farther points: a direction error costs more
  // Degenerate evidence stays finite and positive.
  const double c = ConfidenceFromPredictedError(PredictPoseError(PoseEvidence{}));
  EXPECT_TRUE(std::isfinite(c));
  EXPECT_GT(c, 0);
}

// Weak-support answers rank below every supported one — even one predicted hundreds of metres off — and above the
// prior (0), keeping their own order.
TEST(Confidence, WeakSupportRanksBelowEverySupportedAnswer) {
  const double worst_ok = ConfidenceFromPredictedError({1e6, 1e6});
  double previous = 0;
  for (double c : {0.0, 1e-6, 0.01, 1.0, 10.0, 1e3, 1e9, std::numeric_limits<double>::infinity()}) {
    const double w = WeakSupportConfidence(c);
    EXPECT_GT(w, 0) << c;
    EXPECT_LT(w, worst_ok) << c;
    EXPECT_GE(w, previous) << c;
    previous = w;
  }
  EXPECT_GT(WeakSupportConfidence(10), WeakSupportConfidence(1));
}

// A runner-up that stayed plausible puts its distance under the predicted error; one ruled out adds nothing.
TEST(Confidence, PlausibleRunnerUpLowersTheConfidence) {
  PoseEvidence e = Typical();
  const double alone = ConfidenceFromPredictedError(PredictPoseError(e));
  e.rival_rotation_deg = 17;
  e.rival_translation_m = 1.5;
  e.rival_plausibility = 0.2;  // ruled out
  EXPECT_DOUBLE_EQ(ConfidenceFromPredictedError(PredictPoseError(e)), alone);
  e.rival_plausibility = 0.95;  // nearly as likely: the answer is that uncertain
  const PredictedError p = PredictPoseError(e);
  EXPECT_GT(p.rotation_deg, 0.8 * 17);
  EXPECT_GT(p.translation_m, 0.8 * 1.5);
  EXPECT_LT(ConfidenceFromPredictedError(p), alone / 10);
}

// The seeded synthetic population of the study (bench/confidence runs it larger; its default seed 1 is the one the
// model was tuned on, this one is held out): for every solver, ranking by freeloc's confidence gives a higher
// map-free pose AUC than ranking by the raw inlier count — the inlier count cannot see a bad scale — and a VCRE AUC
// as high (within one query's share: a single VCRE failure decides it on 100 queries).
TEST(Confidence, RanksBetterThanTheInlierCountOnSyntheticQueries) {
  for (const char* solver : {"essential", "hybrid", "pnp", "procrustes"}) {
    std::vector<testing::StudyQuery> all;  // degraded and monocular-like depth: where the ranking matters
    for (int i = 0; i < 150; ++i)
      if (i % 3 != 0) all.push_back(testing::RunStudyQuery(2, i, 640, 480, solver));
    const auto ours = testing::ScoreStudy(all, testing::StudyConfidence::kFreeloc);
    const auto inl = testing::ScoreStudy(all, testing::StudyConfidence::kInlierCount);
    const auto oracle = testing::ScoreStudy(all, testing::StudyConfidence::kOracle);
    std::printf(
        "%s, %zu queries: AUC pose %.4f (inliers %.4f, oracle %.4f), AUC VCRE %.4f (inliers %.4f, oracle "
        "%.4f)\n",
        solver, all.size(), ours.auc_pose, inl.auc_pose, oracle.auc_pose, ours.auc_vcre, inl.auc_vcre, oracle.auc_vcre);
    ASSERT_GE(ours.estimates, static_cast<int>(all.size()) * 85 / 100) << solver;
    ASSERT_LT(ours.precision_pose, 1.0) << solver;  // some estimates are wrong: there is something to rank
    EXPECT_GT(ours.auc_pose, inl.auc_pose) << solver;
    EXPECT_GE(ours.auc_vcre, inl.auc_vcre - 1.0 / all.size()) << solver;
    EXPECT_LE(ours.auc_pose, oracle.auc_pose + 1e-9) << solver;
  }
}

}  // namespace
}  // namespace freeloc::pose
