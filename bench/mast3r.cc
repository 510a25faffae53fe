// bench/mast3r — the released MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric architecture with random weights (no
// download; shapes from the fixture's list of the released tensors): a 512×384 pair on 2 threads, warm-up + median
// of R. Side by side in one run on the same weights: the DUSt3R trunk alone (the same checkpoint without the 8
// local-feature tensors, the DUSt3R path) and MASt3R (pointmaps + descriptors); the per-query time with a cached
// reference encoding; the swapped pass of route B (docs/pipeline.md "The MASt3R routes": decoders + head 1 again, the
// query's own depth); the fast reciprocal NN on the pair's own 512×384×24 descriptors (subsample 8) against its
// exhaustive reference; achieved GFLOP/s (MASt3R 2.04 TFLOP per pair, DUSt3R 1.86: naver/mast3r) next to the fp32 GEMM
// rate measured in this process; peak RSS.
//
//   mast3r [--threads N] [--reps R]
#include <torch/torch.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "bench_torch.h"
#include "freeloc/matching/fast_nn.h"
#include "freeloc/nn/dust3r.h"

using freeloc::bench::Fmt;
using freeloc::bench::Median;
using freeloc::bench::NowSeconds;

int main(int argc, char** argv) {
  int threads = 2, reps = 3;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: mast3r [--threads N] [--reps R]\n");
      return 2;
    }
  }
  torch::set_num_threads(threads);
  const double gemm32 = freeloc::bench::GemmRate(768, 1024, 4096, torch::kFloat32);
  const auto sd = freeloc::bench::RandomFullModel(std::string(FREELOC_SHARED_DIR) +
                                                  "/fixtures/mast3r/full_model_state_dict_shapes.json");
  freeloc::nn::RuntimeOptions rt;
  rt.threads = threads;
  const std::map<std::string, std::string> kw = {{"enc_num_heads", "16"},
                                                 {"dec_num_heads", "12"},
                                                 {"pos_embed", "RoPE100"},
                                                 {"head_type", "catmlp+dpt"},
                                                 {"output_mode", "pts3d+desc24"},
                                                 {"two_confs", "True"},
                                                 {"desc_conf_mode", "('exp', 0, inf)"}};
  const auto mast3r = freeloc::nn::Dust3rModel::Create(sd, kw, "random full-size weights", rt);
  // The DUSt3R path on the same trunk weights (shared, not copied).
  std::map<std::string, freeloc::io::TensorView> trunk;
  for (const auto& [k, v] : sd)
    if (k.find("head_local_features") == std::string::npos) trunk[k] = v;
  const auto dust3r = freeloc::nn::Dust3rModel::Create(
      trunk, {{"enc_num_heads", "16"}, {"dec_num_heads", "12"}, {"pos_embed", "RoPE100"}}, "random trunk", rt);
  const int H = 384, W = 512;
  std::vector<float> img1, img2;
  freeloc::bench::SyntheticImagePair(H, W, &img1, &img2);
  const freeloc::nn::Dust3rView v1{img1.data(), H, W}, v2{img2.data(), H, W};
  std::vector<double> t_d, t_m, heads_d, heads_m, cached, swapped;
  mast3r->Run(v1, v2);  // warm-up
  freeloc::nn::Dust3rPrediction last;
  for (int r = 0; r < reps; ++r) {
    double t0 = NowSeconds();
    const auto pd = dust3r->Run(v1, v2);
    t_d.push_back(NowSeconds() - t0);
    heads_d.push_back(pd.heads_ms / 1e3);
    t0 = NowSeconds();
    last = mast3r->Run(v1, v2);
    t_m.push_back(NowSeconds() - t0);
    heads_m.push_back(last.heads_ms / 1e3);
  }
  const auto ref = mast3r->Encode(v1);
  std::shared_ptr<const freeloc::nn::Dust3rModel::Encoding> q;
  for (int r = 0; r < reps; ++r) {
    double t0 = NowSeconds();
    q = mast3r->Encode(v2);
    mast3r->Decode(*ref, *q);
    cached.push_back(NowSeconds() - t0);
    freeloc::nn::DecodeOutputs only1;
    only1.view2 = false;
    only1.descriptors = false;
    t0 = NowSeconds();
    mast3r->Decode(*q, *ref, only1);
    swapped.push_back(NowSeconds() - t0);
  }
  // Matching on the pair's own descriptors.
  const int D = static_cast<int>(last.desc_1.shape.back());
  const freeloc::matching::DescriptorView a{last.desc_1.as<float>(), last.desc_conf_1.as<float>(), H, W, D};
  const freeloc::matching::DescriptorView b{last.desc_2.as<float>(), last.desc_conf_2.as<float>(), H, W, D};
  freeloc::matching::FastNnOptions fo;
  fo.threads = threads;
  std::vector<double> t_nn;
  freeloc::matching::FastNnStats st;
  std::vector<freeloc::matching::PixelMatch> m;
  for (int r = 0; r < 5; ++r) {
    const double t0 = NowSeconds();
    m = freeloc::matching::FastReciprocalNN(a, b, fo, &st);
    t_nn.push_back(NowSeconds() - t0);
  }
  freeloc::matching::FastNnStats bst;
  const double tb0 = NowSeconds();
  const auto mb = freeloc::matching::FastReciprocalNNBruteForce(a, b, fo, &bst);
  const double t_brute = NowSeconds() - tb0;
  bool same = m.size() == mb.size();
  for (size_t i = 0; same && i < m.size(); ++i)
    same = m[i].x1 == mb[i].x1 && m[i].y1 == mb[i].y1 && m[i].x2 == mb[i].x2 && m[i].y2 == mb[i].y2;
  std::string sizes;
  for (size_t i = 0; i < st.query_sizes.size(); ++i) sizes += (i ? ", " : "") + std::to_string(st.query_sizes[i]);

  std::printf("%s\n\n", freeloc::bench::MachineLine().c_str());
  std::printf(
      "## bench/mast3r — MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric (random weights), 512×384 pair, %d threads, "
      "median of %d after a warm-up\n\n",
      threads, reps);
  const double pd = Median(t_d), pm = Median(t_m);
  freeloc::bench::MarkdownTable t({"measurement", "time", "note"});
  t.Row({"DUSt3R pair (same trunk, dpt heads only)", Fmt("%.2f s", pd), Fmt("%.1f GFLOP/s (1.86 TFLOP)", 1857.0 / pd)});
  t.Row({"  its two DPT heads", Fmt("%.2f s", Median(heads_d)), ""});
  t.Row({"MASt3R pair (pointmaps + descriptors)", Fmt("%.2f s", pm),
         Fmt("%.1f GFLOP/s (2.04 TFLOP); ", 2037.2 / pm) + Fmt("%.3f× the DUSt3R pair (target ≤ 1.15×)", pm / pd)});
  t.Row({"  its heads (2 DPT + 2 MLP)", Fmt("%.2f s", Median(heads_m)),
         Fmt("+%.2f s for the MLPs", Median(heads_m) - Median(heads_d))});
  t.Row({"MASt3R query with cached reference encoding", Fmt("%.2f s", Median(cached)),
         Fmt("%.2f× the pair", Median(cached) / pm)});
  t.Row({"route B swapped pass (decoders + head 1)", Fmt("%.2f s", Median(swapped)),
         Fmt("+%.0f %% of the cached query (the query's own depth)", 100 * Median(swapped) / Median(cached))});
  t.Row({"fast reciprocal NN, 512×384×24, S = 8 (" + st.kernel + ")", Fmt("%.0f ms", 1e3 * Median(t_nn)),
         std::to_string(m.size()) + " matches, calls " + sizes +
             (same ? "; identical to brute force" : "; DIFFERS from brute force")});
  t.Row({"  exhaustive reference (double, 1 thread)", Fmt("%.1f s", t_brute), std::to_string(mb.size()) + " matches"});
  t.Row({"fp32 GEMM rate, same process", Fmt("%.1f GFLOP/s", gemm32),
         Fmt("MASt3R pair reaches %.0f %% of it", 100.0 * 2037.2 / pm / gemm32)});
  t.Row({"peak RSS", Fmt("%.2f GB", freeloc::bench::PeakRssMB() / 1024.0), "weights shared by both models (2.75 GB)"});
  t.Print();
  return same ? 0 : 1;
}
