#include "freeloc/pipeline/confidence.h"

#include <gtest/gtest.h>

#include "testing/confidence_study.h"

namespace freeloc::pipeline {
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
  const double agree = std::sqrt(0.8 * 300.0 / 380.0);
  EXPECT_NEAR(base.rotation_deg, (1.0 / 500 / 20) * 180 / M_PI / agree, 1e-12);
  EXPECT_NEAR(base.translation_m, std::hypot(1.0 / 500 * 3 / 20, 0.01) / agree, 1e-12);
  auto worse = [&](auto change) {
    PoseEvidence e = Typical();
    change(e);
    const PredictedError p = PredictPoseError(e);
    return ConfidenceFromPredictedError(p) < ConfidenceFromPredictedError(base);
  };
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.inliers = 40; }));
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.residual_px = 3; }));
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.scale_std_error_m = 0.05; }));
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.matches = 2000; }));       // a lower inlier ratio
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.scale_inliers = 60; }));   // a split scale vote
  EXPECT_TRUE(worse([](PoseEvidence& e) { e.mean_depth_m = 30; }));  // farther points: a direction error costs more
  // Degenerate evidence stays finite and positive.
  const double c = ConfidenceFromPredictedError(PredictPoseError(PoseEvidence{}));
  EXPECT_TRUE(std::isfinite(c));
  EXPECT_GT(c, 0);
}

// The seeded synthetic population of the study (bench/confidence runs it larger): ranking by freeloc's confidence
// gives higher map-free AUCs than ranking by the raw inlier count, most of all with degraded depth, where the
// inlier count cannot see a bad scale.
TEST(Confidence, RanksBetterThanTheInlierCountOnSyntheticQueries) {
  std::vector<testing::StudyQuery> all, degraded;
  for (int i = 0; i < 120; ++i) {
    all.push_back(testing::RunStudyQuery(2, i, 640, 480));
    if (!all.back().exact_depth) degraded.push_back(all.back());
  }
  for (const auto* qs : {&all, &degraded}) {
    const auto ours = testing::ScoreStudy(*qs, testing::StudyConfidence::kFreeloc);
    const auto inl = testing::ScoreStudy(*qs, testing::StudyConfidence::kInlierCount);
    const auto oracle = testing::ScoreStudy(*qs, testing::StudyConfidence::kOracle);
    std::printf("%zu queries: AUC pose %.4f (inliers %.4f, oracle %.4f), AUC VCRE %.4f (inliers %.4f, oracle %.4f)\n",
                qs->size(), ours.auc_pose, inl.auc_pose, oracle.auc_pose, ours.auc_vcre, inl.auc_vcre,
                oracle.auc_vcre);
    ASSERT_GT(ours.estimates, static_cast<int>(qs->size()) * 9 / 10);
    ASSERT_LT(ours.precision_pose, 1.0);  // some estimates are wrong: there is something to rank
    EXPECT_GT(ours.auc_pose, inl.auc_pose + 0.01);
    EXPECT_GE(ours.auc_vcre, inl.auc_vcre);
    EXPECT_LE(ours.auc_pose, oracle.auc_pose + 1e-9);
  }
}

}  // namespace
}  // namespace freeloc::pipeline
