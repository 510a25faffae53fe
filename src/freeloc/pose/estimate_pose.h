// The solver fronts (docs/geometry.md "Solvers"): correspondences in each frame's pixels, the two cameras and the
// depth maps (either may be empty) in, one PoseEstimate out — the choice between the four solvers, each solver's
// threshold resolved once (solve_options.h), its outcome mapped onto a Status once, and the confidence model
// (confidence.h) applied to the evidence each route measured:
//   essential   5-point LO-RANSAC (geometry/relative_pose.h), then the metric scale from both depths on its inliers
//               (geometry/metric_scale.h); a pair without parallax is a rotation (geometry/rotation_only.h)
//   hybrid      the depth-aware hybrid LO-RANSAC (geometry/hybrid_pose.h) with the essential route as its guard and
//               fallback
//   pnp         PnP on the reference depth; procrustes: both depths (geometry/absolute_pose.h)
// Pure geometry: no images, no files, no pipeline.
#pragma once

#include "freeloc/core/camera.h"
#include "freeloc/core/correspondences.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/pose/pose_estimate.h"
#include "freeloc/pose/solve_options.h"

namespace freeloc::pose {

// Throws freeloc::Error when a depth map does not cover the correspondences it is sampled at (a map of another
// resolution); every estimator failure is a Status.
PoseEstimate EstimatePose(SolverKind solver, const SolveOptions& options, const Correspondences& c, const Camera& k_ref,
                          const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query);

}  // namespace freeloc::pose
