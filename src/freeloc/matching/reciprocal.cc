#include "freeloc/matching/reciprocal.h"

#include <algorithm>
#include <limits>
#include <nanoflann.hpp>
#include <thread>

#include "freeloc/core/error.h"

namespace freeloc::matching {

void ReciprocalOptions::Validate() const {
  FREELOC_CHECK(subsample >= 1, "matching: subsample must be >= 1");
  FREELOC_CHECK(threads >= 0, "matching: threads must be >= 0");
}

namespace {

struct Cloud {
  std::vector<double> xyz;  // n×3
  std::vector<int> pixel;   // row-major pixel index
  size_t kdtree_get_point_count() const { return pixel.size(); }
  double kdtree_get_pt(size_t i, size_t d) const { return xyz[3 * i + d]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3, size_t>;

Cloud Gather(const PointmapView& v, const ReciprocalOptions& o, bool subsample) {
  FREELOC_CHECK(v.pts && v.height > 0 && v.width > 0, "matching: empty pointmap");
  Cloud c;
  const int k = subsample ? o.subsample : 1;
  for (int y = 0; y < v.height; ++y) {
    if (y % k) continue;
    for (int x = 0; x < v.width; ++x) {
      if (x % k) continue;
      const int i = y * v.width + x;
      if (v.mask && !v.mask[i]) continue;
      if (v.conf && !(v.conf[i] >= o.conf_threshold)) continue;
      const float* p = v.pts + 3 * static_cast<size_t>(i);
      if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) continue;
      c.xyz.insert(c.xyz.end(), {p[0], p[1], p[2]});
      c.pixel.push_back(i);
    }
  }
  return c;
}

// Nearest neighbour in `tree` of every point of `queries`, in parallel.
std::vector<int> NearestAll(const Tree& tree, const Cloud& queries, int threads) {
  std::vector<int> out(queries.pixel.size(), -1);
  const int nt = std::max(1, threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency()));
  auto work = [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      size_t idx = 0;
      double d2 = 0;
      nanoflann::KNNResultSet<double, size_t> rs(1);
      rs.init(&idx, &d2);
      tree.findNeighbors(rs, &queries.xyz[3 * i], nanoflann::SearchParams(0, 0.0, false));
      out[i] = static_cast<int>(idx);
    }
  };
  const size_t n = out.size();
  if (nt == 1 || n < 4096) {
    work(0, n);
    return out;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < nt; ++t) pool.emplace_back(work, n * t / nt, n * (t + 1) / nt);
  for (auto& th : pool) th.join();
  return out;
}

std::vector<PixelMatch> Assemble(const PointmapView& v1, const PointmapView& v2, const Cloud& c1, const Cloud& c2,
                                 const std::vector<int>& nn1_in_2, const std::vector<int>& nn2_in_1) {
  std::vector<PixelMatch> m;
  for (size_t j = 0; j < c2.pixel.size(); ++j) {
    const int i = nn2_in_1[j];
    if (i < 0 || nn1_in_2[static_cast<size_t>(i)] != static_cast<int>(j)) continue;
    const int p1 = c1.pixel[static_cast<size_t>(i)], p2 = c2.pixel[j];
    m.push_back({p1 % v1.width, p1 / v1.width, p2 % v2.width, p2 / v2.width, v1.conf ? v1.conf[p1] : 0.f,
                 v2.conf ? v2.conf[p2] : 0.f});
  }
  return m;
}

}  // namespace

std::vector<PixelMatch> ReciprocalMatches(const PointmapView& v1, const PointmapView& v2, const ReciprocalOptions& o) {
  o.Validate();
  const Cloud c1 = Gather(v1, o, false), c2 = Gather(v2, o, true);
  if (c1.pixel.empty() || c2.pixel.empty()) return {};
  Tree t1(3, c1, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  Tree t2(3, c2, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  std::thread build([&] { t1.buildIndex(); });
  t2.buildIndex();
  build.join();
  const std::vector<int> nn1_in_2 = NearestAll(t2, c1, o.threads);
  const std::vector<int> nn2_in_1 = NearestAll(t1, c2, o.threads);
  return Assemble(v1, v2, c1, c2, nn1_in_2, nn2_in_1);
}

std::vector<PixelMatch> ReciprocalMatchesBruteForce(const PointmapView& v1, const PointmapView& v2,
                                                    const ReciprocalOptions& o) {
  o.Validate();
  const Cloud c1 = Gather(v1, o, false), c2 = Gather(v2, o, true);
  if (c1.pixel.empty() || c2.pixel.empty()) return {};
  auto nearest = [](const Cloud& from, const Cloud& to) {
    std::vector<int> out(from.pixel.size());
    for (size_t i = 0; i < from.pixel.size(); ++i) {
      double best = std::numeric_limits<double>::infinity();
      int arg = -1;
      for (size_t j = 0; j < to.pixel.size(); ++j) {
        const double dx = from.xyz[3 * i] - to.xyz[3 * j], dy = from.xyz[3 * i + 1] - to.xyz[3 * j + 1],
                     dz = from.xyz[3 * i + 2] - to.xyz[3 * j + 2];
        const double d = dx * dx + dy * dy + dz * dz;
        if (d < best) {
          best = d;
          arg = static_cast<int>(j);
        }
      }
      out[i] = arg;
    }
    return out;
  };
  return Assemble(v1, v2, c1, c2, nearest(c1, c2), nearest(c2, c1));
}

}  // namespace freeloc::matching
