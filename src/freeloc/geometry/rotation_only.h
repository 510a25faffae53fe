// The rotation between two views that show no parallax — the same photo twice, or a camera turned in place — where
// the essential matrix is undetermined (every translation direction fits). A 2-point minimal solver (Wahba's problem
// on the two bearing pairs: Wahba, SIAM Review 1965; solved by SVD as in Markley, J. Astronaut. Sci. 1988) inside
// the LO-RANSAC of ransac.h, refitted on the inliers by the same SVD. With depth in both views the translation follows
// from the rotation's inliers: the median of X_query − R·X_ref, metres (TranslationFromDepths).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/geometry/ransac.h"

namespace freeloc::geometry {

struct RotationOnlyResult {
  Eigen::Matrix3d query_from_ref = Eigen::Matrix3d::Identity();  // x_query ∝ R·x_ref
  std::vector<char> inliers;                                     // per correspondence
  int num_inliers = 0;
  double residual_px = 0;  // RMS angular residual of the inliers, pixels at the mean focal
  bool found = false;
};

// The search: a rotation worth taking explains at least a seventh of the matches, which 1000 two-point samples find
// with probability > 0.9999; the cap keeps a set with no such rotation at ≈ 1000 × n error evaluations.
inline const RansacOptions kRotationOnlyRansac{/*success_prob=*/0.9999, /*min_iterations=*/50,
                                               /*max_iterations=*/1000, /*max_seconds=*/0};

// The rotation best explaining the correspondences (pixels of each frame, with its camera) within `threshold_px`.
RotationOnlyResult EstimateRotationOnly(const std::vector<Eigen::Vector2d>& px_ref,
                                        const std::vector<Eigen::Vector2d>& px_query, const Camera& ref,
                                        const Camera& query, double threshold_px,
                                        const RansacOptions& ransac = kRotationOnlyRansac);

// The translation of a rotation's pose from both depth maps: over its inliers with depth in both maps, the
// component-wise median of X_query − R·X_ref (metres); `agree`: the samples within max(3 × 1.4826 × MAD, 1 % of the
// mean depth) of it, and the standard error 1.4826 × MAD / √agree. found: at least 5 samples.
struct DepthTranslation {
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  int samples = 0, agree = 0;
  double mean_depth_m = 0, std_error_m = 0;
  bool found = false;
};
DepthTranslation TranslationFromDepths(const std::vector<Eigen::Vector2d>& px_ref,
                                       const std::vector<Eigen::Vector2d>& px_query, const Camera& ref,
                                       const Camera& query, const RotationOnlyResult& rotation, const DepthMap& d_ref,
                                       const DepthMap& d_query);

// The rotation R minimising Σ‖b_i − R·a_i‖² over unit bearings (the SVD solution of Wahba's problem, det R = +1).
Eigen::Matrix3d RotationBetweenBearings(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b);

}  // namespace freeloc::geometry
