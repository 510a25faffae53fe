#include "freeloc/geometry/focal_from_pointmap.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace freeloc::geometry {

namespace {

// One weighted least-squares step of q ≈ g·u: g = Σ w u·q / Σ w u·u (0 when degenerate).
template <typename Weight>
double Step(const std::vector<Eigen::Vector2d>& u, const std::vector<Eigen::Vector2d>& q, const Weight& weight) {
  double num = 0, den = 0;
  for (size_t i = 0; i < u.size(); ++i) {
    const double w = weight(i);
    num += w * u[i].dot(q[i]);
    den += w * u[i].squaredNorm();
  }
  return den > 0 && num > 0 ? num / den : 0;
}

}  // namespace

double FocalFromPointmap(const std::vector<Eigen::Vector2d>& pixels, const std::vector<Eigen::Vector3d>& points,
                         const Eigen::Vector2d& pp, const FocalFromPointmapOptions& o) {
  const size_t n = std::min(pixels.size(), points.size());
  std::vector<Eigen::Vector2d> u, q;  // centred pixels (exact: the pixel grid), rays (X/Z, Y/Z: the network's, noisy)
  u.reserve(n);
  q.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = points[i];
    if (!p.allFinite() || !(p.z() > 0) || !pixels[i].allFinite()) continue;
    const Eigen::Vector2d r(p.x() / p.z(), p.y() / p.z());
    if (!r.allFinite()) continue;
    u.push_back(pixels[i] - pp);
    q.push_back(r);
  }
  if (u.size() < 8) return 0;
  // The noise is in the rays, not in the pixels, so the rays are regressed on the pixels — q ≈ g·u with g = 1/f —
  // which leaves noisy rays unbiased (regressing the pixels on noisy rays shrinks f by var(noise)/var(ray): 3 % for a
  // 1200 px focal and 2 % noise).
  double g = Step(u, q, [](size_t) { return 1.0; });
  if (!(g > 0)) return 0;
  std::vector<double> r(u.size());
  const auto residuals = [&] {
    for (size_t i = 0; i < u.size(); ++i) r[i] = (q[i] - g * u[i]).norm();
  };
  // Weiszfeld: each point weighted by the inverse of its residual's length (floored, so that an exact point does not
  // take all the weight) — each step decreases the sum of distances.
  for (int it = 0; it < o.max_iterations; ++it) {
    residuals();
    const double next = Step(u, q, [&](size_t i) { return 1.0 / std::max(r[i], 1e-9); });
    if (!(next > 0)) return 0;
    const bool done = std::abs(next - g) <= o.tolerance * g;
    g = next;
    if (done) break;
  }
  // The sum of distances still lets far-off points pull (a wrong point at a wide angle weighs like a right one):
  // finish with Tukey's biweight, its scale from the median residual, which gives wrong points no weight at all.
  for (int it = 0; it < o.max_iterations; ++it) {
    residuals();
    std::vector<double> sorted = r;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double c = std::max(4.0 * sorted[sorted.size() / 2], 1e-12);  // ≈ 3.4 σ for a 2-D Gaussian residual
    const double next = Step(u, q, [&](size_t i) {
      if (r[i] >= c) return 0.0;
      const double a = 1 - (r[i] / c) * (r[i] / c);
      return a * a;
    });
    if (!(next > 0)) break;
    const bool done = std::abs(next - g) <= o.tolerance * g;
    g = next;
    if (done) break;
  }
  const double f = 1.0 / g;
  return std::isfinite(f) && f > 0 ? f : 0;
}

}  // namespace freeloc::geometry
