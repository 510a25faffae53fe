// The confidence of a metric pose estimate — essential + scale, hybrid, PnP, Procrustes (docs/architecture.md §1): the
// map-free AUCs rank estimates by it, so it should order them by their actual error. freeloc predicts the pose error
// from what the stages measured and ranks by it:
//   angular noise of one correspondence   σ = RMS Sampson residual of the essential inliers / focal  (radians)
//   rotation error                        σ_R ≈ σ / √n                                    (n essential inliers)
//   translation error from the direction  σ_dir ≈ σ · Z̄ / √n   (metres; Z̄ = mean depth of the scale inliers:
//                                          the metric error of a direction error is independent of the baseline)
//   translation error from the scale      σ_s = the standard error of the scale (or anchoring) that made t (metres)
//   gross-failure risk                    the fraction of correspondences that agreed, for the essential fit and
//                                          for the scale vote: predicted errors are divided by their geometric mean
//   ambiguity                             a competing model the evidence could not rule out: the distance to it,
//                                          weighted by how plausible it stayed, is a floor under both errors
// Confidence = 1 / max(σ_t / 0.25 m, σ_R / 5°) with σ_t = √(σ_dir² + σ_s²) — the inverse of the predicted error in
// units of the benchmark's pose thresholds. bench/confidence compares its AUCs with those of the raw inlier count.
#pragma once

namespace freeloc::pose {

struct PoseEvidence {
  int matches = 0;               // correspondences into the essential estimator
  int inliers = 0;               // its inliers
  double residual_px = 0;        // RMS Sampson error of the inliers, pixels
  double focal_px = 0;           // mean focal of the two cameras
  double mean_depth_m = 0;       // mean depth of the points that voted for the scale
  int scale_candidates = 0;      // correspondences with depth in both images
  int scale_inliers = 0;         // … that agreed on the scale
  double scale_std_error_m = 0;  // standard error of |t|
  // A competing model (geometry/competing_models.h) the evidence could not rule out: how plausible it stayed
  // (0–1, its evidence ÷ the winner's) and how far it is from the answer. A runner-up nearly as plausible puts a
  // floor under the predicted error: the distance to it.
  double rival_plausibility = 0;
  double rival_rotation_deg = 0;
  double rival_translation_m = 0;
};

struct PredictedError {
  double rotation_deg = 0;
  double translation_m = 0;
};

PredictedError PredictPoseError(const PoseEvidence& e);

// 1 / max(t / 0.25 m, R / 5°); larger is better, finite and ≥ kWeakSupportCeiling (a predicted error of 250 m).
double ConfidenceFromPredictedError(const PredictedError& p);

// Weak-support answers (QueryStatus::kWeakSupport) rank below every supported one and above the prior (0): their
// confidence c is mapped into (0, kWeakSupportCeiling), keeping their order among themselves.
constexpr double kWeakSupportCeiling = 1e-3;
double WeakSupportConfidence(double c);

}  // namespace freeloc::pose
