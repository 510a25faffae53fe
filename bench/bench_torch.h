// Helpers for the benchmarks that drive LibTorch directly: the GEMM rate measured in the same process (random
// full-size weights become checkpoint TensorViews through nn's own ToView).
#pragma once

#include <torch/torch.h>

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

// Median GFLOP/s of an M×K by K×N matmul in `dtype` (3 runs after a warm-up).
inline double GemmRate(int64_t m, int64_t k, int64_t n, torch::Dtype dtype) {
  torch::InferenceMode guard;
  const auto a = torch::randn({m, k}).to(dtype), b = torch::randn({k, n}).to(dtype);
  auto c = torch::matmul(a, b);
  std::vector<double> t;
  for (int r = 0; r < 3; ++r) {
    const double t0 = NowSeconds();
    c = torch::matmul(a, b);
    t.push_back(NowSeconds() - t0);
  }
  return 2.0 * m * k * n / Median(t) / 1e9;
}

// A released model's state dict with random weights (no download): names and shapes from a fixture's
// full_model_state_dict_shapes.json; LayerNorm weights 1, biases 0, other weights N(0, 0.02²), seed 0.
inline std::map<std::string, TensorView> RandomFullModel(const std::string& shapes_json) {
  std::ifstream f(shapes_json);
  if (!f.good()) {
    std::fprintf(stderr, "bench: %s not found (it lists the released model's tensor shapes)\n", shapes_json.c_str());
    std::exit(1);
  }
  const nlohmann::json j = nlohmann::json::parse(f);
  torch::manual_seed(0);
  std::map<std::string, TensorView> sd;
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

}  // namespace freeloc::bench
