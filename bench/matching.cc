// bench/matching — reciprocal 3D nearest-neighbour matching of 512×384 pointmaps (196,608 points per side) of a
// realistic surface (the ray-cast room of tests/testing/synthetic_scene.h seen from two cameras, view 2's points
// in view 1's frame, 1 mm noise): freeloc's KD-tree matcher on 2 threads; the brute-force reference on a 128×96
// version of the same scene in the same run (full-size brute force is ~4·10¹⁰ distance evaluations), with the
// match sets compared. Target: ≤ 250 ms at full size on this machine.
// Then MASt3R's fast reciprocal NN on 512×384 descriptor maps with D = 24 (a smooth unit-vector field, view 2 a
// warped copy of view 1 plus noise — the shape of real MASt3R descriptors), subsample 8: the screened kernels
// (int8 VNNI where the CPU has it, float32) against the exhaustive reference in the same run, lists compared row by
// row. Target: ≤ 150 ms on 2 threads, identical to brute force.
//
//   matching [--threads N]
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include "bench_util.h"
#include "freeloc/matching/fast_nn.h"
#include "freeloc/matching/reciprocal.h"
#include "testing/synthetic_scene.h"

using namespace freeloc;
using freeloc::bench::Fmt;

namespace {

struct Maps {
  std::vector<float> p1, c1, p2, c2;
  int h, w;
};

Maps MakeMaps(int w, int h) {
  const testing::SyntheticScene s = testing::MakeRoomScene(3, 0.4, w, h);
  Maps m{{}, {}, {}, {}, h, w};
  std::mt19937 rng(1);
  std::normal_distribution<float> g(0, 0.001f);
  const Rigid3d ref_from_query = s.query_from_ref.Inverse();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector3d a = s.depth_ref.at(x, y) * s.ref.Unproject(x, y);
      const Eigen::Vector3d b = ref_from_query * (s.depth_query.at(x, y) * s.query.Unproject(x, y));
      for (int k = 0; k < 3; ++k) {
        m.p1.push_back(static_cast<float>(a(k)) + g(rng));
        m.p2.push_back(static_cast<float>(b(k)) + g(rng));
      }
      m.c1.push_back(2.f);
      m.c2.push_back(2.f);
    }
  return m;
}

// A smooth descriptor field: D random plane waves per channel, unit-normalised; view 2 samples it at warped
// coordinates (scale 1.05, rotation 3°, shift) so that most pixels have a true partner, plus per-pixel noise.
std::vector<float> DescriptorField(int w, int h, int D, bool warped, uint32_t noise_seed) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  std::vector<double> fx(static_cast<size_t>(D) * 3), fy(fx.size()), ph(fx.size());
  for (size_t i = 0; i < fx.size(); ++i) {
    fx[i] = 0.04 * g(rng);
    fy[i] = 0.04 * g(rng);
    ph[i] = 6.28 * std::uniform_real_distribution<double>()(rng);
  }
  std::mt19937 nrng(noise_seed);
  std::normal_distribution<double> noise(0, 0.03);
  std::vector<float> out(static_cast<size_t>(w) * h * D);
  const double c = std::cos(0.05), s = std::sin(0.05);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double u = x, v = y;
      if (warped) {
        u = 1.05 * (c * (x - w / 2.0) - s * (y - h / 2.0)) + w / 2.0 + 7.3;
        v = 1.05 * (s * (x - w / 2.0) + c * (y - h / 2.0)) + h / 2.0 - 4.1;
      }
      float* p = &out[(static_cast<size_t>(y) * w + x) * D];
      double n = 0;
      for (int d = 0; d < D; ++d) {
        double a = 0;
        for (int k = 0; k < 3; ++k) a += std::sin(fx[d * 3 + k] * u + fy[d * 3 + k] * v + ph[d * 3 + k]);
        p[d] = static_cast<float>(a + noise(nrng));
        n += static_cast<double>(p[d]) * p[d];
      }
      for (int d = 0; d < D; ++d) p[d] = static_cast<float>(p[d] / std::sqrt(n));
    }
  return out;
}

bool SameMatches(const std::vector<matching::PixelMatch>& a, const std::vector<matching::PixelMatch>& b) {
  bool same = a.size() == b.size();
  for (size_t i = 0; same && i < a.size(); ++i)
    same = a[i].x1 == b[i].x1 && a[i].y1 == b[i].y1 && a[i].x2 == b[i].x2 && a[i].y2 == b[i].y2;
  return same;
}

std::string Sizes(const std::vector<int64_t>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s;
}

