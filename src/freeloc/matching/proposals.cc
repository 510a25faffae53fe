#include "freeloc/matching/proposals.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numeric>

#include "freeloc/core/error.h"

namespace freeloc::matching {

void ProposalOptions::Validate() const {
  FREELOC_CHECK(conf_quantile >= 0 && conf_quantile < 1, "proposals: conf_quantile must be in [0, 1)");
  FREELOC_CHECK(depth_jump > 0 && normal_angle_deg > 0 && min_area >= 0 && max_instances >= 1,
                "proposals: thresholds must be positive");
}

std::vector<uint16_t> ProposeInstances(const float* pts, const float* conf, int h, int w, const ProposalOptions& o) {
  o.Validate();
  const size_t n = static_cast<size_t>(h) * w;
  std::vector<uint8_t> valid(n, 0);
  float thr = -1e30f;
  if (conf) {
    std::vector<float> c(conf, conf + n);
    std::nth_element(c.begin(), c.begin() + static_cast<long>(o.conf_quantile * (n - 1)), c.end());
    thr = c[static_cast<size_t>(o.conf_quantile * (n - 1))];
  }
  for (size_t i = 0; i < n; ++i) {
    const float* p = pts + 3 * i;
    valid[i] =
        std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]) && p[2] > 0 && (!conf || conf[i] >= thr);
  }
  auto P = [&](int x, int y) {
    const float* p = pts + 3 * (static_cast<size_t>(y) * w + x);
    return std::array<double, 3>{p[0], p[1], p[2]};
  };
  // Normals from central differences (forward at the border).
  std::vector<std::array<double, 3>> nrm(n, {0, 0, 0});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int x0 = std::max(0, x - 1), x1 = std::min(w - 1, x + 1), y0 = std::max(0, y - 1),
                y1 = std::min(h - 1, y + 1);
      const auto a = P(x1, y), b = P(x0, y), c = P(x, y1), d = P(x, y0);
      const double u[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]}, v[3] = {c[0] - d[0], c[1] - d[1], c[2] - d[2]};
      std::array<double, 3> q = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
      if (len > 0)
        for (double& e : q) e /= len;
      nrm[static_cast<size_t>(y) * w + x] = q;
    }
  const double cos_thr = std::cos(o.normal_angle_deg * M_PI / 180.0);
  auto joined = [&](size_t i, size_t j) {
    if (!valid[i] || !valid[j]) return false;
    const double zi = pts[3 * i + 2], zj = pts[3 * j + 2];
    if (std::abs(zi - zj) > o.depth_jump * std::min(zi, zj)) return false;
    const auto& a = nrm[i];
    const auto& b = nrm[j];
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] >= cos_thr;
  };
  // Connected components with union-find (deterministic: smallest index is the root).
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  std::function<int(int)> find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto unite = [&](int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (x + 1 < w && joined(i, i + 1)) unite(static_cast<int>(i), static_cast<int>(i + 1));
      if (y + 1 < h && joined(i, i + w)) unite(static_cast<int>(i), static_cast<int>(i + w));
    }
  struct Comp {
    int root;
    size_t area = 0;
    double conf = 0;
  };
  std::vector<Comp> comps;
  std::vector<int> index(n, -1);
  for (size_t i = 0; i < n; ++i) {
    if (!valid[i]) continue;
    const int r = find(static_cast<int>(i));
    if (index[r] < 0) {
      index[r] = static_cast<int>(comps.size());
      comps.push_back({r});
    }
    Comp& c = comps[static_cast<size_t>(index[r])];
    ++c.area;
    c.conf += conf ? conf[i] : 1.0;
  }
  std::vector<size_t> order;
  for (size_t k = 0; k < comps.size(); ++k)
    if (comps[k].area >= o.min_area * n) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return comps[a].conf > comps[b].conf; });
  if (order.size() > static_cast<size_t>(o.max_instances)) order.resize(static_cast<size_t>(o.max_instances));
  std::vector<uint16_t> label_of(comps.size(), 0);
  for (size_t r = 0; r < order.size(); ++r) label_of[order[r]] = static_cast<uint16_t>(r + 1);
  std::vector<uint16_t> labels(n, 0);
  for (size_t i = 0; i < n; ++i)
    if (valid[i]) labels[i] = label_of[static_cast<size_t>(index[find(static_cast<int>(i))])];
  // One pixel of dilation into unlabelled neighbours (closes the break lines), lowest label wins.
  std::vector<uint16_t> grown = labels;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (labels[i]) continue;
      uint16_t best = 0;
      for (auto [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int xx = x + dx, yy = y + dy;
        if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
        const uint16_t l = labels[static_cast<size_t>(yy) * w + xx];
        if (l && (!best || l < best)) best = l;
      }
      grown[i] = best;
    }
  return grown;
}

std::vector<uint16_t> ProposalsToImage(const std::vector<uint16_t>& labels, const Dust3rInput& in) {
  std::vector<uint16_t> out(static_cast<size_t>(in.orig_width) * in.orig_height, 0);
  for (int y = 0; y < in.orig_height; ++y)
    for (int x = 0; x < in.orig_width; ++x) {
      double xn, yn;
      in.ToNetwork(x, y, &xn, &yn);
      const int xi = static_cast<int>(std::lround(xn)), yi = static_cast<int>(std::lround(yn));
      if (xi < 0 || yi < 0 || xi >= in.width() || yi >= in.height()) continue;
      out[static_cast<size_t>(y) * in.orig_width + x] = labels[static_cast<size_t>(yi) * in.width() + xi];
    }
  return out;
}

}  // namespace freeloc::matching
