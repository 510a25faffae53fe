// The joint window scale (window_scale.h) on seeded synthetic windows: exact anchorings give the true distance;
// maps with independent global errors give a distance whose error shrinks with the number of maps (against one
// frame's two-map answer); a window too small to say more is refused.
#include "freeloc/geometry/window_scale.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

namespace freeloc::geometry {
namespace {

struct Truth {
  Eigen::Vector3d P;
  std::vector<Eigen::Vector3d> c;
};

// A reference centre 0.3–1.5 m from the evaluated camera and `frames` frames along a hand-held path ending at it
// (2–7 cm per frame); each depth map off by exp(N(0, map_sigma)); rays and directions with angular noise.
WindowScaleInput MakeWindow(uint32_t seed, int frames, double map_sigma, Truth* truth, double ray_noise_deg = 0.1,
                            double baseline_noise_deg = 2.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u(0, 1);
  const auto unit = [&] { return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized(); };
  const auto jitter = [&](const Eigen::Vector3d& v, double deg) {
    return (v.normalized() + deg * M_PI / 180 * Eigen::Vector3d(g(rng), g(rng), g(rng))).normalized();
  };
  const auto anchored = [&](double length, double map_error) {
    AnchoredLength a;
    a.has = true;
    a.log_length = std::log(length) + map_error + 0.005 * g(rng);
    a.se = 0.005;
    return a;
  };
  truth->P = (0.3 + 1.2 * u(rng)) * unit();
  const Eigen::Vector3d v = (0.02 + 0.05 * u(rng)) * unit();
  truth->c.clear();
  std::vector<double> e(static_cast<size_t>(2 + frames));
  for (double& x : e) x = map_sigma * g(rng);
  WindowScaleInput in;
  in.ray = jitter(truth->P, ray_noise_deg);
  in.ray_sigma_rad = ray_noise_deg * M_PI / 180;
  in.to_ref_by_ref = anchored(truth->P.norm(), e[0]);
  in.to_ref_by_own = anchored(truth->P.norm(), e[1]);
  for (int j = 0; j < frames; ++j) {
    const Eigen::Vector3d c = -(frames - j) * v + 0.002 * (frames - j) * (frames - j) * unit();
    truth->c.push_back(c);
    WindowFrameGeometry f;
    f.ray = jitter(truth->P - c, ray_noise_deg);
    f.ray_sigma_rad = ray_noise_deg * M_PI / 180;
    f.baseline = c.norm() * (1 + 0.2 * g(rng)) * jitter(c, baseline_noise_deg);
    f.baseline_sigma_rad = baseline_noise_deg * M_PI / 180;
    f.to_ref_by_ref = anchored((truth->P - c).norm(), e[0]);
    f.to_ref_by_own = anchored((truth->P - c).norm(), e[static_cast<size_t>(2 + j)]);
    f.relation_by_q = anchored(c.norm(), e[1]);
    f.relation_by_own = anchored(c.norm(), e[static_cast<size_t>(2 + j)]);
    in.frames.push_back(f);
  }
  return in;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

TEST(WindowScale, ExactMapsGiveTheTrueDistance) {
  for (uint32_t seed = 1; seed <= 20; ++seed) {
    Truth t;
    const WindowScaleResult r = EstimateWindowScale(MakeWindow(seed, 8, 0.0, &t));
    ASSERT_TRUE(r.ok) << seed;
    EXPECT_LT(std::abs(r.distance / t.P.norm() - 1), 0.01) << seed;
    EXPECT_EQ(r.maps, 10);
    EXPECT_LT(r.map_sigma, 0.02) << seed;
  }
}

// Monocular-like maps (20 % global error each): the joint distance's median relative error is at most 0.65× the
// evaluated frame's own two-map answer (theory: √(2/10) ≈ 0.45), and its stated uncertainty is honest (the error
// within 2.5 σ for 90 % of the windows).
TEST(WindowScale, IndependentMapErrorsAverageOut) {
  std::vector<double> joint, single;
  int within = 0;
  const int n = 200;
  for (uint32_t seed = 1000; seed < 1000 + n; ++seed) {
    Truth t;
    const WindowScaleInput in = MakeWindow(seed, 8, 0.2, &t);
    const WindowScaleResult r = EstimateWindowScale(in);
    ASSERT_TRUE(r.ok) << seed;
    const double err = std::abs(std::log(r.distance / t.P.norm()));
    joint.push_back(err);
    single.push_back(
        std::abs(0.5 * (in.to_ref_by_ref.log_length + in.to_ref_by_own.log_length) - std::log(t.P.norm())));
    within += err <= 2.5 * r.log_sigma;
  }
  const double ratio = Median(joint) / Median(single);
  std::printf("median |log error|: joint %.4f, single frame %.4f (ratio %.2f); within 2.5 σ: %d/%d\n", Median(joint),
              Median(single), ratio, within, n);
  EXPECT_LT(ratio, 0.65);
  EXPECT_GE(within, 0.9 * n);
}

TEST(WindowScale, TooFewMapsIsRefused) {
  Truth t;
  WindowScaleInput in = MakeWindow(7, 1, 0.2, &t);
  in.frames[0].to_ref_by_own.has = in.frames[0].relation_by_own.has = false;
  EXPECT_FALSE(EstimateWindowScale(in).ok);  // the reference's and the evaluated camera's maps only
  in.frames[0].to_ref_by_own.has = true;
  EXPECT_TRUE(EstimateWindowScale(in).ok);
}

}  // namespace
}  // namespace freeloc::geometry
