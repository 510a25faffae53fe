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

namespace {

// Pixels with a finite point in front of the camera and a confidence above the quantile.
std::vector<uint8_t> ValidPixels(const float* pts, const float* conf, size_t n, double quantile) {
  std::vector<uint8_t> valid(n, 0);
  float thr = -1e30f;
  if (conf) {
    std::vector<float> c(conf, conf + n);
    std::nth_element(c.begin(), c.begin() + static_cast<long>(quantile * (n - 1)), c.end());
    thr = c[static_cast<size_t>(quantile * (n - 1))];
  }
  for (size_t i = 0; i < n; ++i) {
    const float* p = pts + 3 * i;
    valid[i] =
        std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]) && p[2] > 0 && (!conf || conf[i] >= thr);
  }
  return valid;
}

// Unit normals from central differences (forward at the border).
std::vector<std::array<double, 3>> Normals(const float* pts, int h, int w) {
  auto P = [&](int x, int y) {
    const float* p = pts + 3 * (static_cast<size_t>(y) * w + x);
    return std::array<double, 3>{p[0], p[1], p[2]};
  };
  std::vector<std::array<double, 3>> nrm(static_cast<size_t>(h) * w, {0, 0, 0});
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
  return nrm;
}

// Union-find over the pixels (deterministic: the smallest index is the root).
struct Components {
  std::vector<int> parent;
  explicit Components(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int Find(int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void Unite(int a, int b) {
    a = Find(a);
    b = Find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

// Labels 1…max_instances for the components of at least min_area, by total confidence; 0 elsewhere.
std::vector<uint16_t> RankComponents(Components& cc, const std::vector<uint8_t>& valid, const float* conf,
                                     const ProposalOptions& o) {
  const size_t n = valid.size();
  std::vector<size_t> area;
  std::vector<double> score;
  std::vector<int> index(n, -1);
  for (size_t i = 0; i < n; ++i) {
    if (!valid[i]) continue;
    const int r = cc.Find(static_cast<int>(i));
    if (index[r] < 0) {
      index[r] = static_cast<int>(area.size());
      area.push_back(0);
      score.push_back(0);
    }
    ++area[static_cast<size_t>(index[r])];
    score[static_cast<size_t>(index[r])] += conf ? conf[i] : 1.0;
  }
  std::vector<size_t> order;
  for (size_t k = 0; k < area.size(); ++k)
    if (area[k] >= o.min_area * n) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return score[a] > score[b]; });
  if (order.size() > static_cast<size_t>(o.max_instances)) order.resize(static_cast<size_t>(o.max_instances));
  std::vector<uint16_t> label_of(area.size(), 0);
  for (size_t r = 0; r < order.size(); ++r) label_of[order[r]] = static_cast<uint16_t>(r + 1);
  std::vector<uint16_t> labels(n, 0);
  for (size_t i = 0; i < n; ++i)
    if (valid[i]) labels[i] = label_of[static_cast<size_t>(index[cc.Find(static_cast<int>(i))])];
  return labels;
}

// One pixel of dilation into unlabelled neighbours (closes the break lines), lowest label wins.
std::vector<uint16_t> Dilate(const std::vector<uint16_t>& labels, int h, int w) {
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

}  // namespace

std::vector<uint16_t> ProposeInstances(const float* pts, const float* conf, int h, int w, const ProposalOptions& o) {
  o.Validate();
  const size_t n = static_cast<size_t>(h) * w;
  const std::vector<uint8_t> valid = ValidPixels(pts, conf, n, o.conf_quantile);
  const std::vector<std::array<double, 3>> nrm = Normals(pts, h, w);
  const double cos_thr = std::cos(o.normal_angle_deg * M_PI / 180.0);
  auto joined = [&](size_t i, size_t j) {
    if (!valid[i] || !valid[j]) return false;
    const double zi = pts[3 * i + 2], zj = pts[3 * j + 2];
    if (std::abs(zi - zj) > o.depth_jump * std::min(zi, zj)) return false;
    const auto& a = nrm[i];
    const auto& b = nrm[j];
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] >= cos_thr;
  };
  Components cc(n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (x + 1 < w && joined(i, i + 1)) cc.Unite(static_cast<int>(i), static_cast<int>(i + 1));
      if (y + 1 < h && joined(i, i + w)) cc.Unite(static_cast<int>(i), static_cast<int>(i + w));
    }
  return Dilate(RankComponents(cc, valid, conf, o), h, w);
}

std::vector<uint16_t> ProposalsToImage(const std::vector<uint16_t>& labels, const vision::Dust3rInput& in) {
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
