// Essential-matrix utilities for the convention x_query = R·x_ref + t (E = [t]×R, x_queryᵀ·E·x_ref = 0):
// decomposition into the four (R, t) candidates, cheirality by two-view triangulation, the Sampson error.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/geometry/lie.h"

namespace freeloc::geometry {

// A relative pose x2 = R·x1 + t (t of unit norm when it comes from an essential matrix).
struct PoseRt {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

Eigen::Matrix3d EssentialFromPose(const PoseRt& p);

// The four (R, t) factorisations of E (t unit norm).
void DecomposeEssential(const Eigen::Matrix3d& E, PoseRt out[4]);

// Depths (λ1 in view 1, λ2 in view 2) of the point seen along x1 and x2 by least squares; false if the rays are
// parallel.
bool TriangulateDepths(const PoseRt& p, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, double* d1, double* d2);
// Whether the point is in front of both cameras.
bool InFront(const PoseRt& p, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2);

// Squared Sampson error of a correspondence in normalised coordinates (x = (u, v, 1)).
inline double SampsonSquared(const Eigen::Matrix3d& E, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2) {
  const Eigen::Vector3d Ex1 = E * x1;
  const Eigen::Vector3d Etx2 = E.transpose() * x2;
  const double c = x2.dot(Ex1);
  const double s = Ex1(0) * Ex1(0) + Ex1(1) * Ex1(1) + Etx2(0) * Etx2(0) + Etx2(1) * Etx2(1);
  return s > 0 ? c * c / s : 0.0;
}

}  // namespace freeloc::geometry
