// The solver fronts' routes and what they share (estimate_pose.h). Internal to pose/.
#pragma once

#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/correspondences.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/geometry/estimator_status.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/pose/pose_estimate.h"
#include "freeloc/pose/solve_options.h"

namespace freeloc::pose::internal {

// essential_route.cc: 5-point LO-RANSAC, the metric scale, no parallax. `sprt_min_matches` as the caller decides it
// (the hybrid guard's differs).
PoseEstimate EssentialRoute(const SolveOptions& o, int sprt_min_matches, const Correspondences& c, const Camera& k_ref,
                            const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query);
// hybrid_route.cc
PoseEstimate HybridRoute(const SolveOptions& o, const Correspondences& c, const Camera& k_ref, const Camera& k_query,
                         const DepthMap& d_ref, const DepthMap& d_query);
// absolute_route.cc: PnP (`pnp`) or Procrustes.
PoseEstimate AbsoluteRoute(bool pnp, const SolveOptions& o, const Correspondences& c, const Camera& k_ref,
                           const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query);

// The one mapping of an estimator's outcome onto a Status.
Status StatusOf(geometry::EstimatorOutcome outcome);
// A depth map must cover the correspondences it is sampled at (throws naming `frame`).
void CheckDepthCovers(const std::vector<Eigen::Vector2d>& px, const DepthMap& d, const char* frame);
// Per-correspondence depths (0 where a map has none); empty vectors for empty maps.
geometry::DepthSamples SampleDepths(const Correspondences& c, const DepthMap& d_ref, const DepthMap& d_query);
// The mean focal of the two cameras, pixels.
double MeanFocal(const Camera& k_ref, const Camera& k_query);
// Evidence for the confidence model (confidence.h): the fit (matches, inliers, residual, focal) and the scale (mean
// depth, candidates, inliers, standard error).
PoseEvidence Evidence(int matches, int inliers, double residual_px, double focal_px, double mean_depth_m,
                      int scale_candidates, int scale_inliers, double scale_std_error_m);

}  // namespace freeloc::pose::internal
