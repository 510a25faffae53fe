// The non-linear refinement of a relative pose (R, unit t) on the Sampson error — the local optimisation of the
// 5-point LO-RANSAC (relative_pose.h), of the competing models (competing_models.h) and of the hybrid estimator's
// epipolar models (hybrid_pose.h): one problem object for MinimizeLM (levenberg_marquardt.h) with a Cauchy loss.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/geometry/essential.h"

namespace freeloc::geometry {

// Robust (Cauchy, scale `loss_scale` in normalised units) Levenberg–Marquardt refinement of (R, unit t) on the
// Sampson error over the correspondences `idx`. Returns the final cost.
double RefineRelativePose(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                          const std::vector<int>& idx, double loss_scale, int max_iterations, PoseRt* pose);

}  // namespace freeloc::geometry
