// Helpers for the benchmarks that drive LibTorch directly: the GEMM rate measured in the same process (random
// full-size weights become checkpoint TensorViews through nn's own ToView).
#pragma once

#include <ATen/record_function.h>
#include <torch/torch.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bench_util.h"
#include "freeloc/io/tensor.h"
#include "freeloc/nn/internal/torch_util.h"  // ToView: torch tensors as TensorViews

namespace freeloc::bench {

// GFLOP/s of an M×K by K×N matmul in `dtype` over `reps` runs after a warm-up: their median, or with `best` the
// fastest run (the machine's rate, for a denominator).
inline double GemmRate(int64_t m, int64_t k, int64_t n, torch::Dtype dtype, int reps = 3, bool best = false) {
  torch::InferenceMode guard;
  const auto a = torch::randn({m, k}).to(dtype), b = torch::randn({k, n}).to(dtype);
  auto c = torch::matmul(a, b);
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    const double t0 = NowSeconds();
    c = torch::matmul(a, b);
    t.push_back(NowSeconds() - t0);
  }
  const double s = best ? *std::min_element(t.begin(), t.end()) : Median(t);
  return 2.0 * m * k * n / s / 1e9;
}

// A released model's state dict with random weights (no download): names and shapes from a fixture's
// full_model_state_dict_shapes.json; LayerNorm weights 1, biases 0, other weights N(0, 0.02²), seed 0.
inline std::map<std::string, io::TensorView> RandomFullModel(const std::string& shapes_json) {
  std::ifstream f(shapes_json);
  if (!f.good()) {
    std::fprintf(stderr, "bench: %s not found (it lists the released model's tensor shapes)\n", shapes_json.c_str());
    std::exit(1);
  }
  const nlohmann::json j = nlohmann::json::parse(f);
  torch::manual_seed(0);
  std::map<std::string, io::TensorView> sd;
  for (const auto& e : j) {
    const std::string name = e[0];
    const std::vector<int64_t> shape = e[1];
    torch::Tensor t;
    if (name.find("norm") != std::string::npos && name.find(".weight") != std::string::npos)
      t = torch::ones(shape);
    else if (name.find(".bias") != std::string::npos)
      t = torch::zeros(shape);
    else
      t = torch::randn(shape) * 0.02;
    sd[name] = nn::internal::ToView(t);
  }
  return sd;
}

inline io::TensorView RandomTensor(const std::vector<int64_t>& shape, double std, double mean = 0) {
  return nn::internal::ToView(torch::randn(shape) * std + mean);
}

