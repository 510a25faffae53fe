// A small ray-cast synthetic scene for geometry tests and benchmarks: a room (floor, ceiling, three walls) with a
// box in it, two pinhole cameras, exact depth maps for both, correspondences with pixel noise, and monocular-style
// depth degradation (global scale error, smooth multiplicative noise, outlier blobs, holes). Header-only.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/rigid3d.h"

namespace freeloc::testing {

struct Plane {
  Eigen::Vector3d n;                                                                          // unit normal
  double h;                                                                                   // n·X = h
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(-1e9), hi = Eigen::Vector3d::Constant(1e9);  // bounds (boxes)
};

struct SyntheticScene {
  std::vector<Plane> planes;
  Camera ref, query;
  Rigid3d query_from_ref;  // world = reference camera
  DepthMap depth_ref, depth_query;

  // The first surface along the ray c + λ·d: λ (0 when nothing is hit) and the plane's index (−1).
  double FirstHit(const Eigen::Vector3d& c, const Eigen::Vector3d& d, int* plane = nullptr) const {
    double best = 0;
    int which = -1;
    for (size_t k = 0; k < planes.size(); ++k) {
      const Plane& p = planes[k];
      const double den = p.n.dot(d);
      if (std::abs(den) < 1e-12) continue;
      const double lam = (p.h - p.n.dot(c)) / den;
      if (lam <= 1e-6) continue;
      const Eigen::Vector3d X = c + lam * d;
      if ((X.array() < p.lo.array() - 1e-9).any() || (X.array() > p.hi.array() + 1e-9).any()) continue;
      if (best == 0 || lam < best) best = lam, which = static_cast<int>(k);
    }
    if (plane) *plane = which;
    return best;
  }

  // Depth (camera z) of the first surface along pixel (u, v) of a camera with pose cam_from_world.
  double RayCast(const Camera& cam, const Rigid3d& cam_from_world, double u, double v) const {
    return FirstHit(cam_from_world.Center(), cam_from_world.R().transpose() * cam.Unproject(u, v));
  }

  DepthMap Render(const Camera& cam, const Rigid3d& cam_from_world) const {
    DepthMap d(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) d.at(x, y) = static_cast<float>(RayCast(cam, cam_from_world, x, y));
    return d;
  }

  // Correspondences: random reference pixels whose 3D point is visible (not occluded) in the query.
  void Correspondences(int n, double noise_px, uint32_t seed, std::vector<Eigen::Vector2d>* p1,
                       std::vector<Eigen::Vector2d>* p2) const {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(0, ref.width - 1), uy(0, ref.height - 1);
    std::normal_distribution<double> g(0, noise_px);
    int guard = 0;
    while (static_cast<int>(p1->size()) < n && guard++ < 100 * n) {
      const Eigen::Vector2d a(ux(rng), uy(rng));
      const double dr = RayCast(ref, Rigid3d(), a.x(), a.y());
      if (dr <= 0) continue;
      const Eigen::Vector3d X = dr * ref.Unproject(a.x(), a.y());
      const Eigen::Vector3d Y = query_from_ref * X;
      if (Y.z() <= 0.05) continue;
      const Eigen::Vector2d b = query.Project(Y);
      if (b.x() < 0 || b.y() < 0 || b.x() > query.width - 1 || b.y() > query.height - 1) continue;
      const double dq = RayCast(query, query_from_ref, b.x(), b.y());
      if (std::abs(dq - Y.z()) > 1e-3 * Y.z()) continue;  // occluded
      p1->push_back(a + Eigen::Vector2d(g(rng), g(rng)));
      p2->push_back(b + Eigen::Vector2d(g(rng), g(rng)));
    }
  }
};

// A room 6 m wide, 3 m high, back wall at z = 7, with a box; the query camera moved by `baseline` metres.
inline SyntheticScene MakeRoomScene(uint32_t seed, double baseline = 0.5, int width = 160, int height = 120) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  SyntheticScene s;
  s.planes = {
      {{0, 0, -1}, -7},    // back wall z = 7
      {{0, -1, 0}, -1.5},  // floor y = 1.5 (y down)
      {{0, 1, 0}, -1.5},   // ceiling y = −1.5
      {{1, 0, 0}, -3},     // left wall x = −3
      {{-1, 0, 0}, -3},    // right wall x = 3
  };
  // Box front face z = 3.5 + jitter, x ∈ [−1.2, 0.3], y ∈ [0, 1.5], and its left side.
  const double zf = 3.5 + 0.5 * u(rng);
  Plane front{{0, 0, -1}, -zf};
  front.lo = {-1.2, 0, -1e9};
  front.hi = {0.3, 1.5, 1e9};
  Plane side{{-1, 0, 0}, 1.2};
  side.lo = {-1e9, 0, zf};
  side.hi = {1e9, 1.5, zf + 1.0};
  s.planes.push_back(front);
  s.planes.push_back(side);
  const double f = 0.9 * width;
  s.ref = Camera{f, f, (width - 1) / 2.0, (height - 1) / 2.0, width, height};
  s.query = Camera{f * 1.02, f * 1.01, (width - 1) / 2.0 + 2, (height - 1) / 2.0 - 1, width, height};
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.15 * u(rng), axis));
  const Eigen::Vector3d centre = Eigen::Vector3d(u(rng), 0.3 * u(rng), 0.5 * u(rng)).normalized() * baseline;
  s.query_from_ref = Rigid3d(q, -(q * centre));
  s.depth_ref = s.Render(s.ref, Rigid3d());
  s.depth_query = s.Render(s.query, s.query_from_ref);
  return s;
}

