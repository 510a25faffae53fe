#include "freeloc/nn/dust3r_config.h"

#include <sstream>

#include "freeloc/core/error.h"

namespace freeloc::nn {

std::string Dust3rConfig::Summary() const {
  std::ostringstream os;
  os << "DUSt3R enc " << enc_depth << "×" << enc_dim << " (" << enc_heads << " heads), dec " << dec_depth << "×"
     << dec_dim << " (" << dec_heads << " heads), patch " << patch_size << ", RoPE" << rope_base << ", DPT "
     << dpt_feature_dim << "/" << dpt_last_dim << "/[" << dpt_layer_dims[0] << "," << dpt_layer_dims[1] << ","
     << dpt_layer_dims[2] << "," << dpt_layer_dims[3] << "], hooks [" << hooks[0] << "," << hooks[1] << "," << hooks[2]
     << "," << hooks[3] << "]";
  return os.str();
}

void Dust3rConfig::Validate() const {
  FREELOC_CHECK(enc_heads > 0 && enc_dim % enc_heads == 0,
                "DUSt3R: enc_embed_dim " << enc_dim << " is not divisible by enc_num_heads " << enc_heads);
  FREELOC_CHECK(dec_heads > 0 && dec_dim % dec_heads == 0,
                "DUSt3R: dec_embed_dim " << dec_dim << " is not divisible by dec_num_heads " << dec_heads);
  FREELOC_CHECK((enc_dim / enc_heads) % 4 == 0 && (dec_dim / dec_heads) % 4 == 0,
                "DUSt3R: RoPE2D needs head dimensions divisible by 4 (enc " << enc_dim / enc_heads << ", dec "
                                                                            << dec_dim / dec_heads << ")");
  FREELOC_CHECK(dec_depth > 9, "DUSt3R: the DPT head needs dec_depth > 9 (got " << dec_depth << ")");
}

std::map<std::string, std::string> ParseConstructorKwargs(const std::string& call) {
  std::map<std::string, std::string> kw;
  const size_t open = call.find('(');
  const size_t close = call.rfind(')');
  if (open == std::string::npos || close == std::string::npos || close < open) return kw;
  const std::string body = call.substr(open + 1, close - open - 1);
  std::vector<std::string> parts;
  int depth = 0;
  char quote = 0;
  std::string cur;
  for (char c : body) {
    if (quote) {
      cur += c;
      if (c == quote) quote = 0;
      continue;
    }
    if (c == '\'' || c == '"') quote = c;
    if (c == '(' || c == '[' || c == '{') ++depth;
    if (c == ')' || c == ']' || c == '}') --depth;
    if (c == ',' && depth == 0) {
      parts.push_back(cur);
      cur.clear();
      continue;
    }
    cur += c;
  }
  if (!cur.empty()) parts.push_back(cur);
  auto trim = [](std::string s) {
    const size_t b = s.find_first_not_of(" \t\n");
    const size_t e = s.find_last_not_of(" \t\n");
    return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  };
  for (const auto& p : parts) {
    const size_t eq = p.find('=');
    if (eq == std::string::npos) continue;
    std::string v = trim(p.substr(eq + 1));
    if (v.size() >= 2 && (v.front() == '\'' || v.front() == '"') && v.back() == v.front())
      v = v.substr(1, v.size() - 2);
    kw[trim(p.substr(0, eq))] = v;
  }
  return kw;
}

namespace {

const TensorView& Need(const std::map<std::string, TensorView>& sd, const std::string& name) {
  auto it = sd.find(name);
  FREELOC_CHECK(it != sd.end(), "DUSt3R weights: tensor '" << name << "' is missing; is this a DUSt3R checkpoint?");
  return it->second;
}

int CountBlocks(const std::map<std::string, TensorView>& sd, const std::string& prefix) {
  int n = 0;
  while (sd.count(prefix + std::to_string(n) + ".norm1.weight")) ++n;
  return n;
}

int IntArg(const std::map<std::string, std::string>& kw, const std::string& key, int fallback) {
  auto it = kw.find(key);
  if (it == kw.end()) return fallback;
  try {
    return std::stoi(it->second);
  } catch (...) {
    FREELOC_THROW("DUSt3R config: " << key << "=" << it->second << " is not an integer");
  }
}

}  // namespace

Dust3rConfig MakeDust3rConfig(const std::map<std::string, TensorView>& sd, const std::map<std::string, std::string>& kw,
                              const std::string& source) {
  Dust3rConfig c;
  c.source = source;
  const TensorView& pe = Need(sd, "patch_embed.proj.weight");
  FREELOC_CHECK(pe.shape.size() == 4 && pe.shape[1] == 3 && pe.shape[2] == pe.shape[3],
                "DUSt3R weights: patch_embed.proj.weight has shape " << pe.ShapeString() << ", expected [C, 3, p, p]");
  c.patch_size = static_cast<int>(pe.shape[2]);
  c.enc_dim = static_cast<int>(pe.shape[0]);
  c.enc_depth = CountBlocks(sd, "enc_blocks.");
  FREELOC_CHECK(c.enc_depth > 0, "DUSt3R weights: no enc_blocks.*");
  c.enc_mlp = static_cast<int>(Need(sd, "enc_blocks.0.mlp.fc1.weight").shape[0]);
  const TensorView& de = Need(sd, "decoder_embed.weight");
  c.dec_dim = static_cast<int>(de.shape[0]);
  FREELOC_CHECK(de.shape[1] == c.enc_dim, "DUSt3R weights: decoder_embed.weight "
                                              << de.ShapeString() << " does not take the encoder width " << c.enc_dim);
  c.dec_depth = CountBlocks(sd, "dec_blocks.");
  c.dec_mlp = static_cast<int>(Need(sd, "dec_blocks.0.mlp.fc1.weight").shape[0]);
  const std::string h = "downstream_head1.dpt.";
  for (int i = 0; i < 4; ++i) {
    c.dpt_layer_dims[i] = static_cast<int>(Need(sd, h + "act_postprocess." + std::to_string(i) + ".0.weight").shape[0]);
  }
  const std::string rn =
      sd.count(h + "scratch.layer1_rn.weight") ? h + "scratch.layer1_rn.weight" : h + "scratch.layer_rn.0.weight";
  c.dpt_feature_dim = static_cast<int>(Need(sd, rn).shape[0]);
  c.dpt_head0_dim = static_cast<int>(Need(sd, h + "head.0.weight").shape[0]);
  c.dpt_last_dim = static_cast<int>(Need(sd, h + "head.2.weight").shape[0]);
  c.dpt_channels = static_cast<int>(Need(sd, h + "head.4.weight").shape[0]);
  c.hooks = {0, c.dec_depth * 2 / 4, c.dec_depth * 3 / 4, c.dec_depth};
  // Constructor arguments: heads (defaults of the released model when absent), RoPE base, modes.
  c.enc_heads = IntArg(kw, "enc_num_heads", 16);
  c.dec_heads = IntArg(kw, "dec_num_heads", 12);
  for (const char* key : {"enc_embed_dim", "enc_depth", "dec_embed_dim", "dec_depth"}) {
    auto it = kw.find(key);
    if (it == kw.end()) continue;
    const int v = IntArg(kw, key, 0);
    const int have = std::string(key) == "enc_embed_dim"   ? c.enc_dim
                     : std::string(key) == "enc_depth"     ? c.enc_depth
                     : std::string(key) == "dec_embed_dim" ? c.dec_dim
                                                           : c.dec_depth;
    FREELOC_CHECK(v == have, "DUSt3R: " << source << " says " << key << "=" << v << " but the weights have " << have
                                        << "; the config does not belong to these weights");
  }
  if (auto it = kw.find("pos_embed"); it != kw.end()) {
    FREELOC_CHECK(it->second.rfind("RoPE", 0) == 0,
                  "DUSt3R: pos_embed '" << it->second << "' is not supported (only RoPE<base>, as released)");
    c.rope_base = std::stod(it->second.substr(4));
  }
  if (auto it = kw.find("head_type"); it != kw.end())
    FREELOC_CHECK(it->second == "dpt", "DUSt3R: head_type '" << it->second << "' is not supported (only dpt)");
  if (auto it = kw.find("output_mode"); it != kw.end())
    FREELOC_CHECK(it->second == "pts3d", "DUSt3R: output_mode '" << it->second << "' is not supported (only pts3d)");
  if (auto it = kw.find("depth_mode"); it != kw.end())
    FREELOC_CHECK(it->second.find("exp") != std::string::npos,
                  "DUSt3R: depth_mode " << it->second << " is not supported");
  if (auto it = kw.find("conf_mode"); it != kw.end())
    FREELOC_CHECK(it->second.find("exp") != std::string::npos,
                  "DUSt3R: conf_mode " << it->second << " is not supported");
  c.Validate();
  return c;
}

}  // namespace freeloc::nn
