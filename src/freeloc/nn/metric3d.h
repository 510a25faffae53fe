// Metric3D v2 (YvanYin/Metric3D: DinoVisionTransformer with 4 registers + RAFTDepthNormalDPT5) in
// LibTorch: metric depth, confidence and surface normals from one image and its intrinsics. The ViT variants
// (vit_small, vit_large: the final norm fed four times; vit_giant2: raw outputs of evenly spaced blocks, SwiGLU)
// are read from the checkpoint's shapes and the config. Torch-free interface.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/image.h"
#include "freeloc/io/tensor.h"
#include "freeloc/nn/runtime.h"
#include "freeloc/vision/metric3d_preprocess.h"

namespace freeloc::nn {

struct Metric3dConfig {
  std::string variant;  // vit_small | vit_large | vit_giant2 | custom
  int embed_dim = 384, depth = 12, heads = 6, ffn_hidden = 1536, patch = 14, registers = 4, pos_grid = 37;
  bool swiglu = false;
  bool multi_output = false;        // raw outputs of `feature_blocks` instead of the final norm ×4
  std::vector<int> feature_blocks;  // multi_output: the 4 blocks whose outputs feed the decoder
  std::vector<int> feature_channels = {96, 192, 384, 768};
  std::vector<int> decoder_channels = {48, 96, 192, 384, 384};
  int hidden = 48, iters = 4;
  int input_h = 616, input_w = 1064;
  int num_bins = 256;
  double min_depth = 0.1, max_depth = 200, regress_scale = 100, canonical_focal = 1000;
  double ln_eps = 1e-6;
  std::string Summary() const;
};

struct Metric3dOutput {
  DepthMap depth;                  // metric depth at the original resolution (metres, clamp [0, 300])
  std::vector<float> confidence;   // [h, w], raw network confidence resized like depth
  std::vector<float> normal;       // [3, h, w] unit normal xyz (camera frame), not re-normalised after resizing
  io::TensorView canonical_depth;  // [H, W] network-resolution canonical depth (metres at focal 1000), padded
  vision::Metric3dInput input;     // the preprocessing that was applied
  double network_ms = 0;
  std::map<std::string, std::string> metadata;  // model, variant, precision, input size, scale, focal factor
};

class Metric3dModel {
 public:
  // The released .pth (`['model_state_dict']`, `depth_model.encoder.*` / `depth_model.decoder.*`) or safetensors
  // with the same names, plus an optional config.json (the fixture's layout: encoder/decoder/data sections).
  static std::shared_ptr<Metric3dModel> Load(const std::string& model_path, const std::string& config_path = "",
                                             const RuntimeOptions& runtime = {});
  static std::shared_ptr<Metric3dModel> Create(const std::map<std::string, io::TensorView>& state_dict,
                                               const std::string& config_json, const std::string& source,
                                               const RuntimeOptions& runtime = {});
  ~Metric3dModel();
  const Metric3dConfig& config() const;

  // The network on a prepared input [3, H, W]: canonical depth, confidence [H, W] and normal [4, H, W].
  void Forward(const std::vector<float>& input, io::TensorView* pred_depth, io::TensorView* confidence,
               io::TensorView* pred_normal) const;
  // Preprocessing + network + postprocessing (hubconf.py): metric depth with this frame's intrinsics.
  Metric3dOutput Estimate(const Image& image, const Camera& camera) const;

  // Parity taps under the fixture names (patch_embed_out, pos_embed_interp, tokens_prepared, encoder_features,
  // readout_{0..3}, ref_feat, init_depth_expectation, normal_head_raw, depth_init, net_init_*, context_*,
  // iter_state, net_final_*, up_mask_final).
  void SetTapSink(std::map<std::string, io::TensorView>* sink) const;

 private:
  struct Impl;
  explicit Metric3dModel(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace freeloc::nn
