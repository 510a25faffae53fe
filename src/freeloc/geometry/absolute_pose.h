// Metric pose baselines of the paper (docs/geometry.md, map-free `PnPSolver` / `ProcrustesSolver`):
//  * PnP — reference depth only: back-projected reference pixels (3D) with query pixels (2D); P3P (p3p.h) inside
//    the LO-RANSAC of ransac.h, then robust Gauss–Newton refinement of the reprojection error on all inliers.
//    Official failure rules: fewer than 6 inliers or ‖t‖ > 1000 m is a failure.
//  * Procrustes — both depths: 3D–3D correspondences; 3-point Kabsch/Umeyama fits inside the same LO-RANSAC with a
//    0.05 m inlier distance, refit on all inliers. Fewer than 3 inliers is a failure.
// Confidence = inlier count (as officially). Depth is read bilinearly at the sub-pixel location (0 if any
// neighbour is invalid); correspondences without valid depth are left out.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/geometry/relative_pose.h"

namespace freeloc::geometry {

struct PnPOptions {
  double threshold_px = 3.0;  // official REPROJECTION_INLIER_THRESHOLD
  RansacOptions ransac{/*success_prob=*/0.9999, /*min_iterations=*/50, /*max_iterations=*/10000, /*max_seconds=*/0};
  int min_inliers = 6;
  double max_translation = 1000.0;
  void Validate() const;
};

struct ProcrustesOptions {
  double threshold_m = 0.05;  // official MAX_CORR_DIST
  RansacOptions ransac{/*success_prob=*/0.999, /*min_iterations=*/50, /*max_iterations=*/100000, /*max_seconds=*/0};
  int min_inliers = 3;
  void Validate() const;
};

struct MetricPoseResult {
  Rigid3d query_from_ref;  // metric
  std::vector<char> inliers;
  double confidence = 0;  // inlier count
  EstimatorStatus status;
};

MetricPoseResult EstimatePnP(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                             const DepthMap& depth_ref, const Camera& ref, const Camera& query,
                             const PnPOptions& options = {});

MetricPoseResult EstimateProcrustes(const std::vector<Eigen::Vector2d>& px_ref,
                                    const std::vector<Eigen::Vector2d>& px_query, const DepthMap& depth_ref,
                                    const DepthMap& depth_query, const Camera& ref, const Camera& query,
                                    const ProcrustesOptions& options = {});

// Robust (Cauchy, scale in pixels) Levenberg–Marquardt refinement of camera_from_world on reprojection errors.
void RefineAbsolutePose(const std::vector<Eigen::Vector3d>& X, const std::vector<Eigen::Vector2d>& px,
                        const Camera& cam, const std::vector<int>& idx, double loss_scale_px, int iterations,
                        PoseRt* pose);

}  // namespace freeloc::geometry
