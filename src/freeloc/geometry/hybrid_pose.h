// Depth-aware hybrid relative pose: LO-RANSAC that draws minimal samples from the 5-point solver
// (five_point.h; its unit-baseline model is completed with the metric length and query-depth scale that its inliers'
// depths imply) AND from the 3-point depth solvers (relpose_depth_3pt.h, scale only; relpose_depth_shift_3pt.h, scale
// and shifts), mixed adaptively, as in MADPose (Yu, Liu, Pautrat, Pollefeys, Larsson, "Relative Pose Estimation
// through Affine Corrections of Monocular Depth Priors", CVPR 2025) and RePoseD (Ding et al., ICCV 2025). Every
// hypothesis is scored on the same hybrid MSAC cost: the Sampson error of each correspondence plus its two-way
// reprojection through the depths (reference point into the query, query point into the reference; a point behind a
// camera costs the maximum), each truncated at its own threshold. Whenever a hypothesis beats the best, and once at
// the end, (R, t, query-depth scale [, shifts]) are refined jointly on the inliers with a Cauchy loss.
//
// The model's translation is in the units of the reference depth (the reference depth anchors the metric scale);
// `scale` maps the query depth into those units, so with two metric depth maps scale ≈ 1 and their disagreement is
// |log scale| (pose/hybrid_route.cc combines the two anchorings).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/geometry/relpose_depth_3pt.h"

namespace freeloc::geometry {

struct HybridPoseOptions {
  double threshold_px = 1.0;      // Sampson inlier threshold, pixels (÷ mean focal)
  double reprojection_px = 16.0;  // two-way reprojection threshold, pixels: depth maps are a few % off
  bool shifts = false;            // also estimate the two depth shifts (3-point scale+shift solver, refinement)
  // The search (its own sampler mixes the two solver families; local optimisation always runs).
  RansacOptions ransac{/*success_prob=*/0.9999, /*min_iterations=*/100, /*max_iterations=*/10000,
                       /*max_seconds=*/10.0};
  int refinement_iterations = 30;
  int min_inliers = 10;   // as RelativePoseOptions: fewer Sampson inliers is no consensus
  void Validate() const;  // throws freeloc::Error
};

struct HybridPoseResult {
  DepthRelPose model;                    // query point = R·reference point + t; t in reference-depth units
  std::vector<char> inliers;             // Sampson inliers in front of both cameras
  EstimatorStatus status;                // reason "ok", "too-few-matches", "no-consensus", "degenerate"
  int depth_candidates = 0;              // inliers with depth in both views
  int depth_inliers = 0;                 // … whose reprojection through the depths agrees both ways
  int samples_5pt = 0, samples_3pt = 0;  // minimal samples drawn from each solver family
  double residual_px = 0;                // RMS Sampson error of the inliers, pixels
  double reprojection_rms_px = 0;        // RMS two-way reprojection error of the depth inliers, pixels
  double scale_std_error = 0;            // relative standard error of the metric length |t| from the depth inliers
  double mean_depth = 0;                 // mean reference depth of the depth inliers (reference units)
};

// `depth_ref[i]`, `depth_query[i]`: the z-depth at correspondence i in each view (≤ 0 or NaN: none).
HybridPoseResult EstimateHybridPose(const std::vector<Eigen::Vector2d>& px_ref,
                                    const std::vector<Eigen::Vector2d>& px_query, const std::vector<double>& depth_ref,
                                    const std::vector<double>& depth_query, const Camera& ref, const Camera& query,
                                    const HybridPoseOptions& options = {});

}  // namespace freeloc::geometry
