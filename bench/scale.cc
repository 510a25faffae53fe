// bench/scale — metric scale from degraded depth: the official map-free D.Scale vs freeloc's robust variant on the
// same synthetic scenes (ray-cast room, two views, 400 correspondences with 0.5 px noise, true R and t̂ given so
// only the scale step is measured). Depth is degraded like a monocular estimate: a per-image global scale error,
// smooth multiplicative noise, outlier blobs and invalid holes. Reports the median and 90th percentile of
// |s − s_true| / s_true, and how well each method's confidence ranks the errors (Spearman correlation between
// confidence and −error; 1 = perfect ranking).
//
//   scale [--scenes N]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numeric>

#include "bench_util.h"
#include "freeloc/geometry/metric_scale.h"
#include "testing/synthetic_scene.h"

using namespace freeloc;
using freeloc::bench::Fmt;

namespace {

std::vector<double> Ranks(const std::vector<double>& v) {
  std::vector<size_t> idx(v.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (size_t i = 0; i < idx.size();) {
    size_t j = i;
    while (j + 1 < idx.size() && v[idx[j + 1]] == v[idx[i]]) ++j;
    for (size_t k = i; k <= j; ++k) r[idx[k]] = 0.5 * (i + j);
    i = j + 1;
  }
  return r;
}

double Spearman(const std::vector<double>& a, const std::vector<double>& b) {
  const auto ra = Ranks(a), rb = Ranks(b);
  const double ma = std::accumulate(ra.begin(), ra.end(), 0.0) / ra.size();
  const double mb = std::accumulate(rb.begin(), rb.end(), 0.0) / rb.size();
  double num = 0, da = 0, db = 0;
  for (size_t i = 0; i < ra.size(); ++i) {
    num += (ra[i] - ma) * (rb[i] - mb);
    da += (ra[i] - ma) * (ra[i] - ma);
    db += (rb[i] - mb) * (rb[i] - mb);
  }
  return num / std::sqrt(da * db + 1e-300);
}

double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

}  // namespace

int main(int argc, char** argv) {
  int scenes = 200;
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "--scenes") && i + 1 < argc) scenes = std::atoi(argv[++i]);
  std::printf("## bench/scale — %d synthetic scenes per row, 400 correspondences, true R and t̂\n\n", scenes);
  bench::MarkdownTable t({"depth degradation", "method", "median rel. err", "p90 rel. err", "failures",
                          "Spearman(conf, −err)", "median ms"});
  struct Degr {
    const char* name;
    double global, smooth, outliers, holes;
  };
  const Degr rows[] = {{"exact", 0, 0, 0, 0},
                       {"global 5 % only", 0.05, 0, 0, 0},
                       {"smooth 5 % only", 0, 0.05, 0, 0},
                       {"outliers 20 % + holes 10 % only", 0, 0, 0.20, 0.10},
                       {"global 5 %, smooth 5 %, outliers 10 %, holes 5 %", 0.05, 0.05, 0.10, 0.05},
                       {"global 10 %, smooth 10 %, outliers 20 %, holes 10 %", 0.10, 0.10, 0.20, 0.10},
                       {"global 10 %, smooth 10 %, outliers 30 %, holes 10 %", 0.10, 0.10, 0.30, 0.10}};
  for (const Degr& dg : rows) {
    for (auto method : {geometry::ScaleMethod::kOfficial, geometry::ScaleMethod::kRobust}) {
      std::vector<double> err, conf, ms;
      int fail = 0;
      for (int s = 0; s < scenes; ++s) {
        const testing::SyntheticScene sc = testing::MakeRoomScene(1000 + s, 0.3 + 0.7 * ((s * 37) % 100) / 100.0);
        std::vector<Eigen::Vector2d> p1, p2;
        sc.Correspondences(400, 0.5, 5000 + s, &p1, &p2);
        const DepthMap dr = testing::DegradeDepth(sc.depth_ref, 7 * s + 1, dg.global, dg.smooth, dg.outliers, dg.holes);
        const DepthMap dq =
            testing::DegradeDepth(sc.depth_query, 7 * s + 2, dg.global, dg.smooth, dg.outliers, dg.holes);
        Rigid3d unit = sc.query_from_ref;
        const double truth = unit.translation.norm();
        unit.translation.normalize();
        geometry::ScaleOptions o;
        o.method = method;
        const double t0 = bench::NowSeconds();
        const auto r = geometry::EstimateMetricScale(p1, p2, unit, dr, dq, sc.ref, sc.query, o);
        ms.push_back((bench::NowSeconds() - t0) * 1e3);
        if (!r.success()) {
          ++fail;
          continue;
        }
        err.push_back(std::abs(r.scale - truth) / truth);
        conf.push_back(r.confidence);
      }
      std::vector<double> neg(err.size());
      for (size_t i = 0; i < err.size(); ++i) neg[i] = -err[i];
      t.Row({dg.name, freeloc::ToString(method), Fmt("%.4f", Percentile(err, 0.5)), Fmt("%.4f", Percentile(err, 0.9)),
             std::to_string(fail), Fmt("%.3f", Spearman(conf, neg)), Fmt("%.2f", bench::Median(ms))});
    }
  }
  t.Print();
  return 0;
}
