// The rotation-only estimator (rotation_only.h) on seeded synthetic views that share a centre: exact data → the
// exact rotation; pixel noise and 30 % outliers → bounded error with the outliers rejected; a pair with a real
// baseline close to the points → no rotation explains most matches.
#include "freeloc/geometry/rotation_only.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

namespace freeloc::geometry {
namespace {

Camera Cam() {
  Camera k;
  k.fx = 520;
  k.fy = 515;
  k.cx = 319.5;
  k.cy = 239.5;
  k.width = 640;
  k.height = 480;
  return k;
}

struct Pairs {
  std::vector<Eigen::Vector2d> a, b;
  std::vector<char> outlier;
};

// Points 1–5 m in front of the reference, seen from a camera at R·X + t; `outliers` of them replaced by random pixels.
Pairs MakePairs(uint32_t seed, const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double noise_px, double outliers) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), px(0, 640);
  std::normal_distribution<double> g(0, noise_px);
  const Camera k = Cam();
  Pairs p;
  while (p.a.size() < 300) {
    const Eigen::Vector3d X(1.5 * u(rng), 1.0 * u(rng), 3 + 2 * u(rng));
    const Eigen::Vector3d Y = R * X + t;
    if (Y.z() < 0.5) continue;
    const Eigen::Vector2d a = k.Project(X), b = k.Project(Y);
    if (b.x() < 0 || b.x() > 640 || b.y() < 0 || b.y() > 480) continue;
    const bool out = (u(rng) + 1) / 2 < outliers;
    p.a.push_back(a + Eigen::Vector2d(g(rng), g(rng)));
    p.b.push_back(out ? Eigen::Vector2d(px(rng), 0.75 * px(rng)) : b + Eigen::Vector2d(g(rng), g(rng)));
    p.outlier.push_back(out);
  }
  return p;
}

double AngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a * b.transpose()).angle() * 180 / M_PI;
}

TEST(RotationOnly, ExactDataGiveTheExactRotation) {
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(0.05 * seed, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
    const Pairs p = MakePairs(seed, R, Eigen::Vector3d::Zero(), 0, 0);
    const RotationOnlyResult r = EstimateRotationOnly(p.a, p.b, Cam(), Cam(), 1.0);
    ASSERT_TRUE(r.found);
    EXPECT_EQ(r.num_inliers, 300);
    EXPECT_LT(AngleDeg(r.query_from_ref, R), 1e-6);
    EXPECT_LT(r.residual_px, 1e-6);
  }
}

TEST(RotationOnly, NoiseAndOutliersStayBounded) {
  for (uint32_t seed = 11; seed <= 15; ++seed) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 0.3, 0).normalized()).toRotationMatrix();
    const Pairs p = MakePairs(seed, R, Eigen::Vector3d::Zero(), 0.5, 0.3);
    const RotationOnlyResult r = EstimateRotationOnly(p.a, p.b, Cam(), Cam(), 2.0);
    ASSERT_TRUE(r.found);
    EXPECT_LT(AngleDeg(r.query_from_ref, R), 0.1);
    int wrong = 0;
    for (size_t i = 0; i < p.a.size(); ++i) wrong += p.outlier[i] && r.inliers[i];
    EXPECT_LE(wrong, 3);
    EXPECT_NEAR(r.residual_px, 0.5 * std::sqrt(2.0), 0.35);
  }
}

TEST(RotationOnly, ABaselineLeavesMostMatchesUnexplained) {
  const Pairs p = MakePairs(21, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.5, 0, 0), 0.3, 0);
  const RotationOnlyResult r = EstimateRotationOnly(p.a, p.b, Cam(), Cam(), 1.0);
  EXPECT_LT(r.num_inliers, 150);  // the pipeline takes a rotation only when it explains half the matches
}

TEST(RotationOnly, WahbaSolutionIsAProperRotation) {
  const std::vector<Eigen::Vector3d> a = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()};
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const std::vector<Eigen::Vector3d> b = {R * a[0], R * a[1]};
  const Eigen::Matrix3d got = RotationBetweenBearings(a, b);
  EXPECT_NEAR(got.determinant(), 1.0, 1e-12);
  EXPECT_LT(AngleDeg(got, R), 1e-9);
}

}  // namespace
}  // namespace freeloc::geometry
