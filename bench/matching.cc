// bench/matching — reciprocal 3D nearest-neighbour matching of 512×384 pointmaps (196,608 points per side) of a
// realistic surface (the ray-cast room of tests/testing/synthetic_scene.h seen from two cameras, view 2's points
// in view 1's frame, 1 mm noise): freeloc's KD-tree matcher on 2 threads; the brute-force reference on a 128×96
// version of the same scene in the same run (full-size brute force is ~4·10¹⁰ distance evaluations), with the
// match sets compared. Target: ≤ 250 ms at full size on this machine.
//
//   matching [--threads N]
#include <cstdio>
#include <cstring>
#include <random>

#include "bench_util.h"
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
  std::printf("## bench/matching — reciprocal 3D NN, median of 5 (full) / 3 (small)\n\n");
  t.Print();
  std::printf("\ntarget: ≤ 250 ms at 512×384 with 2 threads\n");
  return same ? 0 : 1;
}
