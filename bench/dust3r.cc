// bench/dust3r — the released DUSt3R_ViTLarge_BaseDecoder_512_dpt architecture with random weights (no download):
// a 512×384 landscape pair on 2 threads; warm-up + median of 3 for the full pair (encoder / decoder / heads split),
// the per-query time with a cached reference encoding, achieved GFLOP/s (1.86 TFLOP per pair, naver/dust3r)
// next to the fp32 GEMM rate measured in this process, and peak RSS. bf16 is measured per block (one encoder and
// one decoder block at 768 tokens) because on CPUs without AVX512-BF16 LibTorch's bf16 GEMM is emulated and a full
// bf16 pair takes minutes; `--bf16-pair` runs the whole pair in bf16 once.
//
//   dust3r [--threads N] [--reps R] [--bf16-pair]
#include "freeloc/nn/dust3r.h"

#include <torch/torch.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "bench_torch.h"

using freeloc::bench::Fmt;
using freeloc::bench::NowSeconds;

namespace {

// One ViT block's worth of GEMM work at N tokens (qkv, proj, fc1, fc2) in a dtype: seconds.
double BlockGemms(int64_t n, int64_t c, int64_t hidden, torch::Dtype dt) {
  torch::InferenceMode g;
  auto x = torch::randn({n, c}).to(dt);
  auto wqkv = torch::randn({3 * c, c}).to(dt), wp = torch::randn({c, c}).to(dt);
  auto w1 = torch::randn({hidden, c}).to(dt), w2 = torch::randn({c, hidden}).to(dt);
  const double t0 = NowSeconds();
  auto q = torch::linear(x, wqkv);
  auto p = torch::linear(x, wp);
  auto h = torch::linear(x, w1);
  auto o = torch::linear(h, w2);
  (void)q;
  (void)p;
  (void)o;
  return NowSeconds() - t0;
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 2, reps = 3;
  bool bf16_pair = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--bf16-pair"))
      bf16_pair = true;
    else {
      std::fprintf(stderr, "usage: dust3r [--threads N] [--reps R] [--bf16-pair]\n");
      return 2;
    }
  }
  torch::set_num_threads(threads);
  const double gemm32 = freeloc::bench::GemmRate(768, 1024, 4096, torch::kFloat32);
  const double gemm16 = freeloc::bench::GemmRate(768, 1024, 4096, torch::kBFloat16);
  const auto sd = freeloc::bench::RandomFullModel(std::string(FREELOC_SHARED_DIR) +
                                                  "/fixtures/dust3r/full_model_state_dict_shapes.json");
  freeloc::nn::RuntimeOptions rt;
  rt.threads = threads;
  const auto model = freeloc::nn::Dust3rModel::Create(
      sd, {{"enc_num_heads", "16"}, {"dec_num_heads", "12"}, {"pos_embed", "RoPE100"}}, "random full-size weights", rt);
  const int H = 384, W = 512;
  std::vector<float> img1, img2;
  freeloc::bench::SyntheticImagePair(H, W, &img1, &img2);
  const freeloc::nn::Dust3rView v1{img1.data(), H, W}, v2{img2.data(), H, W};
  model->Run(v1, v2);  // warm-up
  std::vector<double> total, enc, dec, heads, cached;
  for (int r = 0; r < reps; ++r) {
    const double t0 = NowSeconds();
    const auto p = model->Run(v1, v2);
    total.push_back(NowSeconds() - t0);
    enc.push_back(p.encode_ms / 1e3);
    dec.push_back(p.decode_ms / 1e3);
    heads.push_back(p.heads_ms / 1e3);
  }
  const auto ref = model->Encode(v1);
  for (int r = 0; r < reps; ++r) {
    const double t0 = NowSeconds();
    const auto q = model->Encode(v2);
    model->Decode(*ref, *q);
    cached.push_back(NowSeconds() - t0);
  }
  const double pair = freeloc::bench::Median(total);
  std::printf("%s\n\n", freeloc::bench::MachineLine().c_str());
  std::printf(
      "## bench/dust3r — DUSt3R_ViTLarge_BaseDecoder_512_dpt (random weights), 512×384 pair, %d threads, "
      "median of %d after a warm-up\n\n",
      threads, reps);
  freeloc::bench::MarkdownTable t({"measurement", "fp32", "note"});
  t.Row({"full pair", Fmt("%.2f s", pair), Fmt("%.1f GFLOP/s (1.86 TFLOP)", 1860.0 / pair)});
  t.Row({"  encoder (both views)", Fmt("%.2f s", freeloc::bench::Median(enc)), ""});
  t.Row({"  decoder (both stacks)", Fmt("%.2f s", freeloc::bench::Median(dec)), ""});
  t.Row({"  two DPT heads", Fmt("%.2f s", freeloc::bench::Median(heads)), ""});
  const double q = freeloc::bench::Median(cached);
  t.Row({"query with cached reference", Fmt("%.2f s", q), Fmt("%.2f× the pair time", q / pair)});
  t.Row({"fp32 GEMM rate, same process", Fmt("%.1f GFLOP/s", gemm32),
         Fmt("pair reaches %.0f %% of it", 100.0 * 1860.0 / pair / gemm32)});
  t.Row({"bf16 GEMM rate, same process", Fmt("%.1f GFLOP/s", gemm16), ""});
  t.Row({"PyTorch reference (spec §9)", "44.5 s", "≈42 GFLOP/s"});
  t.Row({"peak RSS", Fmt("%.2f GB", freeloc::bench::PeakRssMB() / 1024.0), "target ≤ 3.0 GB"});
  t.Print();
  // bf16 vs fp32 on one encoder block's GEMMs (768 tokens, 1024 wide, MLP 4096).
  const double b32 = BlockGemms(768, 1024, 4096, torch::kFloat32);
  const double b16 = BlockGemms(768, 1024, 4096, torch::kBFloat16);
  std::printf(
      "\nbf16: one encoder block's GEMMs (torch::linear) take %.3f s in fp32 and %.3f s in bf16 (%.2f× the fp32 "
      "time) on this CPU.\n",
      b32, b16, b16 / b32);
  if (bf16_pair) {
    freeloc::nn::RuntimeOptions rb = rt;
    rb.precision = freeloc::nn::Precision::kBf16;
    const auto mb = freeloc::nn::Dust3rModel::Create(
        sd, {{"enc_num_heads", "16"}, {"dec_num_heads", "12"}, {"pos_embed", "RoPE100"}}, "random", rb);
    const auto p32 = model->Run(v1, v2);
    mb->Run(v1, v2);  // warm-up: packs the weights for each layer's shape once
    const double t0 = NowSeconds();
    const auto p16 = mb->Run(v1, v2);
    const double tb = NowSeconds() - t0;
    double enc_gflop = 0, dec_gflop = 0;
    {
      const freeloc::bench::FlopCounter counter;
      double f0 = freeloc::bench::FlopCounter::Total();
      const auto e1 = mb->Encode(v1);
      const auto e2 = mb->Encode(v2);
      enc_gflop = (freeloc::bench::FlopCounter::Total() - f0) / 1e9;
      f0 = freeloc::bench::FlopCounter::Total();
      mb->Decode(*e1, *e2);
      dec_gflop = (freeloc::bench::FlopCounter::Total() - f0) / 1e9;
    }
    std::printf("bf16 network GFLOP: encoder (both views) %.0f, decoder and heads %.0f\n", enc_gflop, dec_gflop);
    const float* a = p32.pts3d_2.as<float>();
    const float* b = p16.pts3d_2.as<float>();
    double num = 0, den = 0;
    for (int64_t i = 0; i < p32.pts3d_2.numel(); ++i) {
      num += (a[i] - b[i]) * (a[i] - b[i]);
      den += a[i] * a[i];
    }
    std::printf(
        "bf16 full pair: %.1f s (%.2f× fp32; encoder %.2f s, decoder %.2f s, heads %.2f s); pts3d_2 relative RMS "
        "deviation from fp32: %.2e\n",
        tb, tb / pair, p16.encode_ms / 1e3, p16.decode_ms / 1e3, p16.heads_ms / 1e3,
        std::sqrt(num / std::max(den, 1e-30)));
  }
  return 0;
}
