// bench/seggpt — the released seggpt_vit_large architecture (896×448 input, ViT-L, 24 blocks, global attention over
// 1568 tokens) with random weights, one prompt, 2 threads, median of 3 after a warm-up: time per prompt, achieved
// GFLOP/s (1.59 TFLOP per prompt, spec/seggpt.md §5) next to the fp32 GEMM rate measured in this process, peak
// RSS. bf16 is reported per block on CPUs without AVX512-BF16 (emulated bf16 GEMM); `--bf16` runs a full bf16 pass.
//
//   seggpt [--threads N] [--reps R] [--bf16]
#include "freeloc/nn/seggpt.h"

#include <torch/torch.h>

#include <cstdio>
#include <cstring>

#include "bench_torch.h"

using freeloc::bench::Fmt;
using freeloc::bench::NowSeconds;

namespace {

freeloc::TensorView Random(const std::vector<int64_t>& shape, double std, double mean = 0) {
  return freeloc::nn::internal::ToView(torch::randn(shape) * std + mean);
}

std::map<std::string, freeloc::TensorView> FullModel() {
  torch::manual_seed(0);
  const int64_t C = 1024, M = 4096, D = 64;
  std::map<std::string, freeloc::TensorView> sd;
  sd["patch_embed.proj.weight"] = Random({C, 3, 16, 16}, 0.02);
  sd["patch_embed.proj.bias"] = Random({C}, 0.0);
  for (const char* t : {"mask_token", "segment_token_x", "segment_token_y", "type_token_cls", "type_token_ins"})
    sd[t] = Random({1, 1, 1, C}, 0.02);
  sd["pos_embed"] = Random({1, 197, C}, 0.02);
  for (int i = 0; i < 24; ++i) {
    const std::string b = "blocks." + std::to_string(i) + ".";
    sd[b + "norm1.weight"] = Random({C}, 0, 1);
    sd[b + "norm1.bias"] = Random({C}, 0);
    sd[b + "attn.qkv.weight"] = Random({3 * C, C}, 0.02);
    sd[b + "attn.qkv.bias"] = Random({3 * C}, 0);
    sd[b + "attn.proj.weight"] = Random({C, C}, 0.02);
    sd[b + "attn.proj.bias"] = Random({C}, 0);
    sd[b + "attn.rel_pos_h"] = Random({111, 64}, 0.02);
    sd[b + "attn.rel_pos_w"] = Random({55, 64}, 0.02);
    sd[b + "norm2.weight"] = Random({C}, 0, 1);
    sd[b + "norm2.bias"] = Random({C}, 0);
    sd[b + "mlp.fc1.weight"] = Random({M, C}, 0.02);
    sd[b + "mlp.fc1.bias"] = Random({M}, 0);
    sd[b + "mlp.fc2.weight"] = Random({C, M}, 0.02);
    sd[b + "mlp.fc2.bias"] = Random({C}, 0);
  }
  sd["norm.weight"] = Random({C}, 0, 1);
  sd["norm.bias"] = Random({C}, 0);
  sd["decoder_embed.weight"] = Random({16 * 16 * D, 4 * C}, 0.02);
  sd["decoder_embed.bias"] = Random({16 * 16 * D}, 0);
  sd["decoder_pred.0.weight"] = Random({D, D, 3, 3}, 0.02);
  sd["decoder_pred.0.bias"] = Random({D}, 0);
  sd["decoder_pred.1.weight"] = Random({D}, 0, 1);
  sd["decoder_pred.1.bias"] = Random({D}, 0);
  sd["decoder_pred.3.weight"] = Random({3, D, 1, 1}, 0.02);
  sd["decoder_pred.3.bias"] = Random({3}, 0);
  return sd;
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 2, reps = 3;
  bool bf16 = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--bf16"))
      bf16 = true;
    else {
      std::fprintf(stderr, "usage: seggpt [--threads N] [--reps R] [--bf16]\n");
      return 2;
    }
  }
  torch::set_num_threads(threads);
  const double gemm = freeloc::bench::GemmRate(1568, 1024, 4096, torch::kFloat32),
               gemm16 = freeloc::bench::GemmRate(1568, 1024, 4096, torch::kBFloat16);
  const auto sd = FullModel();
  freeloc::nn::RuntimeOptions rt;
  rt.threads = threads;
  const auto model = freeloc::nn::SegGptModel::Create(sd, R"({"img_size": [896, 448], "num_heads": 16})", "random", rt);
  const size_t item = 3 * 896 * 448;
  std::vector<float> imgs(item), tgts(item);
  for (size_t i = 0; i < item; ++i) {
    imgs[i] = static_cast<float>((i * 7919 % 255) / 127.5 - 1.0);
    tgts[i] = static_cast<float>((i * 104729 % 2) * 4.0 - 2.0);
  }
  model->Forward(imgs, tgts, 1, freeloc::nn::SegType::kInstance, false);  // warm-up
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    const double t0 = NowSeconds();
    model->Forward(imgs, tgts, 1, freeloc::nn::SegType::kInstance, false);
    t.push_back(NowSeconds() - t0);
  }
  const double s = freeloc::bench::Median(t);
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
