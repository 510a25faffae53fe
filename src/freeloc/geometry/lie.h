// The Lie-group helpers of geometry/: the hat operator of so(3), its exponential (Rodrigues' formula) and a basis of
// the tangent plane of the unit sphere S² (for unit-norm translations). Every refiner perturbs rotations on the left,
// R ← Exp(δ)·R, and unit directions within their tangent plane, t ← normalise(t + δ₁b₁ + δ₂b₂).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace freeloc::geometry {

// [v]×: the cross-product matrix, [v]×·w = v × w.
inline Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

// exp([w]×): the rotation by |w| radians about w (first order below 1e-12 rad).
inline Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-12) return Eigen::Matrix3d::Identity() + Skew(w);
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

// An orthonormal basis (b1, b2) of the plane orthogonal to the unit vector t.
inline void TangentBasis(const Eigen::Vector3d& t, Eigen::Vector3d* b1, Eigen::Vector3d* b2) {
  const Eigen::Vector3d a = std::abs(t.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  *b1 = t.cross(a).normalized();
  *b2 = t.cross(*b1).normalized();
}

}  // namespace freeloc::geometry
