#include "freeloc/core/rigid3d.h"

#include <cmath>

#include "freeloc/core/error.h"

namespace freeloc {

Eigen::Matrix<double, 3, 4> Rigid3d::Matrix3x4() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = R();
  m.col(3) = translation;
  return m;
}

Rigid3d Rigid3d::Inverse() const {
  Rigid3d inv;
  inv.rotation = rotation.conjugate();
  inv.translation = -(inv.rotation * translation);
  return inv;
}

Rigid3d Rigid3d::operator*(const Rigid3d& b_from_a) const {
  Rigid3d c_from_a;
  c_from_a.rotation = (rotation * b_from_a.rotation).normalized();
  c_from_a.translation = rotation * b_from_a.translation + translation;
  return c_from_a;
}

Eigen::Quaterniond CanonicalQuaternion(const Eigen::Quaterniond& q_in) {
  // Normalised only when not unit already: normalising a unit quaternion again moves its last bit about one time in
  // a hundred for large rotations (N(N(q)) != N(q)), so a pose written, read back from its record (an MPI rank's
  // scene, a --resume journal) and written again would change its digits. A unit quaternion keeps its own
  // coefficients (normalized() leaves |q|² within 3 ulp of 1), which makes this a fixed point:
  // CanonicalQuaternion(CanonicalQuaternion(q)) == CanonicalQuaternion(q).
  Eigen::Quaterniond q = q_in;
  if (!(std::abs(q.squaredNorm() - 1.0) <= 1e-14)) q.normalize();
  const double c[4] = {q.w(), q.x(), q.y(), q.z()};
  for (double v : c) {
    if (v < 0) {
      q = Eigen::Quaterniond(-q.w(), -q.x(), -q.y(), -q.z());
      break;
    }
    if (v > 0) break;
  }
  q.coeffs().array() += 0.0;  // −0.0 + 0.0 = +0.0: no negative zeros in written files
  return q;
}

std::array<double, 4> Rigid3d::QuaternionWxyz() const {
  const Eigen::Quaterniond q = CanonicalQuaternion(rotation);
  return {q.w(), q.x(), q.y(), q.z()};
}

Rigid3d Rigid3d::FromWxyz(const std::array<double, 4>& q, const Eigen::Vector3d& t) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  FREELOC_CHECK(std::isfinite(n) && n > 1e-12,
                "quaternion (" << q[0] << ", " << q[1] << ", " << q[2] << ", " << q[3]
                               << ") has zero or non-finite norm; give a unit quaternion qw qx qy qz");
  FREELOC_CHECK(t.allFinite(), "translation (" << t.transpose() << ") is not finite");
  Rigid3d r;
  r.rotation = Eigen::Quaterniond(q[0] / n, q[1] / n, q[2] / n, q[3] / n);
  r.translation = t;
  return r;
}

double RotationAngleDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  // 2·acos(|w|) of the relative rotation, in the atan2 form that stays accurate for tiny angles.
  const Eigen::Quaterniond r = a.normalized() * b.normalized().conjugate();
  const double angle = 2.0 * std::atan2(r.vec().norm(), std::abs(r.w()));
  return angle * 180.0 / M_PI;
}

}  // namespace freeloc