// Returns whether every fast kernel equals the exhaustive reference.
bool DescriptorBench(int threads) {
  const int W = 512, H = 384, D = 24;
  const auto d1 = DescriptorField(W, H, D, false, 11), d2 = DescriptorField(W, H, D, true, 12);
  const matching::DescriptorView a{d1.data(), nullptr, H, W, D}, b{d2.data(), nullptr, H, W, D};
  matching::FastNnOptions o;
  o.subsample = 8;
  o.threads = threads;
  bench::MarkdownTable t({"descriptors", "method", "median ms", "matches", "NN calls (upstream sizes)", "lookups",
                          "exactly scored", "tiles skipped", "identical to brute force"});
  matching::FastNnStats ref_st;
  const double t0 = bench::NowSeconds();
  const auto ref = matching::FastReciprocalNNBruteForce(a, b, o, &ref_st);
  const double ref_ms = (bench::NowSeconds() - t0) * 1e3;
  bool all_same = true;
  std::vector<matching::NnKernel> kernels = {matching::NnKernel::kFloat32};
  if (matching::CpuHasVnni()) kernels.insert(kernels.begin(), matching::NnKernel::kInt8Vnni);
  for (matching::NnKernel k : kernels) {
    o.kernel = k;
    std::vector<double> ms;
    matching::FastNnStats st;
    std::vector<matching::PixelMatch> m;
    for (int r = 0; r < 5; ++r) {
      const double s0 = bench::NowSeconds();
      m = matching::FastReciprocalNN(a, b, o, &st);
      ms.push_back((bench::NowSeconds() - s0) * 1e3);
    }
    const bool same = SameMatches(m, ref);
    all_same = all_same && same;
    t.Row({"512×384, D = 24, S = 8", "fast NN, " + st.kernel + " screening, " + std::to_string(threads) + " threads",
           Fmt("%.1f", bench::Median(ms)), std::to_string(m.size()), Sizes(st.query_sizes), std::to_string(st.lookups),
           std::to_string(st.candidates), st.kernel == "int8-vnni" ? Fmt("%.0f %%", 100 * st.tiles_skipped) : "–",
           same ? "yes" : "NO"});
  }
  t.Row({"512×384, D = 24, S = 8", "exhaustive reference (double, 1 thread)", Fmt("%.0f", ref_ms),
         std::to_string(ref.size()), Sizes(ref_st.query_sizes), std::to_string(ref_st.lookups),
         std::to_string(ref_st.lookups * W * H), "–", "–"});
  std::printf("\n## bench/matching — MASt3R fast reciprocal NN on descriptors, median of 5\n\n");
  t.Print();
  std::printf("\ntarget: ≤ 150 ms at 512×384, D = 24, S = 8 with 2 threads, identical to brute force\n");
  return all_same;
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 2;
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc) threads = std::atoi(argv[++i]);
  matching::ReciprocalOptions o;
  o.threads = threads;
  bench::MarkdownTable t({"pointmaps", "method", "median ms", "matches", "identical to brute force"});
  const Maps full = MakeMaps(512, 384);
  const matching::PointmapView f1{full.p1.data(), full.c1.data(), nullptr, full.h, full.w};
  const matching::PointmapView f2{full.p2.data(), full.c2.data(), nullptr, full.h, full.w};
  std::vector<double> ms;
  size_t n_full = 0;
  for (int r = 0; r < 5; ++r) {
    const double t0 = bench::NowSeconds();
    n_full = matching::ReciprocalMatches(f1, f2, o).size();
    ms.push_back((bench::NowSeconds() - t0) * 1e3);
  }
  t.Row({"512×384 (196,608 per side)", "freeloc KD-tree, " + std::to_string(threads) + " threads",
         Fmt("%.0f", bench::Median(ms)), std::to_string(n_full), "–"});
  const Maps small = MakeMaps(128, 96);
  const matching::PointmapView s1{small.p1.data(), small.c1.data(), nullptr, small.h, small.w};
  const matching::PointmapView s2{small.p2.data(), small.c2.data(), nullptr, small.h, small.w};
  std::vector<double> ms_k, ms_b;
  std::vector<matching::PixelMatch> mk, mb;
  for (int r = 0; r < 3; ++r) {
    double t0 = bench::NowSeconds();
    mk = matching::ReciprocalMatches(s1, s2, o);
    ms_k.push_back((bench::NowSeconds() - t0) * 1e3);
    t0 = bench::NowSeconds();
    mb = matching::ReciprocalMatchesBruteForce(s1, s2, o);
    ms_b.push_back((bench::NowSeconds() - t0) * 1e3);
  }
  bool same = mk.size() == mb.size();
  for (size_t i = 0; same && i < mk.size(); ++i)
    same = mk[i].x1 == mb[i].x1 && mk[i].y1 == mb[i].y1 && mk[i].x2 == mb[i].x2 && mk[i].y2 == mb[i].y2;
  t.Row({"128×96 (12,288 per side)", "freeloc KD-tree", Fmt("%.1f", bench::Median(ms_k)), std::to_string(mk.size()),
         same ? "yes" : "NO"});
  t.Row({"128×96 (12,288 per side)", "brute force (double)", Fmt("%.1f", bench::Median(ms_b)),
         std::to_string(mb.size()), "–"});
  std::printf("%s\n\n", bench::MachineLine().c_str());
  std::printf("## bench/matching — reciprocal 3D NN, median of 5 (full) / 3 (small)\n\n");
  t.Print();
  std::printf("\ntarget: ≤ 250 ms at 512×384 with 2 threads\n");
  const bool same_desc = DescriptorBench(threads);
  return same && same_desc ? 0 : 1;
}