// The released seggpt_vit_large architecture with random weights (seed 0).
inline std::map<std::string, io::TensorView> RandomSegGpt() {
  torch::manual_seed(0);
  const int64_t C = 1024, M = 4096, D = 64;
  std::map<std::string, io::TensorView> sd;
  sd["patch_embed.proj.weight"] = RandomTensor({C, 3, 16, 16}, 0.02);
  sd["patch_embed.proj.bias"] = RandomTensor({C}, 0.0);
  for (const char* t : {"mask_token", "segment_token_x", "segment_token_y", "type_token_cls", "type_token_ins"})
    sd[t] = RandomTensor({1, 1, 1, C}, 0.02);
  sd["pos_embed"] = RandomTensor({1, 197, C}, 0.02);
  for (int i = 0; i < 24; ++i) {
    const std::string b = "blocks." + std::to_string(i) + ".";
    sd[b + "norm1.weight"] = RandomTensor({C}, 0, 1);
    sd[b + "norm1.bias"] = RandomTensor({C}, 0);
    sd[b + "attn.qkv.weight"] = RandomTensor({3 * C, C}, 0.02);
    sd[b + "attn.qkv.bias"] = RandomTensor({3 * C}, 0);
    sd[b + "attn.proj.weight"] = RandomTensor({C, C}, 0.02);
    sd[b + "attn.proj.bias"] = RandomTensor({C}, 0);
    sd[b + "attn.rel_pos_h"] = RandomTensor({111, 64}, 0.02);
    sd[b + "attn.rel_pos_w"] = RandomTensor({55, 64}, 0.02);
    sd[b + "norm2.weight"] = RandomTensor({C}, 0, 1);
    sd[b + "norm2.bias"] = RandomTensor({C}, 0);
    sd[b + "mlp.fc1.weight"] = RandomTensor({M, C}, 0.02);
    sd[b + "mlp.fc1.bias"] = RandomTensor({M}, 0);
    sd[b + "mlp.fc2.weight"] = RandomTensor({C, M}, 0.02);
    sd[b + "mlp.fc2.bias"] = RandomTensor({C}, 0);
  }
  sd["norm.weight"] = RandomTensor({C}, 0, 1);
  sd["norm.bias"] = RandomTensor({C}, 0);
  sd["decoder_embed.weight"] = RandomTensor({16 * 16 * D, 4 * C}, 0.02);
  sd["decoder_embed.bias"] = RandomTensor({16 * 16 * D}, 0);
  sd["decoder_pred.0.weight"] = RandomTensor({D, D, 3, 3}, 0.02);
  sd["decoder_pred.0.bias"] = RandomTensor({D}, 0);
  sd["decoder_pred.1.weight"] = RandomTensor({D}, 0, 1);
  sd["decoder_pred.1.bias"] = RandomTensor({D}, 0);
  sd["decoder_pred.3.weight"] = RandomTensor({3, D, 1, 1}, 0.02);
  sd["decoder_pred.3.bias"] = RandomTensor({3}, 0);
  return sd;
}

// A released Metric3D v2 variant (vit_small, vit_large, vit_giant2) with random weights (seed 0), shapes from the
// fixture's list of the released state dicts.
inline std::map<std::string, io::TensorView> RandomMetric3d(const std::string& variant) {
  std::ifstream f(std::string(FREELOC_SHARED_DIR) + "/fixtures/metric3d/released_state_dict_shapes.json");
  if (!f.good()) {
    std::fprintf(stderr, "bench/metric3d: released_state_dict_shapes.json not found under ../shared\n");
    std::exit(1);
  }
  const nlohmann::json j = nlohmann::json::parse(f);
  torch::manual_seed(0);
  std::map<std::string, io::TensorView> sd;
  for (const auto& e : j[variant]) {
    const std::string name = e[0];
    const std::vector<int64_t> shape = e[1];
    torch::Tensor t;
    if (name.find("gamma") != std::string::npos)
      t = torch::full(shape, 1e-5);
    else if (name.find("norm") != std::string::npos && name.find(".weight") != std::string::npos && shape.size() == 1)
      t = torch::ones(shape);
    else if (name.find(".bias") != std::string::npos)
      t = torch::zeros(shape);
    else {
      int64_t fan_in = 1;
      for (size_t k = 1; k < shape.size(); ++k) fan_in *= shape[k];
      t = torch::randn(shape) * (1.0 / std::sqrt(static_cast<double>(std::max<int64_t>(fan_in, 1))));
    }
    sd[name] = nn::internal::ToView(t);
  }
  return sd;
}

// Counts the floating-point operations LibTorch executes (all threads): matrix products (aten::mm, addmm, bmm, and
// nn's oneDNN bf16 matmul, which records itself as freeloc::bf16_linear; the fused attention's QKᵀ and PV, recorded as
// freeloc::fused_attention) and convolutions (aten::convolution,
// transposed too) from their input shapes at the dispatcher, 1 multiply-add = 2
// FLOP — the counter the specs' FLOP figures were checked with. Elementwise work (softmax, norms, GELU) is not
// counted: it is memory traffic, not arithmetic the GEMM rate could bound.
class FlopCounter {
 public:
  FlopCounter() {
    at::enableRecordFunction(true);
    handle_ = at::addGlobalCallback(at::RecordFunctionCallback(&FlopCounter::OnStart).needsInputs(true));
  }
  ~FlopCounter() { at::removeCallback(handle_); }
  FlopCounter(const FlopCounter&) = delete;
  FlopCounter& operator=(const FlopCounter&) = delete;
  static double Total() { return static_cast<double>(Flops().load()); }

