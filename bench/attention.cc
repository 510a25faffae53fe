// bench/attention — the attention core of DUSt3R and Metric3D (nn/internal ScaledDotProduct, fp32): row-blocked
// (logits block kept in cache, scale folded into Q, (head, block) items over the threads) against the upstream
// three-op form (matmul, softmax, matmul over whole heads), at the shapes the released models run: Metric3D vit_large
// at 616×1064 (3349 tokens, 16 heads × 64), DUSt3R ViT-L encoder at 512×384 (768 tokens, 16 × 64), and, for scale,
// 3136 tokens (SegGPT's global blocks at 896×448; SegGPT keeps its own head-chunked attention with relative
// position terms). Median ms of one layer, max |difference|.
//
//   attention [--threads N] [--reps R]
#include <torch/torch.h>

#include <cstdio>
#include <cstring>

#include "bench_torch.h"
#include "freeloc/nn/internal/layers.h"

using freeloc::bench::Fmt;
using freeloc::bench::NowSeconds;

int main(int argc, char** argv) {
  int threads = 2, reps = 5;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc) threads = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) reps = std::atoi(argv[++i]);
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
  }
  std::printf("## bench/attention — fp32, %d threads, median of %d\n\n", threads, reps);
  t.Print();
  return 0;
}
