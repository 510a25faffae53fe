// Torch bridge for nn/ .cc files only (never included from a public header): checkpoint TensorViews ↔ torch
// tensors without copies, and the precision policy.
#pragma once

#include <torch/torch.h>

#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "freeloc/io/tensor.h"
#include "freeloc/nn/runtime.h"

namespace freeloc::nn::internal {

// Zero-copy view of a checkpoint tensor (the TensorView's owner is kept alive by the torch tensor's deleter).
torch::Tensor ToTorch(const io::TensorView& t);
// Contiguous float32 CPU copy as a TensorView (owns its bytes through the tensor).
io::TensorView ToView(const torch::Tensor& t);

torch::Device DeviceOf(const RuntimeOptions& r);

// Validates the runtime options and applies the thread count (every model's Create starts with this).
void ApplyRuntime(const RuntimeOptions& runtime);
// Python's json.dump writes ±inf and NaN as the bare tokens Infinity, -Infinity, NaN (HF config.json of MASt3R),
// which strict JSON rejects: outside strings they become the strings "inf", "-inf", "nan".
std::string QuoteNonFiniteJson(const std::string& text);
// A model config's JSON (non-finite tokens accepted, see above); an error names `source` and the model (`what`) when it
// does not parse.
nlohmann::json ParseModelConfig(const std::string& text, const std::string& source, const std::string& what);

// The text of a model's config: `config_path` when given, else a config.json beside safetensors weights (the HF
// layout), else "{}". `what` names the model in errors.
std::string ReadModelConfig(const std::string& model_path, const std::string& config_path, bool is_safetensors,
                            const std::string& what);

// Name → tensor with bookkeeping: every Take() is recorded so that unexpected tensors can be reported, and a
// missing tensor is an error that lists all the missing ones at once (Finish()).
class WeightStore {
 public:
  // `own_copies`: every tensor taken is a copy of its own (bf16 models): the weights kept in fp32 (norms, biases,
  // heads) then hold no reference to a checkpoint's shared buffer (a safetensors file), which is freed after load
  // while the packed bf16 copies serve — the weights are held once.
  WeightStore(std::map<std::string, torch::Tensor> tensors, std::string source, torch::Device device,
              bool own_copies = false);
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
  bool own_copies_ = false;
  std::set<std::string> used_;
  std::vector<std::string> missing_;
  std::vector<std::string> wrong_shape_;
};

}  // namespace freeloc::nn::internal