 private:
  static std::atomic<uint64_t>& Flops() {
    static std::atomic<uint64_t> f{0};
    return f;
  }
  static std::vector<int64_t> Shape(const c10::IValue& v) {
    return v.isTensor() ? v.toTensor().sizes().vec() : std::vector<int64_t>{};
  }
  static std::unique_ptr<at::ObserverContext> OnStart(const at::RecordFunction& fn) {
    const std::string name = fn.name();
    const auto in = fn.inputs();
    double f = 0;
    if (name == "aten::mm" && in.size() >= 2) {
      const auto a = Shape(in[0]), b = Shape(in[1]);
      if (a.size() == 2 && b.size() == 2) f = 2.0 * a[0] * a[1] * b[1];
    } else if (name == "aten::addmm" && in.size() >= 3) {
      const auto a = Shape(in[1]), b = Shape(in[2]);
      if (a.size() == 2 && b.size() == 2) f = 2.0 * a[0] * a[1] * b[1];
    } else if (name == "freeloc::bf16_linear" &&
               in.size() >= 2) {  // nn's oneDNN bf16 matmul: x [rows, in], w [out, in]
      const auto a = Shape(in[0]), w = Shape(in[1]);
      if (a.size() == 2 && w.size() == 2) f = 2.0 * a[0] * a[1] * w[0];
    } else if (name == "freeloc::fused_attention" && in.size() >= 3) {  // q [B,H,Nq,D], k [B,H,Nk,D], v [B,H,Nk,Dv]
      const auto q = Shape(in[0]), k = Shape(in[1]), v = Shape(in[2]);
      if (q.size() == 4 && k.size() == 4 && v.size() == 4) f = 2.0 * q[0] * q[1] * q[2] * k[2] * (q[3] + v[3]);
    } else if (name == "aten::bmm" && in.size() >= 2) {
      const auto a = Shape(in[0]), b = Shape(in[1]);
      if (a.size() == 3 && b.size() == 3) f = 2.0 * a[0] * a[1] * a[2] * b[2];
    } else if (name == "aten::convolution" && in.size() >= 9) {
      const auto x = Shape(in[0]), w = Shape(in[1]);
      const bool transposed = in[6].isBool() && in[6].toBool();
      if (x.size() == 4 && w.size() == 4) {
        if (transposed) {  // weight [Cin, Cout/groups, kh, kw]: every input pixel scatters a kernel
          f = 2.0 * x[0] * x[1] * x[2] * x[3] * w[1] * w[2] * w[3];
        } else {  // weight [Cout, Cin/groups, kh, kw]: w[1] is already per group
          // stride / padding / dilation: one value for both axes or one per axis.
          const auto at = [](const c10::IValue& v, int i, int64_t dflt) {
            if (!v.isIntList()) return dflt;
            const auto l = v.toIntVector();
            return l.empty() ? dflt : l[std::min<size_t>(i, l.size() - 1)];
          };
          const int64_t s0 = std::max<int64_t>(1, at(in[3], 0, 1)), s1 = std::max<int64_t>(1, at(in[3], 1, 1));
          const int64_t ho = (x[2] + 2 * at(in[4], 0, 0) - at(in[5], 0, 1) * (w[2] - 1) - 1) / s0 + 1;
          const int64_t wo = (x[3] + 2 * at(in[4], 1, 0) - at(in[5], 1, 1) * (w[3] - 1) - 1) / s1 + 1;
          f = 2.0 * x[0] * w[0] * ho * wo * w[1] * w[2] * w[3];
        }
      }
    }
    if (f > 0) Flops().fetch_add(static_cast<uint64_t>(f));
    return nullptr;
  }
  at::CallbackHandle handle_;
};

}  // namespace freeloc::bench
