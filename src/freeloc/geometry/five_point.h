// Calibrated 5-point relative pose: D. Nistér, "An efficient solution to the five-point relative pose problem",
// IEEE TPAMI 26(6), 2004 — the null space of the 5 epipolar constraints, the cubic trace and determinant
// constraints reduced by Gauss–Jordan elimination to a degree-10 polynomial in z, real roots by Sturm-sequence
// bisection. Each essential matrix is decomposed and only the factorisations that put all 5 sample points in
// front of both cameras are returned (cheirality inside the solver).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/geometry/essential.h"

namespace freeloc::geometry {

// x1[i], x2[i]: normalised image coordinates (u, v, 1) or bearing vectors of the same point in the reference and
// the query camera, with x2 ∝ R·x1·d + t. Appends every real solution to `essentials` (up to 10).
int FivePointEssential(const Eigen::Vector3d x1[5], const Eigen::Vector3d x2[5],
                       std::vector<Eigen::Matrix3d>* essentials);

// Pose candidates (t unit norm) that pass the cheirality test on all 5 points. Returns their number.
int FivePointRelativePose(const Eigen::Vector3d x1[5], const Eigen::Vector3d x2[5], std::vector<PoseRt>* poses);
// The same on the correspondences `sample[0..4]` of two ray lists (RANSAC's minimal samples); `poses` is cleared.
int FivePointRelativePose(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                          const int* sample, std::vector<PoseRt>* poses);

}  // namespace freeloc::geometry
