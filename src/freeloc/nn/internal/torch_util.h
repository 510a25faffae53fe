// Torch bridge for nn/ .cc files only (never included from a public header): checkpoint TensorViews ↔ torch
// tensors without copies, and the precision policy.
#pragma once

#include <torch/torch.h>

#include <map>
#include <set>
#include <string>
#include <vector>

#include "freeloc/io/tensor.h"
#include "freeloc/nn/runtime.h"

namespace freeloc::nn::internal {

// Zero-copy view of a checkpoint tensor (the TensorView's owner is kept alive by the torch tensor's deleter).
torch::Tensor ToTorch(const TensorView& t);
// Contiguous float32 CPU copy as a TensorView (owns its bytes through the tensor).
TensorView ToView(const torch::Tensor& t);

torch::Device DeviceOf(const RuntimeOptions& r);

// Name → tensor with bookkeeping: every Take() is recorded so that unexpected tensors can be reported, and a
// missing tensor is an error that lists all the missing ones at once (Finish()).
class WeightStore {
 public:
  WeightStore(std::map<std::string, torch::Tensor> tensors, std::string source, torch::Device device);
  // The tensor `name`, optionally checked against `shape` (−1 = any); moved to the device as float32.
  torch::Tensor Take(const std::string& name, const std::vector<int64_t>& shape = {});
  bool Has(const std::string& name) const { return tensors_.count(name) > 0; }
  void Ignore(const std::string& name) { used_.insert(name); }
  void Alias(const std::string& name, const std::string& same_as);  // both spellings of one tensor
  // Throws freeloc::Error listing missing and unexpected tensors (names ignored or aliased are fine).
  void Finish() const;

 private:
  std::map<std::string, torch::Tensor> tensors_;
  std::string source_;
  torch::Device device_;
  std::set<std::string> used_;
  std::vector<std::string> missing_;
  std::vector<std::string> wrong_shape_;
};

}  // namespace freeloc::nn::internal
