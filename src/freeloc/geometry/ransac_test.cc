// The search that runs beside another (ConcurrentSearch, ransac.h): cut at k iterations, it reports exactly what the
// same search with max_iterations = k finds — the weak-support control relies on it. Seeded 2D line fits.
#include "freeloc/geometry/ransac.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <random>
#include <thread>

namespace freeloc::geometry {
namespace {

// Lines a·x + b·y = c (unit normal) through two points; error: squared distance.
struct LineEstimator {
  using Model = Eigen::Vector3d;
  static constexpr int kSampleSize = 2;
  std::vector<Eigen::Vector2d> pts;
  size_t num_data() const { return pts.size(); }
  void MinimalSolve(const int* s, std::vector<Model>* models) const {
    const Eigen::Vector2d d = pts[s[1]] - pts[s[0]];
    if (d.norm() < 1e-12) return;
    const Eigen::Vector2d nrm = Eigen::Vector2d(-d.y(), d.x()).normalized();
    models->push_back({nrm.x(), nrm.y(), nrm.dot(pts[s[0]])});
  }
  double SquaredError(const Model& m, size_t i) const {
    const double e = m.x() * pts[i].x() + m.y() * pts[i].y() - m.z();
    return e * e;
  }
  void LocalOptimize(Model*, double) const {}
};

LineEstimator MakeLines(int n, double inlier_share, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-10, 10);
  std::normal_distribution<double> g(0, 0.01);
  LineEstimator e;
  for (int i = 0; i < n; ++i) {
    const double x = u(rng);
    e.pts.emplace_back(x, i < inlier_share * n ? 0.5 * x + 1 + g(rng) : u(rng));
  }
  return e;
}

TEST(ConcurrentSearch, CutAtKIsTheSearchWithMaxIterationsK) {
  for (const double share : {0.03, 0.08, 0.3}) {
    const LineEstimator est = MakeLines(400, share, 3);
    RansacOptions opt(/*success_prob=*/0.999, /*min_iterations=*/5, /*max_iterations=*/5000, /*max_seconds=*/0);
    opt.seed = 9;
    opt.sprt_min_data = 0;
    int improvements_seen = 0;
    for (const int k : {5, 17, 60, 250, 1000, 5000}) {
      RansacOptions ok = opt;
      ok.max_iterations = k;
      Eigen::Vector3d m;
      const RansacStats st = Ransac(est, ok, 1e-3, &m);
      const int expected = st.found() ? st.num_inliers : 0;
      ConcurrentSearch search([&](RansacTrace* trace) {
        Eigen::Vector3d mm;
        Ransac(est, opt, 1e-3, &mm, trace);
      });
      if (k > 100) std::this_thread::sleep_for(std::chrono::milliseconds(2));  // let it run past k sometimes
      EXPECT_EQ(search.BestInliersAfter(k), expected) << "share " << share << ", k " << k;
      improvements_seen += expected > 0;
    }
    EXPECT_GT(improvements_seen, 0);
  }
}

// Destroyed without being asked: it stops and joins (no thread left running on the estimator).
TEST(ConcurrentSearch, DestroyedUnaskedStopsTheSearch) {
  const LineEstimator est = MakeLines(2000, 0.01, 4);
  RansacOptions opt;
  opt.max_iterations = 100000000;
  opt.min_iterations = 100000000;
  const auto t0 = std::chrono::steady_clock::now();
  {
    ConcurrentSearch search([&](RansacTrace* trace) {
      Eigen::Vector3d m;
      Ransac(est, opt, 1e-6, &m, trace);
    });
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
}

}  // namespace
}  // namespace freeloc::geometry
