// bf16 that pays: a Linear layer in bf16 through oneDNN's matmul with its weights reordered once, at
// load, into the blocked layout the kernel wants (brgemm on AVX512-BF16 / AMX), f32 accumulation, f32 bias and
// output. torch::linear on bf16 tensors repacks the weights on every call and rounds the output to bf16; this does
// neither (half the error, 10–20 % faster on the GEMM alone). Whether bf16 is used at all is decided once per
// process by Bf16Decision(): the CPU must have native bf16 and a measured bf16 GEMM must beat fp32; otherwise
// `--precision bf16` says why and runs fp32. nn/ .cc files only.
#pragma once

#include <torch/torch.h>

#include <memory>
#include <string>

#include "freeloc/nn/runtime.h"

namespace freeloc::nn::internal {

class PackedLinearBf16 {
 public:
  // `w` [out, in] fp32 and `b` [out] fp32 (or undefined), on the CPU.
  PackedLinearBf16(const torch::Tensor& w, const torch::Tensor& b);
  ~PackedLinearBf16();
  // x [..., in] fp32 or bf16 → [..., out] fp32.
  torch::Tensor operator()(const torch::Tensor& x) const { return Forward(x, false, false); }
  // With `gelu`: GELU (erf) applied inside the kernel. With `bf16_out`: the output in bf16 — for outputs that only
  // feed bf16 products (the MLP's hidden layer, attention's q/k/v): the same rounding as converting them there, one
  // memory pass less and half the bytes.
  torch::Tensor Forward(const torch::Tensor& x, bool gelu, bool bf16_out) const;
  // The oneDNN kernel chosen for `rows` rows (e.g. "brg:avx512_core_bf16").
  std::string Kernel(int64_t rows) const;
  // Packed copies of the weights held (one per distinct layout the kernels asked for) and their bytes.
  int PackedCopies() const;
  size_t PackedBytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct Bf16Decision {
  bool use = false;        // run bf16
  bool native = false;     // the CPU has native bf16 arithmetic (AVX512-BF16 or AMX-BF16) as oneDNN sees it
  double fp32_gflops = 0;  // the calibration GEMM (768 × 1024 × 1024) in fp32 (torch::linear) …
  double bf16_gflops = 0;  // … and through PackedLinearBf16
  std::string kernel;      // oneDNN's kernel for it
  std::string reason;      // one line for the log: what runs and why
};

// The pure rule: bf16 only with native support and when measured ≥ 10 % faster than fp32; `force` (FREELOC_BF16=force,
// for tests and benchmarks) runs bf16 regardless.
bool ChooseBf16(bool native, double fp32_seconds, double bf16_seconds, bool force);

// Whether a model loaded with `runtime` runs its matmuls in bf16: asked for, and on CUDA or where CpuBf16Decision()
// says it pays.
bool RunBf16(const RuntimeOptions& runtime);

// Decided once per process on the CPU (calibration ≈ 50 ms); logged once. FREELOC_BF16=force skips the measurement.
const Bf16Decision& CpuBf16Decision();

}  // namespace freeloc::nn::internal
