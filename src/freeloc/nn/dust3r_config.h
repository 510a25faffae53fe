// DUSt3R model configuration (AsymmetricCroCo3DStereo, spec/dust3r.md §1): dimensions, depths and DPT widths come
// from tensor shapes; head counts, RoPE base and modes from the constructor arguments found with the weights —
// the official .pth's `args.model` string, an HF config.json, or the fixture's config.json (`constructor_args`).
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include "freeloc/io/tensor.h"

namespace freeloc::nn {

struct Dust3rConfig {
  int patch_size = 16;
  int enc_dim = 1024, enc_depth = 24, enc_heads = 16, enc_mlp = 4096;
  int dec_dim = 768, dec_depth = 12, dec_heads = 12, dec_mlp = 3072;
  double rope_base = 100.0, rope_f0 = 1.0;
  double ln_eps = 1e-6;
  int dpt_feature_dim = 256, dpt_last_dim = 128, dpt_head0_dim = 128, dpt_channels = 4;
  std::array<int, 4> dpt_layer_dims = {96, 192, 384, 768};
  std::array<int, 4> hooks = {0, 6, 9, 12};
  std::string source;  // where the constructor arguments came from

  std::string Summary() const;
  void Validate() const;  // head dims divisible, RoPE needs head_dim % 4 == 0, …
};

// Keyword arguments of a Python constructor call "Name(a=1, b='x', c=(1, 2), …)" as raw value strings.
std::map<std::string, std::string> ParseConstructorKwargs(const std::string& call);

// Builds the configuration from the state dict (shapes) and the constructor kwargs (may be empty: released
// defaults). Throws freeloc::Error when they disagree or describe something other than the DUSt3R DPT model.
Dust3rConfig MakeDust3rConfig(const std::map<std::string, TensorView>& state_dict,
                              const std::map<std::string, std::string>& kwargs, const std::string& source);

}  // namespace freeloc::nn
