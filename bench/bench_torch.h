// Helpers for the benchmarks that drive LibTorch directly: torch tensors as checkpoint TensorViews (random full-size
// weights without files) and the GEMM rate measured in the same process.
#pragma once

#include <torch/torch.h>

#include <memory>
#include <vector>

#include "bench_util.h"
#include "freeloc/io/tensor.h"

namespace freeloc::bench {

// A float32 TensorView sharing the tensor's memory (the TensorView keeps the tensor alive).
inline TensorView ViewOf(const torch::Tensor& t_in) {
  const torch::Tensor t = t_in.to(torch::kFloat32).contiguous();
  TensorView v;
  v.dtype = DType::kF32;
  v.shape = t.sizes().vec();
  v.nbytes = static_cast<size_t>(t.numel()) * 4;
  auto holder = std::make_shared<torch::Tensor>(t);
  v.data = static_cast<const uint8_t*>(holder->data_ptr());
  v.owner = holder;
  return v;
}

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
