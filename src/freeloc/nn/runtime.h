// Where and how the networks run (docs/architecture.md §2): typed options with one string table per enum; applied by
// each model at load time.
#pragma once

#include <string>

#include "freeloc/core/enum_table.h"
#include "freeloc/core/error.h"

namespace freeloc::nn {

enum class Device { kCpu, kCuda };
// fp32 (parity) | bf16: matmuls and convolutions in bf16, norms/softmax/postprocessing in fp32.
enum class Precision { kFp32, kBf16 };

struct RuntimeOptions {
  Device device = Device::kCpu;
  Precision precision = Precision::kFp32;
  int threads = 0;  // 0 = LibTorch default
  // Throws freeloc::Error naming the field. Light (no LibTorch): whether CUDA exists is checked when a model loads.
  void Validate() const;
  std::string Key() const;  // "cpu|fp32|0": what makes two runtimes different (model caches key on it)
};

// Whether this LibTorch build can run on CUDA here (loads LibTorch).
bool CudaAvailable();

// Hands the memory freed while a model was built (its checkpoint, fp32 weights once packed in bf16) back to the
// system — glibc keeps freed blocks below its mmap threshold in the heap, where they stay resident. Call it after
// loading models (the networks' model cache does) and after each network pass of a query (the network stages do:
// a bf16 seed query's peak went 4.7 -> 4.3 GB, and 2.9 instead of 4.4 GB stays resident between queries, at no
// measurable cost in time).
void ReleaseFreedMemory();
// After a pass of `model`: the tensor pool's cache of free blocks (≤ 1 GiB) and glibc's freed chunks stay for the
// next pass (the same sizes again: no page faults — first-touch faults cost ≈ 0.4 ms per MB on a VM). The pool's
// blocks go when a pass needs room for blocks of other sizes (idle blocks add at most 192 MiB to the high-water mark of
// the passes since the model changed) or at the next ReleaseFreedMemory().
void ReleaseFreedMemory(const void* model);
// Before a network pass of `model`: if another model's pass came last, glibc's freed chunks go back (malloc_trim) and
// the pool's slack is counted from this model's passes on.
void BeginNetworkPass(const void* model);

}  // namespace freeloc::nn

namespace freeloc {
template <>
struct EnumTable<nn::Device> {
  static constexpr const char* kField = "device";
  static constexpr EnumEntry<nn::Device> kEntries[] = {{nn::Device::kCpu, "cpu"}, {nn::Device::kCuda, "cuda"}};
};
template <>
struct EnumTable<nn::Precision> {
  static constexpr const char* kField = "precision";
  static constexpr EnumEntry<nn::Precision> kEntries[] = {{nn::Precision::kFp32, "fp32"},
                                                          {nn::Precision::kBf16, "bf16"}};
};

namespace nn {
inline void RuntimeOptions::Validate() const {
  FREELOC_OPTION_CHECK("threads", threads >= 0, ": " << threads << " is negative; use 0 (library default) or a count");
  FREELOC_OPTION_CHECK("threads", threads <= 1024,
                       ": " << threads << " is more than 1024; use 0 (library default) or a count");
}
inline std::string RuntimeOptions::Key() const {
  return ToString(device) + "|" + ToString(precision) + "|" + std::to_string(threads);
}
}  // namespace nn
}  // namespace freeloc
