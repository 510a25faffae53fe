// DUSt3R (AsymmetricCroCo3DStereo, naver/dust3r) inference in LibTorch: siamese ViT encoder with RoPE2D, two
// decoders updated simultaneously with cross-attention, two DPT heads, pts3d/conf postprocessing
// (naver/dust3r). The same class runs MASt3R (AsymmetricMASt3R, naver/mast3r): DUSt3R's
// trunk plus the 'catmlp+dpt' local-feature head (per-token MLP on [encoder ‖ decoder] tokens, pixel-shuffled to
// dense unit descriptors and their confidence), chosen from the checkpoint. Native portrait and mixed shapes; different
// token counts per view. The encoder output of a view can be cached and reused against many others (`Encode` once,
// `Decode` per query). Torch-free interface: inputs are normalised CHW floats (vision/dust3r_preprocess.h), outputs
// float32 TensorViews.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/io/tensor.h"
#include "freeloc/nn/dust3r_config.h"
#include "freeloc/nn/runtime.h"

namespace freeloc::nn {

struct Dust3rView {
  const float* chw = nullptr;  // 3×H×W, (u8/255 − 0.5)/0.5
  int height = 0, width = 0;
};

struct Dust3rPrediction {
  io::TensorView pts3d_1;  // [H1, W1, 3] view 1's points in view 1's frame
  io::TensorView conf_1;   // [H1, W1]
  io::TensorView pts3d_2;  // [H2, W2, 3] view 2's points in view 1's frame
  io::TensorView conf_2;   // [H2, W2]
  // MASt3R only (empty for DUSt3R or when not asked for): unit descriptors and their confidence per view.
  io::TensorView desc_1;       // [H1, W1, D]
  io::TensorView desc_conf_1;  // [H1, W1]
  io::TensorView desc_2;       // [H2, W2, D]
  io::TensorView desc_conf_2;  // [H2, W2]
  double encode_ms = 0, decode_ms = 0, heads_ms = 0;
};

// What a decode computes (both decoders always run: they cross-attend at every block; each head reads only its own
// decoder, so a route pays only for the outputs it uses — docs/pipeline.md "The MASt3R routes").
struct DecodeOutputs {
  bool view1 = true;        // head 1: pts3d_1, conf_1 (and desc_1 with descriptors)
  bool view2 = true;        // head 2: pts3d_2, conf_2 (and desc_2)
  bool descriptors = true;  // MASt3R's local features of the views computed
};

class Dust3rModel {
 public:
  // The encoder output of one view (tokens after enc_norm, positions, grid), opaque to callers.
  class Encoding;

  // `model_path`: the official .pth, an HF model.safetensors (config.json beside it is read when present; bare
  // Infinity tokens accepted), or any safetensors with DUSt3R/MASt3R key names. `config_path` (optional): a config.json
  // with the constructor arguments (top level, or under "constructor_args"). Throws freeloc::Error naming
  // missing/unexpected tensors.
  static std::shared_ptr<Dust3rModel> Load(const std::string& model_path, const std::string& config_path = "",
                                           const RuntimeOptions& runtime = {});
  // The same from a state dict already in memory (upstream key names) and constructor kwargs (may be empty).
  // `source`: where the kwargs came from (config().source); `weights`: what weight errors name (default: source).
  static std::shared_ptr<Dust3rModel> Create(const std::map<std::string, io::TensorView>& state_dict,
                                             const std::map<std::string, std::string>& kwargs,
                                             const std::string& source, const RuntimeOptions& runtime = {},
                                             const std::string& weights = "");
  ~Dust3rModel();

  const Dust3rConfig& config() const;
  const RuntimeOptions& runtime() const;

  std::shared_ptr<const Encoding> Encode(const Dust3rView& view) const;
  Dust3rPrediction Decode(const Encoding& view1, const Encoding& view2, const DecodeOutputs& outputs = {}) const;
  // One shot: encodes each view on its own (upstream batches same-shape pairs; the results agree within float
  // rounding, and this way the cached-reference path gives identical outputs) and decodes.
  Dust3rPrediction Run(const Dust3rView& view1, const Dust3rView& view2) const;

  // Debugging/parity: when set, intermediate tensors are stored under the fixture names ("enc1.out",
  // "dec2.block05", "head1.rn2", "head1.raw", MASt3R's "head1.mlp_in", "head1.mlp_hidden", "head1.mlp_out",
  // "head1.local", …) as float32 TensorViews.
  void SetTapSink(std::map<std::string, io::TensorView>* sink) const;

 private:
  struct Impl;
  std::shared_ptr<const Encoding> EncodeView(const Dust3rView& view, int tap_id) const;
  explicit Dust3rModel(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace freeloc::nn
