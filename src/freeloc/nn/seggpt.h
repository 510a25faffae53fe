// SegGPT (baaivision/Painter models_seggpt.SegGPT) in LibTorch: shared patch embedding of the image
// and mask streams, mask token on the target half of the mask stream, segment/type tokens, bicubic size-based
// resize of the absolute position embedding, global attention with decomposed relative positions (unscaled q),
// the original feature-ensemble schedule, stream merge after `merge_index`, the shared final norm at the
// `out_indices` taps, pixel-shuffle decoder. Torch-free interface.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/core/image.h"
#include "freeloc/io/tensor.h"
#include "freeloc/nn/runtime.h"
#include "freeloc/vision/seggpt_preprocess.h"

namespace freeloc::nn {

struct SegGptConfig {
  int embed_dim = 1024, depth = 24, heads = 16, mlp = 4096, patch = 16;
  int half = 448;                // S: each half of the network input is S×S
  int grid_h = 56, grid_w = 28;  // token grid of the (2S)×S input
  int pos_grid = 14;             // pretraining grid of pos_embed (cls entry dropped)
  int decoder_dim = 64;
  int merge_index = 2;
  std::vector<int> out_indices = {5, 11, 17, 23};
  double ln_eps = 1e-6;
  std::string source;
  std::string Summary() const;
};

enum class SegType { kSemantic = 0, kInstance = 1 };
SegType ParseSegType(const std::string& s);  // "instance" | "semantic"

class SegGptModel {
 public:
  // The original .pth (`['model']`), HF model.safetensors (renamed on load; config.json beside it is read), or a
  // safetensors with original names plus `config_path` (the fixture's config.json).
  static std::shared_ptr<SegGptModel> Load(const std::string& model_path, const std::string& config_path = "",
                                           const RuntimeOptions& runtime = {});
  static std::shared_ptr<SegGptModel> Create(const std::map<std::string, io::TensorView>& state_dict,
                                             const std::string& config_json, const std::string& source,
                                             const RuntimeOptions& runtime = {});
  ~SegGptModel();
  const SegGptConfig& config() const;

  // The network on prepared inputs [K, 3, 2S, S]; the feature ensemble runs when `ensemble` (the original code
  // turns it on exactly when K > 1). Returns pred [K, 3, 2S, S] in normalised space.
  io::TensorView Forward(const std::vector<float>& imgs, const std::vector<float>& tgts, int k, SegType type,
                         bool ensemble) const;
  // Preprocessing + network + post-processing of item 0 (as run_one_image): the binary mask at the target's size.
  vision::SegGptMask Segment(const std::vector<Image>& prompt_images, const std::vector<Image>& prompt_masks,
                             const Image& target, SegType type = SegType::kInstance,
                             io::TensorView* raw_pred = nullptr) const;

  // Parity taps under the fixture names: embeddings, block0_out, merged, decoder_input, decoder_pixel_shuffled,
  // pos_embed_resized.
  void SetTapSink(std::map<std::string, io::TensorView>* sink) const;

 private:
  struct Impl;
  explicit SegGptModel(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace freeloc::nn
