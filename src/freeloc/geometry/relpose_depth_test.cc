// The 3-point depth-aware relative pose solvers (relpose_depth_3pt.h, relpose_depth_shift_3pt.h) on seeded
// synthetic triangles: exact data → the exact pose, scale and shifts; noise → bounded error; degenerate and
// invalid inputs → no solution.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <random>

#include "freeloc/core/rigid3d.h"
#include "freeloc/geometry/relpose_depth_3pt.h"
#include "freeloc/geometry/relpose_depth_shift_3pt.h"

namespace freeloc::geometry {
namespace {

struct Triangle {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  Eigen::Vector3d x[3], y[3];
  double zr[3], zq[3];  // true z-depths
};

Triangle MakeTriangle(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Triangle tr;
  for (;;) {
    const Eigen::Vector3d axis = Eigen::Vector3d(u(*rng), u(*rng), u(*rng)).normalized();
    tr.R = Eigen::AngleAxisd(0.4 * u(*rng), axis).toRotationMatrix();
    tr.t = Eigen::Vector3d(u(*rng), 0.4 * u(*rng), 0.4 * u(*rng));
    bool ok = true;
    for (int i = 0; i < 3 && ok; ++i) {
      const Eigen::Vector3d X(2 * u(*rng), 1.5 * u(*rng), 4 + 3 * u(*rng));
      const Eigen::Vector3d Y = tr.R * X + tr.t;
      ok = Y.z() > 0.5;
      tr.x[i] = X / X.z();
      tr.y[i] = Y / Y.z();
      tr.zr[i] = X.z();
      tr.zq[i] = Y.z();
    }
    if (ok) return tr;
  }
}

double AngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180 / M_PI;
}

TEST(RelPoseDepth3pt, ScaleOnlyExactDataGiveTheExactPose) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> us(0.3, 3.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Triangle tr = MakeTriangle(&rng);
    const double k = us(rng);  // the query depth map is off by this factor
    double dq[3];
    for (int i = 0; i < 3; ++i) dq[i] = k * tr.zq[i];
    std::vector<DepthRelPose> sols;
    ASSERT_EQ(RelPoseDepthScale3pt(tr.x, tr.zr, tr.y, dq, &sols), 1) << trial;
    EXPECT_LT(AngleDeg(sols[0].R, tr.R), 1e-7) << trial;
    EXPECT_LT((sols[0].t - tr.t).norm(), 1e-8) << trial;
    EXPECT_NEAR(sols[0].scale, 1.0 / k, 1e-9) << trial;
  }
}

TEST(RelPoseDepth3pt, ScaleOnlyNoiseGivesBoundedError) {
  std::mt19937 rng(12);
  std::normal_distribution<double> g(0, 1);
  std::vector<double> rot, trans;
  for (int trial = 0; trial < 200; ++trial) {
    Triangle tr = MakeTriangle(&rng);
    double dr[3], dq[3];
    for (int i = 0; i < 3; ++i) {
      dr[i] = tr.zr[i] * (1 + 0.002 * g(rng));  // 0.2 % depth noise
      dq[i] = tr.zq[i] * (1 + 0.002 * g(rng));
    }
    std::vector<DepthRelPose> sols;
    if (RelPoseDepthScale3pt(tr.x, dr, tr.y, dq, &sols) != 1) continue;
    rot.push_back(AngleDeg(sols[0].R, tr.R));
    trans.push_back((sols[0].t - tr.t).norm());
  }
  ASSERT_GE(rot.size(), 195u);
  std::sort(rot.begin(), rot.end());
  std::sort(trans.begin(), trans.end());
  // A 3-point fit with cm-level depth noise on a ~2 m triangle: sub-degree typically; skinny triangles are worse.
  EXPECT_LT(rot[rot.size() / 2], 0.5);
  EXPECT_LT(trans[trans.size() / 2], 0.03);
  EXPECT_LT(rot.back(), 15.0);
  EXPECT_GT(trans.back(), 0.0);
}

