// Helpers for the benchmarks that drive LibTorch directly: the GEMM rate measured in the same process (random
// full-size weights become checkpoint TensorViews through nn's own ToView).
#pragma once

#include <torch/torch.h>

#include <memory>
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

}  // namespace freeloc::bench
