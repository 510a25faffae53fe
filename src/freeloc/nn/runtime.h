// Where and how the networks run. Plain options (DESIGN §2); applied by each model at load time.
#pragma once

#include <string>

namespace freeloc::nn {

struct RuntimeOptions {
  std::string device = "cpu";      // cpu | cuda
  std::string precision = "fp32";  // fp32 | bf16 (matmuls/convs in bf16, norms/softmax/postprocess in fp32)
  int threads = 0;                 // 0 = LibTorch default
  void Validate() const;           // throws freeloc::Error (e.g. cuda without a CUDA build of LibTorch)
};

// Whether this LibTorch build can run on CUDA here.
bool CudaAvailable();

}  // namespace freeloc::nn
