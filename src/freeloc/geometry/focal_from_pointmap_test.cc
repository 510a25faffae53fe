#include "freeloc/geometry/focal_from_pointmap.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

namespace freeloc::geometry {
namespace {

struct Pointmap {
  std::vector<Eigen::Vector2d> pixels;
  std::vector<Eigen::Vector3d> points;
};

// A W×H camera of focal `f` (principal point at the centre) looking at a bumpy scene 1–6 m away, one point per
// `step` pixels; `noise`: each coordinate perturbed by that fraction of the point's depth; `outliers`: that fraction
// of the points replaced by random ones in front of the camera.
Pointmap MakePointmap(double f, int w, int h, double noise, double outliers, unsigned seed, int step = 4) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> depth(1.0, 6.0), unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Pointmap pm;
  const double cx = (w - 1) / 2.0, cy = (h - 1) / 2.0;
  for (int y = 0; y < h; y += step)
    for (int x = 0; x < w; x += step) {
      const double z = 2.0 + std::sin(x * 0.01) + 0.5 * std::cos(y * 0.013) + 0.3 * depth(rng) / 6.0;
      Eigen::Vector3d p((x - cx) / f * z, (y - cy) / f * z, z);
      p += noise * z * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
      if (unit(rng) < outliers) p = Eigen::Vector3d((unit(rng) - 0.5) * 8, (unit(rng) - 0.5) * 6, depth(rng));
      pm.pixels.emplace_back(x, y);
      pm.points.push_back(p);
    }
  return pm;
}

TEST(FocalFromPointmap, NoiseFreeIsExact) {
  for (unsigned seed : {11u, 12u, 13u})
    for (double f : {300.0, 525.0, 1500.0}) {
      const Pointmap pm = MakePointmap(f, 640, 480, 0, 0, seed);
      const double got = FocalFromPointmap(pm.pixels, pm.points, {319.5, 239.5});
      EXPECT_NEAR(got / f, 1.0, 1e-2) << "f " << f;  // the acceptance bound is 1 %
      EXPECT_NEAR(got / f, 1.0, 1e-6) << "f " << f;  // and noise-free points give it exactly
    }
}

TEST(FocalFromPointmap, NoisyPointsWithOutliersWithin3Percent) {
  double worst = 0;
  for (unsigned seed = 100; seed < 110; ++seed)
    for (double f : {350.0, 600.0, 1200.0}) {
      const Pointmap pm = MakePointmap(f, 512, 384, 0.02, 0.10, seed);
      const double got = FocalFromPointmap(pm.pixels, pm.points, {255.5, 191.5});
      worst = std::max(worst, std::abs(got / f - 1));
    }
  EXPECT_LT(worst, 0.03);
  std::printf("worst focal error with 2 %% noise and 10 %% outliers: %.2f %%\n", 100 * worst);
}

TEST(FocalFromPointmap, WeiszfeldBeatsLeastSquaresOnOutliers) {
  // One iteration is the least-squares answer; the robust iteration must do clearly better with 10 % outliers.
  const Pointmap pm = MakePointmap(500, 512, 384, 0.0, 0.10, 7);
  const double ls = FocalFromPointmap(pm.pixels, pm.points, {255.5, 191.5}, {0, 1e-9});
  const double robust = FocalFromPointmap(pm.pixels, pm.points, {255.5, 191.5});
  EXPECT_LT(std::abs(robust / 500 - 1), 0.5 * std::abs(ls / 500 - 1));
}

TEST(FocalFromPointmap, RefusesTooFewOrDegeneratePoints) {
  Pointmap pm = MakePointmap(500, 32, 32, 0, 0, 1, 16);  // 4 points
  EXPECT_EQ(FocalFromPointmap(pm.pixels, pm.points, {15.5, 15.5}), 0);
  pm = MakePointmap(500, 64, 64, 0, 0, 1, 4);
  for (auto& p : pm.points) p.z() = -p.z();  // all behind the camera
  EXPECT_EQ(FocalFromPointmap(pm.pixels, pm.points, {31.5, 31.5}), 0);
  pm = MakePointmap(500, 64, 64, 0, 0, 1, 4);
  for (auto& p : pm.points) p.x() = p.y() = std::nan("");
  EXPECT_EQ(FocalFromPointmap(pm.pixels, pm.points, {31.5, 31.5}), 0);
}

}  // namespace
}  // namespace freeloc::geometry