TEST(RelPoseDepth3pt, DegenerateAndInvalidInputsGiveNoSolution) {
  std::mt19937 rng(13);
  Triangle tr = MakeTriangle(&rng);
  std::vector<DepthRelPose> sols;
  double bad[3] = {tr.zr[0], 0.0, tr.zr[2]};
  EXPECT_EQ(RelPoseDepthScale3pt(tr.x, bad, tr.y, tr.zq, &sols), 0);  // a missing depth
  // Collinear 3D points (on one line through space): the rotation about the line is free.
  const Eigen::Vector3d P(0.2, -0.1, 4), D(0.5, 0.2, 0.3);
  Eigen::Vector3d x[3], y[3];
  double zr[3], zq[3];
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d X = P + (i + 1) * D, Y = tr.R * X + tr.t;
    x[i] = X / X.z();
    y[i] = Y / Y.z();
    zr[i] = X.z();
    zq[i] = Y.z();
  }
  EXPECT_EQ(RelPoseDepthScale3pt(x, zr, y, zq, &sols), 0);
  EXPECT_EQ(RelPoseDepthShift3pt(x, zr, y, zq, &sols), 0);
  // Three copies of one point.
  for (int i = 1; i < 3; ++i) {
    x[i] = x[0];
    y[i] = y[0];
    zr[i] = zr[0];
    zq[i] = zq[0];
  }
  EXPECT_EQ(RelPoseDepthScale3pt(x, zr, y, zq, &sols), 0);
  EXPECT_EQ(RelPoseDepthShift3pt(x, zr, y, zq, &sols), 0);
  EXPECT_TRUE(sols.empty());
}

TEST(RelPoseDepthShift3pt, ExactDataGiveTheExactPoseScaleAndShifts) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> us(0.5, 2.0), ush(-0.4, 0.4);
  int found = 0, trials = 200;
  for (int trial = 0; trial < trials; ++trial) {
    const Triangle tr = MakeTriangle(&rng);
    const double k = us(rng), u = ush(rng), v = ush(rng);
    // Given depths: reference z − u (so z = d_r + u), query k·z − v (so z = (d_q + v) / k, scale 1/k).
    double dr[3], dq[3];
    for (int i = 0; i < 3; ++i) {
      dr[i] = tr.zr[i] - u;
      dq[i] = k * tr.zq[i] - v;
    }
    std::vector<DepthRelPose> sols;
    RelPoseDepthShift3pt(tr.x, dr, tr.y, dq, &sols);
    ASSERT_LE(sols.size(), 8u);
    bool match = false;
    for (const auto& s : sols)
      match |= AngleDeg(s.R, tr.R) < 1e-5 && (s.t - tr.t).norm() < 1e-6 && std::abs(s.scale - 1 / k) < 1e-6 &&
               std::abs(s.shift_ref - u) < 1e-6 && std::abs(s.shift_query - v) < 1e-6;
    found += match;
    // Every solution returned is a rigid motion of the triangle it implies.
    for (const auto& s : sols) {
      EXPECT_NEAR(s.R.determinant(), 1.0, 1e-9);
      for (int i = 0; i < 3; ++i) {
        const Eigen::Vector3d A = (dr[i] + s.shift_ref) * tr.x[i], B = s.scale * (dq[i] + s.shift_query) * tr.y[i];
        EXPECT_LT((s.R * A + s.t - B).norm(), 1e-5 * (1 + B.norm())) << trial;
      }
    }
  }
  EXPECT_GE(found, trials - 2);  // a near-singular draw may lose its root to conditioning
}

TEST(RelPoseDepthShift3pt, ZeroShiftsReduceToTheScaleOnlySolution) {
  std::mt19937 rng(22);
  for (int trial = 0; trial < 50; ++trial) {
    const Triangle tr = MakeTriangle(&rng);
    std::vector<DepthRelPose> a, b;
    ASSERT_EQ(RelPoseDepthScale3pt(tr.x, tr.zr, tr.y, tr.zq, &a), 1);
    RelPoseDepthShift3pt(tr.x, tr.zr, tr.y, tr.zq, &b);
    bool match = false;
    for (const auto& s : b) match |= AngleDeg(s.R, a[0].R) < 1e-5 && std::abs(s.scale - 1) < 1e-6;
    EXPECT_TRUE(match) << trial;
  }
}

}  // namespace
}  // namespace freeloc::geometry