// Monocular-style degradation: depth × global factor × smooth field, outlier blobs, invalid holes.
inline DepthMap DegradeDepth(const DepthMap& in, uint32_t seed, double global_sigma, double smooth_amp,
                             double outlier_frac, double hole_frac) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  DepthMap d = in;
  const double global = std::exp(global_sigma * g(rng));
  const double fx1 = 0.5 + u01(rng), fy1 = 0.5 + u01(rng), ph1 = 6.28 * u01(rng), ph2 = 6.28 * u01(rng);
  for (int y = 0; y < d.height; ++y)
    for (int x = 0; x < d.width; ++x) {
      const double sx = static_cast<double>(x) / d.width, sy = static_cast<double>(y) / d.height;
      const double field = 1 + smooth_amp * (std::sin(6.28 * fx1 * sx + ph1) * std::cos(6.28 * fy1 * sy + ph2));
      d.at(x, y) = static_cast<float>(d.at(x, y) * global * field);
    }
  // Outlier blobs: discs whose depth is replaced by a wrong constant, until the fraction is covered.
  const int total = d.width * d.height;
  int covered = 0;
  while (covered < outlier_frac * total) {
    const int cx = static_cast<int>(u01(rng) * d.width), cy = static_cast<int>(u01(rng) * d.height);
    const int r = 3 + static_cast<int>(u01(rng) * d.width / 12);
    const float wrong = static_cast<float>(0.5 + 8 * u01(rng));
    for (int y = std::max(0, cy - r); y < std::min(d.height, cy + r); ++y)
      for (int x = std::max(0, cx - r); x < std::min(d.width, cx + r); ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) < r * r) {
          d.at(x, y) = wrong;
          ++covered;
        }
  }
  for (int i = 0; i < hole_frac * total; ++i) {
    d.data[static_cast<size_t>(u01(rng) * total) % d.data.size()] = 0.f;
  }
  return d;
}

// Monocular-like depth, each part drawn from `seed`:
//  * a per-image global scale error, log-normal with σ = `log_sigma`, clipped to ×[0.5, 1.5];
//  * an additive shift, uniform in ±`shift_m`;
//  * a smooth low-frequency multiplicative field of amplitude uniform in [field_min, field_max];
//  * depth edges bled 2–4 px into the neighbouring surface (the nearer surface spreads: the map's min filter wherever
//    the window holds a depth step of more than 10 %);
//  * `salt` of the pixels replaced by the true depth × U(0.3, 3);
//  * `holes` of the pixels set invalid (0).
struct MonoDepthOptions {
  double log_sigma = 0.2, shift_m = 0.15, field_min = 0.05, field_max = 0.10, salt = 0.01, holes = 0.05;
  int bleed_min_px = 2, bleed_max_px = 4;
};
inline DepthMap DegradeDepthMonocular(const DepthMap& in, uint32_t seed, const MonoDepthOptions& o = {}) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  const double global = std::clamp(std::exp(o.log_sigma * g(rng)), 0.5, 1.5);
  const double shift = o.shift_m * (2 * u01(rng) - 1);
  const double amp = o.field_min + (o.field_max - o.field_min) * u01(rng);
  const double fx1 = 0.4 + 0.8 * u01(rng), fy1 = 0.4 + 0.8 * u01(rng), ph1 = 6.28 * u01(rng), ph2 = 6.28 * u01(rng);
  const int bleed = o.bleed_min_px + static_cast<int>(u01(rng) * (o.bleed_max_px - o.bleed_min_px + 1));
  const int w = in.width, h = in.height;
  // Edge bleeding on the true depth: separable min / max filters of radius `bleed` (invalid pixels ignored).
  auto at = [w](int x, int y) { return static_cast<size_t>(y) * w + x; };
  auto pass = [&](const std::vector<float>& src, bool along_x, bool take_min) {
    std::vector<float> out(src.size());
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int pos = along_x ? x : y, len = along_x ? w : h;
        float v = src[at(x, y)];
        for (int k = std::max(0, pos - bleed); k <= std::min(len - 1, pos + bleed); ++k) {
          const float c = src[along_x ? at(k, y) : at(x, k)];
          if (c > 0) v = take_min ? (v > 0 ? std::min(v, c) : c) : std::max(v, c);
        }
        out[at(x, y)] = v;
      }
    return out;
  };
  auto filter = [&](const std::vector<float>& src, bool take_min) {
    return pass(pass(src, true, take_min), false, take_min);
  };
  const std::vector<float> lo = filter(in.data, true), hi = filter(in.data, false);
  DepthMap d = in;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      float v = in.data[i];
      if (!(v > 0)) continue;
      if (hi[i] > 1.1f * lo[i]) v = lo[i];  // a depth step within the window: the nearer surface bleeds over
      const double sx = static_cast<double>(x) / w, sy = static_cast<double>(y) / h;
      const double field = 1 + amp * std::sin(6.28 * fx1 * sx + ph1) * std::cos(6.28 * fy1 * sy + ph2);
      d.data[i] = static_cast<float>(std::max(0.05, v * global * field + shift));
    }
  const int total = w * h;
  for (int k = 0; k < o.salt * total; ++k) {
    const size_t i = static_cast<size_t>(u01(rng) * total) % d.data.size();
    if (in.data[i] > 0) d.data[i] = static_cast<float>(in.data[i] * (0.3 + 2.7 * u01(rng)));
  }
  for (int k = 0; k < o.holes * total; ++k) d.data[static_cast<size_t>(u01(rng) * total) % d.data.size()] = 0.f;
  return d;
}

}  // namespace freeloc::testing
