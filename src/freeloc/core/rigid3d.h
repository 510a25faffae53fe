// Rigid transform x_b = R·x_a + t, named b_from_a (docs/architecture.md §2). freeloc's pose is `query_from_ref`:
// x_query = R·x_ref + t, metres (the map-free convention: world = reference camera, world-to-camera).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

namespace freeloc {

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : rotation(q.normalized()), translation(t) {}
  Rigid3d(const Eigen::Matrix3d& R, const Eigen::Vector3d& t)
      : rotation(Eigen::Quaterniond(R).normalized()), translation(t) {}

  Eigen::Matrix3d R() const { return rotation.toRotationMatrix(); }
  Eigen::Matrix<double, 3, 4> Matrix3x4() const;

  // a_from_b given b_from_a.
  Rigid3d Inverse() const;
  // Composition: (c_from_b * b_from_a) = c_from_a.
  Rigid3d operator*(const Rigid3d& b_from_a) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& x_a) const { return rotation * x_a + translation; }

  // Camera centre in the source frame: for query_from_ref it is the query camera's position in the reference frame.
  Eigen::Vector3d Center() const { return -(rotation.conjugate() * translation); }

  // w-first quaternion (qw, qx, qy, qz), unit norm, sign-canonical (qw ≥ 0; if qw == 0 the first non-zero
  // component is positive) so that equal rotations always write equal numbers; a pose built from these numbers
  // gives them back exactly (what a record read back writes is what was written).
  std::array<double, 4> QuaternionWxyz() const;
  // From a w-first quaternion; normalises it. Throws freeloc::Error on zero norm or non-finite values.
  static Rigid3d FromWxyz(const std::array<double, 4>& qwxyz, const Eigen::Vector3d& t);
};

// Angle in degrees of the rotation a·b⁻¹ (geodesic distance between rotations).
double RotationAngleDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

// Canonical-sign copy of a unit quaternion (see Rigid3d::QuaternionWxyz).
Eigen::Quaterniond CanonicalQuaternion(const Eigen::Quaterniond& q);

}  // namespace freeloc
