// The rotation between two views that show no parallax — the same photo twice, or a camera turned in place — where
// the essential matrix is undetermined (every translation direction fits). A 2-point minimal solver (Wahba's problem
// on the two bearing pairs: Wahba, SIAM Review 1965; solved by SVD as in Markley, J. Astronaut. Sci. 1988) inside
// the LO-RANSAC of ransac.h, refitted on the inliers by the same SVD. With depth in both views the translation follows
// from the rotation's inliers: the median of X_query − R·X_ref, metres.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/geometry/ransac.h"

namespace freeloc::geometry {

struct RotationOnlyResult {
  Eigen::Matrix3d query_from_ref = Eigen::Matrix3d::Identity();  // x_query ∝ R·x_ref
  std::vector<char> inliers;                                     // per correspondence
  int num_inliers = 0;
  double residual_px = 0;  // RMS angular residual of the inliers, pixels at the mean focal
  bool found = false;
};

// The rotation best explaining the correspondences (pixels of each frame, with its camera) within `threshold_px`.
RotationOnlyResult EstimateRotationOnly(const std::vector<Eigen::Vector2d>& px_ref,
                                        const std::vector<Eigen::Vector2d>& px_query, const Camera& ref,
                                        const Camera& query, double threshold_px, const RansacOptions& ransac = {});

// The rotation R minimising Σ‖b_i − R·a_i‖² over unit bearings (the SVD solution of Wahba's problem, det R = +1).
Eigen::Matrix3d RotationBetweenBearings(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b);

}  // namespace freeloc::geometry
