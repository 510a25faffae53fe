// DUSt3R / MASt3R model configuration (AsymmetricCroCo3DStereo, naver/dust3r; AsymmetricMASt3R, naver/mast3r
// §1): dimensions, depths, DPT and MLP widths come from tensor shapes; head counts, RoPE base, modes, the descriptor
// size D and two_confs from the constructor arguments found with the weights — the official .pth's `args.model`
// string, an HF config.json, or the fixture's config.json (`constructor_args`).
#pragma once

#include <array>
#include <limits>
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
  // reg_dense_conf: conf = conf_min + min(exp(x), conf_max − conf_min) (conf_mode ('exp', vmin, vmax)).
  double conf_min = 1, conf_max = std::numeric_limits<double>::infinity();
  // MASt3R's 'catmlp+dpt' head (local features): D = int(output_mode[10:]); 0 = none (DUSt3R's 'dpt').
  int local_feat_dim = 0;
  bool two_confs = false;  // desc_conf from its own channel (else a copy of conf)
  int local_mlp_hidden = 0;
  // desc_conf = desc_conf_min + min(exp(x), desc_conf_max − desc_conf_min); desc_conf_mode defaults to conf_mode.
  double desc_conf_min = 1, desc_conf_max = std::numeric_limits<double>::infinity();
  std::string desc_conf_mode_source = "conf_mode";  // "desc_conf_mode" or "conf_mode" (the fallback)
  std::string source;                               // where the constructor arguments came from

  bool is_mast3r() const { return local_feat_dim > 0; }
  const char* family() const { return is_mast3r() ? "MASt3R" : "DUSt3R"; }

  std::string Summary() const;
  void Validate() const;  // head dims divisible, RoPE needs head_dim % 4 == 0, …
};

// Keyword arguments of a Python constructor call "Name(a=1, b='x', c=(1, 2), …)" as raw value strings.
// The class name (before the parenthesis) is returned under the key "__class__".
std::map<std::string, std::string> ParseConstructorKwargs(const std::string& call);

// A confidence mode ("('exp', 0, inf)", "['exp', 1, 'inf']", '["exp",0,Infinity]'): vmin and vmax. Throws naming
// `key` for modes other than 'exp'.
void ParseConfMode(const std::string& text, const std::string& key, double* vmin, double* vmax);

// Builds the configuration from the state dict (shapes) and the constructor kwargs (may be empty: released
// defaults). Throws freeloc::Error when they disagree or describe something other than the DUSt3R DPT model.
Dust3rConfig MakeDust3rConfig(const std::map<std::string, io::TensorView>& state_dict,
                              const std::map<std::string, std::string>& kwargs, const std::string& source);

}  // namespace freeloc::nn
