// bench/seggpt — the released seggpt_vit_large architecture (896×448 input, ViT-L, 24 blocks, global attention over
// 1568 tokens) with random weights, one prompt, 2 threads, median of 3 after a warm-up: time per prompt, achieved
// GFLOP/s (1.59 TFLOP per prompt, baaivision/Painter SegGPT) next to the fp32 GEMM rate measured in this process, peak
// RSS. bf16 is reported per block on CPUs without AVX512-BF16 (emulated bf16 GEMM); `--bf16` runs a full bf16 pass.
//
//   seggpt [--threads N] [--reps R] [--bf16 | --bf16-only]   (--bf16-only: the bf16 model alone, warm, median of R)
#include "freeloc/nn/seggpt.h"

#include <torch/torch.h>

#include <cstdio>
#include <cstring>

#include "bench_torch.h"

using freeloc::bench::Fmt;
using freeloc::bench::NowSeconds;

namespace {}  // namespace

int main(int argc, char** argv) {
  int threads = 2, reps = 3;
  bool bf16 = false, bf16_only = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--bf16"))
      bf16 = true;
    else if (!std::strcmp(argv[i], "--bf16-only"))
      bf16_only = true;
    else {
      std::fprintf(stderr, "usage: seggpt [--threads N] [--reps R] [--bf16 | --bf16-only]\n");
      return 2;
    }
  }
  torch::set_num_threads(threads);
  const double gemm = freeloc::bench::GemmRate(1568, 1024, 4096, torch::kFloat32),
               gemm16 = freeloc::bench::GemmRate(1568, 1024, 4096, torch::kBFloat16);
  const auto sd = freeloc::bench::RandomSegGpt();
  freeloc::nn::RuntimeOptions rt;
  rt.threads = threads;
  const size_t item = 3 * 896 * 448;
  std::vector<float> imgs(item), tgts(item);
  for (size_t i = 0; i < item; ++i) {
    imgs[i] = static_cast<float>((i * 7919 % 255) / 127.5 - 1.0);
    tgts[i] = static_cast<float>((i * 104729 % 2) * 4.0 - 2.0);
  }
  // One prompt after a warm-up, median of R.
  const auto warm_median = [&](const freeloc::nn::SegGptModel& m) {
    m.Forward(imgs, tgts, 1, freeloc::nn::SegType::kInstance, false);
    std::vector<double> t;
    for (int r = 0; r < reps; ++r) {
      const double t0 = NowSeconds();
      m.Forward(imgs, tgts, 1, freeloc::nn::SegType::kInstance, false);
      t.push_back(NowSeconds() - t0);
    }
    return freeloc::bench::Median(t);
  };
  if (bf16_only) {  // the bf16 model alone (for profiling the bf16 path)
    freeloc::nn::RuntimeOptions rb = rt;
    rb.precision = freeloc::nn::Precision::kBf16;
    const double s = warm_median(
        *freeloc::nn::SegGptModel::Create(sd, R"({"img_size": [896, 448], "num_heads": 16})", "random", rb));
    std::printf(
        "## bench/seggpt — seggpt_vit_large bf16 (random weights), 896×448, one prompt, %d threads, median of "
        "%d\n\n%s\n\n",
        threads, reps, freeloc::bench::MachineLine().c_str());
    freeloc::bench::MarkdownTable tab({"measurement", "value", "note"});
    tab.Row({"bf16, one prompt", Fmt("%.2f s", s), Fmt("%.1f GFLOP/s (1.59 TFLOP)", 1590.0 / s)});
    tab.Row({"bf16 GEMM rate, same process", Fmt("%.1f GFLOP/s", gemm16),
             Fmt("reaches %.0f %% of it", 100.0 * 1590.0 / s / gemm16)});
    tab.Print();
    return 0;
  }
  const auto model = freeloc::nn::SegGptModel::Create(sd, R"({"img_size": [896, 448], "num_heads": 16})", "random", rt);
  const double s = warm_median(*model);
  std::printf("## bench/seggpt — seggpt_vit_large (random weights), 896×448, one prompt, %d threads, median of %d\n\n",
              threads, reps);
  freeloc::bench::MarkdownTable tab({"measurement", "value", "note"});
  tab.Row({"fp32, one prompt", Fmt("%.2f s", s), Fmt("%.1f GFLOP/s (1.59 TFLOP)", 1590.0 / s)});
  tab.Row({"fp32 GEMM rate, same process", Fmt("%.1f GFLOP/s", gemm),
           Fmt("reaches %.0f %% of it", 100.0 * 1590.0 / s / gemm)});
  tab.Row({"bf16 GEMM rate, same process", Fmt("%.1f GFLOP/s", gemm16), ""});
  tab.Row({"PyTorch reference here (issue)", "32 s", Fmt("freeloc at %.2f× of it (target ≤ 0.5×)", s / 32.0)});
  tab.Row({"peak RSS", Fmt("%.2f GB", freeloc::bench::PeakRssMB() / 1024.0), "target ≤ 2.8 GB"});
  if (bf16) {
    freeloc::nn::RuntimeOptions rb = rt;
    rb.precision = freeloc::nn::Precision::kBf16;
    const auto mb = freeloc::nn::SegGptModel::Create(sd, R"({"img_size": [896, 448], "num_heads": 16})", "random", rb);
    const auto p32 = model->Forward(imgs, tgts, 1, freeloc::nn::SegType::kInstance, false);
    const double t0 = NowSeconds();
    const auto p16 = mb->Forward(imgs, tgts, 1, freeloc::nn::SegType::kInstance, false);
    const double tb = NowSeconds() - t0;
    double num = 0, den = 0;
    for (int64_t i = 0; i < p32.numel(); ++i) {
      const double d = p32.as<float>()[i] - p16.as<float>()[i];
      num += d * d;
      den += double(p32.as<float>()[i]) * p32.as<float>()[i];
    }
    tab.Row(
        {"bf16, one prompt", Fmt("%.2f s", tb), Fmt("relative RMS deviation from fp32 %.2e", std::sqrt(num / den))});
  }
  tab.Print();
  return 0;
}
