// Robust calibrated relative pose from pixel correspondences: the 5-point solver (five_point.h) inside LO-RANSAC
// (ransac.h) scored with the Sampson error, a local non-linear refit whenever a hypothesis beats the best, and a
// final robust (Cauchy) non-linear refinement on all inliers. Output: query_from_ref with a unit translation.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/geometry/competing_models.h"
#include "freeloc/geometry/essential.h"
#include "freeloc/geometry/estimator_status.h"
#include "freeloc/geometry/ransac.h"
#include "freeloc/geometry/refine_relative_pose.h"

namespace freeloc::geometry {

struct RelativePoseOptions {
  double threshold_px = 1.0;  // inlier threshold on the Sampson error, pixels (÷ mean focal for normalised units)
  // The search; its wall-clock budget is 10 s, then the best model so far, if it passes the checks.
  RansacOptions ransac{/*success_prob=*/0.9999, /*min_iterations=*/50, /*max_iterations=*/100000,
                       /*max_seconds=*/10.0};
  bool final_refinement = true;
  int refinement_iterations = 25;
  // Never a confident wrong answer: fewer inliers than this is no consensus (5 matches always fit a 5-point model
  // exactly); a support no larger than what the same model (or the same search) gets from shuffled pairs is weak.
  int min_inliers = 10;
  // Competing models (competing_models.h): minimal samples drawn from the winner's inliers to find a distinct
  // model with nearly the same support (0: no search, RANSAC's winner stands unexamined).
  int competitor_samples = 60;
  void Validate() const;  // throws freeloc::Error
};

struct RelativePoseResult {
  Rigid3d query_from_ref;  // translation of unit norm; set for "ok" and "weak-support"
  std::vector<char> inliers;
  EstimatorStatus status;
  Rigid3d runner_up;  // the strongest competing model (unit translation), when status.competitors > 0
};

// `depth`: optional per-correspondence depths, used only to tell competing models apart.
RelativePoseResult EstimateRelativePose(const std::vector<Eigen::Vector2d>& px_ref,
                                        const std::vector<Eigen::Vector2d>& px_query, const Camera& ref,
                                        const Camera& query, const RelativePoseOptions& options = {},
                                        const DepthSamples& depth = {});

// Degenerate support: the inliers lie on (almost) a line or a single pixel in either image (a 2-pixel band).
bool InliersDegenerate(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                       const std::vector<char>& inliers);
// Sampson inliers of `pose` when the query rays are paired with other reference rays (fixed derangements,
// averaged): what chance alone gives this model with these point distributions.
int ChanceInliers(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2, const PoseRt& pose,
                  double threshold_sq);

// Throws freeloc::Error naming `what` when a coordinate is NaN or infinite.
void CheckFinite(const std::vector<Eigen::Vector2d>& pts, const std::string& what);

}  // namespace freeloc::geometry
