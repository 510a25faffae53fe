#include "freeloc/core/rigid3d.h"

#include <gtest/gtest.h>

#include <random>

#include "freeloc/core/error.h"

namespace freeloc {
namespace {

Rigid3d RandomPose(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return Rigid3d(q.normalized(), Eigen::Vector3d(n(rng), n(rng), n(rng)));
}

TEST(Rigid3d, InverseAndComposition) {
  std::mt19937 rng(7);
  for (int i = 0; i < 100; ++i) {
    const Rigid3d b_from_a = RandomPose(rng);
    const Rigid3d c_from_b = RandomPose(rng);
    const Eigen::Vector3d x_a(1.5, -2, 0.25);
    const Rigid3d c_from_a = c_from_b * b_from_a;
    EXPECT_NEAR((c_from_a * x_a - c_from_b * (b_from_a * x_a)).norm(), 0, 1e-12);
    EXPECT_NEAR((b_from_a.Inverse() * (b_from_a * x_a) - x_a).norm(), 0, 1e-12);
    const Rigid3d id = b_from_a * b_from_a.Inverse();
    EXPECT_NEAR(id.translation.norm(), 0, 1e-12);
    EXPECT_NEAR(RotationAngleDeg(id.rotation, Eigen::Quaterniond::Identity()), 0, 1e-6);
  }
}

TEST(Rigid3d, CenterIsQueryPositionInReference) {
  // Query camera 2 m along the reference x axis, same orientation: x_query = x_ref - (2,0,0).
  const Rigid3d query_from_ref(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-2, 0, 0));
  EXPECT_NEAR((query_from_ref.Center() - Eigen::Vector3d(2, 0, 0)).norm(), 0, 1e-15);
}

TEST(Rigid3d, QuaternionWxyzIsNormalisedAndSignStable) {
  std::mt19937 rng(3);
  for (int i = 0; i < 100; ++i) {
    Rigid3d p = RandomPose(rng);
    auto q1 = p.QuaternionWxyz();
    p.rotation.coeffs() *= -1.0;  // the same rotation
    auto q2 = p.QuaternionWxyz();
    EXPECT_EQ(q1, q2);
    EXPECT_GE(q1[0], 0.0);
    EXPECT_NEAR(q1[0] * q1[0] + q1[1] * q1[1] + q1[2] * q1[2] + q1[3] * q1[3], 1.0, 1e-14);
    const Rigid3d back = Rigid3d::FromWxyz(q1, p.translation);
    EXPECT_NEAR(RotationAngleDeg(back.rotation, p.rotation), 0, 1e-6);
  }
  // w == 0: the first non-zero component decides the sign.
  const Rigid3d r180 = Rigid3d::FromWxyz({0, 0, -1, 0}, Eigen::Vector3d::Zero());
  const auto q = r180.QuaternionWxyz();
  EXPECT_EQ(q[0], 0.0);
  EXPECT_EQ(q[2], 1.0);
}

// The numbers written are a fixed point: a pose read back from them (a record from another MPI rank, a --resume
// journal) writes the same digits. Large rotations (|qw| far from 1) are where normalising twice moves a last bit.
TEST(Rigid3d, QuaternionWxyzReadBackWritesTheSameNumbers) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0, 1);
  int changed = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
    const Rigid3d p(q.normalized().toRotationMatrix(), Eigen::Vector3d::Zero());  // as the solvers build theirs
    const auto written = p.QuaternionWxyz();
    Rigid3d back;  // as QueryResultFromJson keeps a unit quaternion's coefficients
    back.rotation = Eigen::Quaterniond(written[0], written[1], written[2], written[3]);
    changed += back.QuaternionWxyz() != written;
    EXPECT_EQ(CanonicalQuaternion(CanonicalQuaternion(q)).coeffs(), CanonicalQuaternion(q).coeffs());
  }
  EXPECT_EQ(changed, 0);
}

TEST(Rigid3d, FromWxyzNormalisesAndRejectsBadInput) {
  const Rigid3d r = Rigid3d::FromWxyz({2, 0, 0, 0}, Eigen::Vector3d(1, 2, 3));
  EXPECT_DOUBLE_EQ(r.rotation.w(), 1.0);
  EXPECT_THROW(Rigid3d::FromWxyz({0, 0, 0, 0}, Eigen::Vector3d::Zero()), Error);
  EXPECT_THROW(Rigid3d::FromWxyz({NAN, 0, 0, 1}, Eigen::Vector3d::Zero()), Error);
  EXPECT_THROW(Rigid3d::FromWxyz({1, 0, 0, 0}, Eigen::Vector3d(NAN, 0, 0)), Error);
}

TEST(Rigid3d, RotationAngleKnownValue) {
  const Eigen::Quaterniond a(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  const Eigen::Quaterniond b(Eigen::AngleAxisd(0.3 + 5 * M_PI / 180, Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(RotationAngleDeg(a, b), 5.0, 1e-9);
  EXPECT_NEAR(RotationAngleDeg(a, Eigen::Quaterniond(-a.coeffs())), 0.0, 1e-9);
}

}  // namespace
}  // namespace freeloc
