// bench/attention — the attention core of every ViT in freeloc at the shapes the released models run: Metric3D
// vit_large at 616×1064 (3349 tokens, 16 heads × 64), 3136 tokens (SegGPT's global blocks at 896×448 have 1568;
// 3136 for scale) and DUSt3R ViT-L at 512×384 (768 tokens, 16 × 64). Side by side in one process: the upstream
// three-op form (matmul, softmax, matmul over whole heads, fp32), the row-blocked LibTorch form at several block
// sizes (fp32), the LibTorch bf16 form the networks ran before the fused kernel (bf16 matmuls, fp32 softmax), and
// the fused kernel (nn/internal/fused_attention.h) in every instruction set this CPU runs. Median ms of one layer,
// GFLOP/s of its QKᵀ and PV products, max |difference| from the fp32 upstream form.
//
//   attention [--threads N] [--reps R] [--only avx512-bf16|avx512|avx2|generic]   (--only: that fused kernel alone,
//   for profiling)
#include <torch/torch.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "bench_torch.h"
#include "freeloc/nn/internal/fused_attention.h"
#include "freeloc/nn/internal/layers.h"

using freeloc::bench::Fmt;
using freeloc::bench::NowSeconds;

int main(int argc, char** argv) {
  int threads = 2, reps = 5;
  std::string only;  // --only NAME: just the fused kernel NAME (for profiling)
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc) threads = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) reps = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
  }
  torch::set_num_threads(threads);
  torch::NoGradGuard ng;
  struct Shape {
    const char* name;
    int64_t heads, tokens, dim;
  };
  const Shape shapes[] = {{"Metric3D vit_large 616×1064", 16, 3349, 64},
                          {"3136 tokens (SegGPT global-block size)", 16, 3136, 64},
                          {"DUSt3R ViT-L 512×384", 16, 768, 64}};
  freeloc::bench::MarkdownTable t({"shape", "method", "median ms / layer", "GFLOP/s (QKᵀ + PV)", "max |diff|"});
  for (const Shape& s : shapes) {
    torch::manual_seed(0);
    const auto q = torch::randn({1, s.heads, s.tokens, s.dim}), k = torch::randn({1, s.heads, s.tokens, s.dim}),
               v = torch::randn({1, s.heads, s.tokens, s.dim});
    const double scale = 1.0 / std::sqrt(static_cast<double>(s.dim));
    const double gflop = 4.0 * s.heads * s.tokens * s.tokens * s.dim / 1e9;
    const torch::Tensor ref = freeloc::nn::internal::ScaledDotProductReference(q, k, v, scale);
    auto time = [&](auto fn) {
      fn();
      std::vector<double> ms;
      for (int r = 0; r < reps; ++r) {
        const double t0 = NowSeconds();
        fn();
        ms.push_back((NowSeconds() - t0) * 1e3);
      }
      return freeloc::bench::Median(ms);
    };
    if (!only.empty()) {
      for (auto isa : {freeloc::nn::internal::AttentionIsa::kAvx512Bf16, freeloc::nn::internal::AttentionIsa::kAvx512,
                       freeloc::nn::internal::AttentionIsa::kAvx2, freeloc::nn::internal::AttentionIsa::kGeneric}) {
        if (only != freeloc::nn::internal::AttentionIsaName(isa)) continue;
        const bool bf16 = isa == freeloc::nn::internal::AttentionIsa::kAvx512Bf16;
        const double ms = time([&] { return freeloc::nn::internal::FusedAttention(q, k, v, scale, {}, bf16, isa); });
        t.Row({s.name, std::string("fused, ") + only, Fmt("%.1f", ms), Fmt("%.1f", gflop / ms * 1e3), "-"});
      }
      continue;
    }
    const double ms_ref = time([&] { return freeloc::nn::internal::ScaledDotProductReference(q, k, v, scale); });
    t.Row({s.name, "upstream form (3 whole-head ops)", Fmt("%.1f", ms_ref), Fmt("%.1f", gflop / ms_ref * 1e3), "0"});
    for (int64_t rows : {64, 128, 256, 512}) {
      freeloc::nn::internal::PrecisionPolicy p;
      const torch::Tensor o = freeloc::nn::internal::ScaledDotProduct(q, k, v, scale, p, rows);
      const double diff = (o - ref).abs().max().item<double>();
      const double ms = time([&] { return freeloc::nn::internal::ScaledDotProduct(q, k, v, scale, p, rows); });
      t.Row({s.name, "row-blocked, " + std::to_string(rows) + " rows" + (rows == 128 ? " (default)" : ""),
             Fmt("%.1f", ms), Fmt("%.1f", gflop / ms * 1e3), Fmt("%.1e", diff)});
    }
    {
      freeloc::nn::internal::PrecisionPolicy p;
      p.bf16 = true;
      const torch::Tensor o = freeloc::nn::internal::ScaledDotProduct(q, k, v, scale, p);
      const double diff = (o - ref).abs().max().item<double>();
      const double ms = time([&] { return freeloc::nn::internal::ScaledDotProduct(q, k, v, scale, p); });
      t.Row({s.name, "bf16 matmuls, fp32 softmax (LibTorch ops)", Fmt("%.1f", ms), Fmt("%.1f", gflop / ms * 1e3),
             Fmt("%.1e", diff)});
    }
    const torch::Tensor ref_t = ref.transpose(1, 2);  // the fused kernel's [B, N, H, D] layout
    for (auto isa : {freeloc::nn::internal::AttentionIsa::kAvx512Bf16, freeloc::nn::internal::AttentionIsa::kAvx512,
                     freeloc::nn::internal::AttentionIsa::kAvx2}) {
      if (!freeloc::nn::internal::AttentionIsaAvailable(isa)) continue;
      const bool bf16 = isa == freeloc::nn::internal::AttentionIsa::kAvx512Bf16;
      auto run = [&] { return freeloc::nn::internal::FusedAttention(q, k, v, scale, {}, bf16, isa); };
      const double diff = (run() - ref_t).abs().max().item<double>();
      const double ms = time(run);
      t.Row({s.name, std::string("fused, ") + freeloc::nn::internal::AttentionIsaName(isa), Fmt("%.1f", ms),
             Fmt("%.1f", gflop / ms * 1e3), Fmt("%.1e", diff)});
    }
    // RoPE in the pass (DUSt3R's grid 24×32) against applying it first with LibTorch ops (Rope2D::Apply).
    if (s.tokens == 768) {
      const freeloc::nn::internal::Rope2D rope(100.0);
      const auto tables = rope.Tables(24, 32, s.dim, torch::kCPU);
      freeloc::nn::internal::AttentionExtras x;
      x.rope_q = x.rope_k = &tables;
      const bool bf16 = freeloc::nn::internal::AttentionIsaAvailable(freeloc::nn::internal::AttentionIsa::kAvx512Bf16);
      const auto in_pass = [&] { return freeloc::nn::internal::FusedAttention(q, k, v, scale, x, bf16); };
      const auto before = [&] {
        return freeloc::nn::internal::FusedAttention(freeloc::nn::internal::Rope2D::Apply(q, tables),
                                                     freeloc::nn::internal::Rope2D::Apply(k, tables), v, scale, {},
                                                     bf16);
      };
      const double diff = (in_pass() - before()).abs().max().item<double>();
      const double ms_in = time(in_pass), ms_before = time(before);
      t.Row({s.name, std::string("fused + RoPE in the pass, ") + (bf16 ? "bf16" : "fp32"), Fmt("%.1f", ms_in),
             Fmt("%.1f", gflop / ms_in * 1e3), Fmt("%.1e", diff) + " (vs RoPE first)"});
      t.Row({s.name, std::string("RoPE (LibTorch ops), then fused, ") + (bf16 ? "bf16" : "fp32"),
             Fmt("%.1f", ms_before), Fmt("%.1f", gflop / ms_before * 1e3), "–"});
    }
  }
  std::printf("## bench/attention — %d threads, median of %d\n\n", threads, reps);
  std::printf("%s\n\n", freeloc::bench::MachineLine().c_str());
  t.Print();
  return 0;
}
