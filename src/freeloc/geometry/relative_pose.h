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
#include "freeloc/geometry/ransac.h"

namespace freeloc::geometry {

struct RelativePoseOptions {
  double threshold_px = 1.0;  // inlier threshold on the Sampson error, pixels (÷ mean focal for normalised units)
  double success_prob = 0.9999;
  int min_iterations = 50;
  int max_iterations = 100000;
  uint64_t seed = 0;
  bool local_optimization = true;
  bool final_refinement = true;
  int refinement_iterations = 25;
  // Never a confident wrong answer: fewer inliers than this is no consensus (5 matches always fit a 5-point model
  // exactly); a support no larger than what the same model (or the same search) gets from shuffled pairs is weak.
  int min_inliers = 10;
  // Competing models (competing_models.h): minimal samples drawn from the winner's inliers to find a distinct
  // model with nearly the same support (0: no search, RANSAC's winner stands unexamined).
  int competitor_samples = 60;
  double max_seconds = 10.0;  // RANSAC wall-clock budget; then the best model so far, if it passes the checks
  void Validate() const;  // throws freeloc::Error
};

struct EstimatorStatus {
  bool success = false;
  // "ok", "weak-support" (a model, but its support is not clearly beyond chance: the pose is returned, success
  // false), "too-few-matches", "no-consensus" (no model), "degenerate"
  std::string reason;
  int chance_inliers = 0;   // inliers of the final model on shuffled pairs (what chance alone gives)
  int shuffled_best = -1;   // weak support only: the best RANSAC model's inliers on shuffled pairs (−1: not run)
  std::string stop_reason;  // from RANSAC: "confidence", "max-iterations", …
  int num_matches = 0;
  int iterations = 0;
  int num_inliers = 0;
  int local_optimizations = 0;
  double refinement_cost = 0;  // robust cost after the final refinement
  // Competing models: how many distinct models had nearly the winner's support, what decided between them
  // ("support": nothing else told them apart; "cheirality"; "depth"; "" when there was no competitor), and how
  // plausible the strongest loser stayed (its evidence ÷ the winner's, 0–1; 0 without competitor).
  int competitors = 0;
  std::string decided_by;
  double runner_up_plausibility = 0;
  int runner_up_inliers = 0;
  double time_ms = 0;
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

// Robust (Cauchy, scale `loss_scale` in normalised units) Levenberg–Marquardt refinement of (R, unit t) on the
// Sampson error over the correspondences `idx`. Returns the final cost.
double RefineRelativePose(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                          const std::vector<int>& idx, double loss_scale, int max_iterations, PoseRt* pose);

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
