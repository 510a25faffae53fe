// Ambiguity-aware model selection for the calibrated relative pose. A match set can support two different
// essential matrices almost equally: a plane-dominated view has two 5-point answers that explain the plane's
// matches alike (the homography's two decompositions; Longuet-Higgins, "Multiple interpretations of a pair of
// images of a surface", Proc. R. Soc. A 1988), and weak texture leaves any model's support close to another's.
// RANSAC keeps only the best-scoring one, which then wins by a few matches — or by chance.
//
// After RANSAC, FindCompetingRelativeModels samples minimal sets from the winner's inliers (where the twin of a
// planar configuration lives), refines every distinct model with most of the winner's support, and returns those
// that stay distinct. EvaluateRelativeModel gathers the evidence that tells them apart beyond the Sampson count:
// cheirality (points in front of both cameras) and, when depth is given, whether the depths of the inliers are
// consistent with the model's triangulation up to one common scale (a wrong twin's triangulated depths are not
// proportional to the true ones). The caller decides, and reports how plausible the runner-up stayed.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "freeloc/geometry/essential.h"

namespace freeloc::geometry {

// Depth of each correspondence in the reference and the query frame (metres or any common unit; ≤ 0 or NaN: none).
// Either may be empty.
struct DepthSamples {
  std::vector<double> ref, query;
};

struct ModelEvidence {
  int inliers = 0;        // Sampson inliers
  int in_front = 0;       // … in front of both cameras
  int depth_samples = 0;  // in-front inliers with a depth (reference and query counted separately)
  // … whose point, moved by the model at the scale the depths agree on (median), reprojects within 6σ of the other
  // view's ray: the reference point (depth · ray) into the query, the query's back into the reference.
  int depth_reprojection_inliers = 0;
};

// `sigma_rad`: the angular noise of one correspondence (≈ 1 px / focal); the reprojection threshold is 6σ.
ModelEvidence EvaluateRelativeModel(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                                    const PoseRt& pose, double threshold_sq, const DepthSamples& depth,
                                    double sigma_rad);

// Rotation angle between two rotations and angle between two translation directions, degrees.
double RotationDistanceDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);
double DirectionDistanceDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

// Whether two models are different answers: rotation ≥ 1° or translation direction ≥ 5° apart.
bool DistinctModels(const PoseRt& a, const PoseRt& b);

struct CompetingModel {
  PoseRt pose;  // refined, unit translation
  int inliers = 0;
};

// Distinct models (rotation ≥ 1° or direction ≥ 5° from `best`, after refinement) whose Sampson support is at
// least `min_support_ratio` of the best's, most supported first, at most `max_models`. `near` (optional): the most
// supported minimal-sample models that are not distinct from `best` (unrefined; the spread of a flat valley).
// `best_inliers`: the indices of `best`'s inliers. Deterministic for a seed; costs ~`samples` 5-point solves and
// scoring on ≤ 4000 matches.
std::vector<CompetingModel> FindCompetingRelativeModels(const std::vector<Eigen::Vector3d>& x1,
                                                        const std::vector<Eigen::Vector3d>& x2, const PoseRt& best,
                                                        const std::vector<int>& best_inliers, double threshold_sq,
                                                        double loss_scale, uint64_t seed, int samples = 60,
                                                        double min_support_ratio = 0.7, int max_models = 3,
                                                        std::vector<CompetingModel>* near = nullptr);

}  // namespace freeloc::geometry
