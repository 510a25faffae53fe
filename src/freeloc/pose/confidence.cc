#include "freeloc/pose/confidence.h"

#include <algorithm>
#include <cmath>

namespace freeloc::pose {

PredictedError PredictPoseError(const PoseEvidence& e) {
  constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
  const double n = std::max(1, e.inliers);
  // A floor on the residual: a fit that is too good to be true on few points is not more certain than 0.1 px.
  const double sigma = std::max(e.residual_px, 0.1) / std::max(e.focal_px, 1.0);
  const double rot = sigma / std::sqrt(n);
  const double dir = sigma * std::max(e.mean_depth_m, 0.0) / std::sqrt(n);
  const double trans = std::sqrt(dir * dir + e.scale_std_error_m * e.scale_std_error_m);
  // Risk of a wrong model: few of the correspondences agreed (essential) or few depths agreed (scale).
  const double ess_ratio = e.matches > 0 ? static_cast<double>(e.inliers) / e.matches : 0.0;
  // No scale vote (PnP, Procrustes: the depth is inside the model): only the inliers' agreement counts.
  const double scale_ratio = e.scale_candidates > 0 ? static_cast<double>(e.scale_inliers) / e.scale_candidates : 1.0;
  // … and few inliers: a model a few dozen matches support is more often a wrong one (a near-degenerate essential
  // matrix, a rotation that fits a subset) than the residuals show — support below kSupport halves the trust.
  constexpr double kSupport = 30;
  const double support = e.inliers / (e.inliers + kSupport);
  const double agree = std::sqrt(std::max(ess_ratio, 1e-3) * std::max(scale_ratio, 1e-3)) * std::max(support, 1e-3);
  PredictedError p;
  p.rotation_deg = rot * kRadToDeg / agree;
  p.translation_m = trans / agree;
  // A runner-up as plausible as the answer (plausibility 1) is as likely the truth: the error is its distance. One
  // the evidence clearly ruled out (plausibility ≤ 0.5) adds nothing.
  const double w = std::clamp((e.rival_plausibility - 0.5) / 0.5, 0.0, 1.0);
  p.rotation_deg = std::hypot(p.rotation_deg, w * e.rival_rotation_deg);
  p.translation_m = std::hypot(p.translation_m, w * e.rival_translation_m);
  return p;
}

double ConfidenceFromPredictedError(const PredictedError& p) {
  const double worst = std::max(p.translation_m / 0.25, p.rotation_deg / 5.0);
  return 1.0 / std::clamp(worst, 1e-9, 1.0 / kWeakSupportCeiling);
}

double WeakSupportConfidence(double c) {
  const double r = std::isnan(c) || c <= 0 ? 0.0 : std::isinf(c) ? 1.0 : c / (1.0 + c);
  return kWeakSupportCeiling * (0.001 + 0.998 * r);  // strictly inside (0, kWeakSupportCeiling)
}

}  // namespace freeloc::pose
