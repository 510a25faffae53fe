#include "freeloc/nn/dust3r_config.h"

#include <sstream>

#include "freeloc/core/error.h"

namespace freeloc::nn {

std::string Dust3rConfig::Summary() const {
  std::ostringstream os;
  os << family() << " enc " << enc_depth << "×" << enc_dim << " (" << enc_heads << " heads), dec " << dec_depth << "×"
     << dec_dim << " (" << dec_heads << " heads), patch " << patch_size << ", RoPE" << rope_base << ", DPT "
     << dpt_feature_dim << "/" << dpt_last_dim << "/[" << dpt_layer_dims[0] << "," << dpt_layer_dims[1] << ","
     << dpt_layer_dims[2] << "," << dpt_layer_dims[3] << "], hooks [" << hooks[0] << "," << hooks[1] << "," << hooks[2]
     << "," << hooks[3] << "]";
  if (is_mast3r())
    os << ", local features D=" << local_feat_dim << " (MLP " << local_mlp_hidden << ", two_confs "
       << (two_confs ? "true" : "false") << ", desc_conf " << desc_conf_min << " + exp(x) from "
       << (two_confs ? desc_conf_mode_source : std::string("conf (two_confs false)")) << ")";
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
  FREELOC_CHECK(local_feat_dim >= 0 && local_feat_dim <= 4096,
                "MASt3R: local_feat_dim " << local_feat_dim << " is out of range");
  FREELOC_CHECK(conf_max > conf_min && desc_conf_max > desc_conf_min,
                "DUSt3R: a confidence mode has vmax <= vmin (conf " << conf_min << ".." << conf_max << ", desc_conf "
                                                                    << desc_conf_min << ".." << desc_conf_max << ")");
}

std::map<std::string, std::string> ParseConstructorKwargs(const std::string& call) {
  std::map<std::string, std::string> kw;
  const size_t open = call.find('(');
  const size_t close = call.rfind(')');
  if (open == std::string::npos || close == std::string::npos || close < open) return kw;
  {
    std::string name = call.substr(0, open);
    const size_t b = name.find_first_not_of(" \t\n"), e = name.find_last_not_of(" \t\n");
    kw["__class__"] = b == std::string::npos ? "" : name.substr(b, e - b + 1);
  }
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

const io::TensorView& Need(const std::map<std::string, io::TensorView>& sd, const std::string& name) {
  auto it = sd.find(name);
  FREELOC_CHECK(it != sd.end(), "DUSt3R weights: tensor '" << name << "' is missing; is this a DUSt3R checkpoint?");
  return it->second;
}

int CountBlocks(const std::map<std::string, io::TensorView>& sd, const std::string& prefix) {
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

bool BoolArg(const std::map<std::string, std::string>& kw, const std::string& key, bool fallback) {
  auto it = kw.find(key);
  if (it == kw.end()) return fallback;
  if (it->second == "True" || it->second == "true" || it->second == "1") return true;
  if (it->second == "False" || it->second == "false" || it->second == "0") return false;
  FREELOC_THROW("DUSt3R config: " << key << "=" << it->second << " is not a boolean");
}

bool IsNone(const std::string& v) { return v.empty() || v == "None" || v == "null"; }

double ParseBound(std::string t, const std::string& key, const std::string& text) {
  if (t == "inf" || t == "Infinity" || t == "+inf" || t == "float('inf')")
    return std::numeric_limits<double>::infinity();
  if (t == "-inf" || t == "-Infinity" || t == "-float('inf')") return -std::numeric_limits<double>::infinity();
  try {
    size_t used = 0;
    const double v = std::stod(t, &used);
    if (used == t.size()) return v;
  } catch (...) {
  }
  FREELOC_THROW("model config: " << key << "=" << text << ": '" << t << "' is not a number");
}

}  // namespace

void ParseConfMode(const std::string& text, const std::string& key, double* vmin, double* vmax) {
  std::vector<std::string> items;
  std::string cur;
  for (char ch : text) {
    if (ch == '(' || ch == ')' || ch == '[' || ch == ']' || ch == '\'' || ch == '"' || ch == ' ' || ch == '\t' ||
        ch == '\n')
      continue;
    if (ch == ',') {
      items.push_back(cur);
      cur.clear();
      continue;
    }
    cur += ch;
  }
  if (!cur.empty()) items.push_back(cur);
  FREELOC_CHECK(items.size() == 3 && items[0] == "exp",
                "model config: " << key << "=" << text << " is not supported (only ('exp', vmin, vmax), as released)");
  *vmin = ParseBound(items[1], key, text);
  *vmax = ParseBound(items[2], key, text);
}

Dust3rConfig MakeDust3rConfig(const std::map<std::string, io::TensorView>& sd,
                              const std::map<std::string, std::string>& kw, const std::string& source) {
  Dust3rConfig c;
  c.source = source;
  const io::TensorView& pe = Need(sd, "patch_embed.proj.weight");
  FREELOC_CHECK(pe.shape.size() == 4 && pe.shape[1] == 3 && pe.shape[2] == pe.shape[3],
                "DUSt3R weights: patch_embed.proj.weight has shape " << pe.ShapeString() << ", expected [C, 3, p, p]");
  c.patch_size = static_cast<int>(pe.shape[2]);
  c.enc_dim = static_cast<int>(pe.shape[0]);
  c.enc_depth = CountBlocks(sd, "enc_blocks.");
  FREELOC_CHECK(c.enc_depth > 0, "DUSt3R weights: no enc_blocks.*");
  c.enc_mlp = static_cast<int>(Need(sd, "enc_blocks.0.mlp.fc1.weight").shape[0]);
  const io::TensorView& de = Need(sd, "decoder_embed.weight");
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
  // The head: DUSt3R's 'dpt' (output 'pts3d') or MASt3R's 'catmlp+dpt' (output 'pts3d+desc<D>', naver/mast3r).
  const bool has_local = sd.count("downstream_head1.head_local_features.fc1.weight") > 0;
  std::string head_type = has_local ? "catmlp+dpt" : "dpt";
  if (auto it = kw.find("head_type"); it != kw.end()) head_type = it->second;
  FREELOC_CHECK(head_type == "dpt" || head_type == "catmlp+dpt",
                "DUSt3R/MASt3R: head_type '" << head_type << "' is not supported (dpt or catmlp+dpt)");
  FREELOC_CHECK((head_type == "catmlp+dpt") == has_local,
                source << " says head_type '" << head_type << "' but the weights " << (has_local ? "have" : "have no")
                       << " head_local_features tensors");
  if (auto it = kw.find("depth_mode"); it != kw.end())
    FREELOC_CHECK(it->second.find("exp") != std::string::npos,
                  "DUSt3R: depth_mode " << it->second << " is not supported");
  if (auto it = kw.find("conf_mode"); it != kw.end() && !IsNone(it->second))
    ParseConfMode(it->second, "conf_mode", &c.conf_min, &c.conf_max);
  std::string output_mode = head_type == "dpt" ? "pts3d" : "";
  if (auto it = kw.find("output_mode"); it != kw.end()) output_mode = it->second;
  if (head_type == "dpt") {
    FREELOC_CHECK(output_mode == "pts3d",
                  "DUSt3R: output_mode '" << output_mode << "' is not supported (only pts3d for head_type dpt)");
  } else {
    // D and two_confs come from the configuration, never from fc2's shape: (D + two_confs)·p² is ambiguous.
    FREELOC_CHECK(output_mode.rfind("pts3d+desc", 0) == 0 && output_mode.size() > 10,
                  "MASt3R: output_mode '" << output_mode << "' is not supported (pts3d+desc<D>); " << source
                                          << " must give it (the descriptor size cannot be read from the "
                                             "weights)");
    try {
      size_t used = 0;
      c.local_feat_dim = std::stoi(output_mode.substr(10), &used);
      FREELOC_CHECK(used == output_mode.size() - 10 && c.local_feat_dim > 0, "");
    } catch (...) {
      FREELOC_THROW("MASt3R: output_mode '" << output_mode
                                            << "': the descriptor size after 'pts3d+desc' is not a "
                                               "positive integer");
    }
    c.two_confs = BoolArg(kw, "two_confs", false);
    if (auto it = kw.find("desc_mode"); it != kw.end())
      FREELOC_CHECK(it->second == "norm", "MASt3R: desc_mode '" << it->second << "' is not supported (only norm)");
    c.desc_conf_min = c.conf_min;
    c.desc_conf_max = c.conf_max;
    c.desc_conf_mode_source = "conf_mode (desc_conf_mode absent)";
    if (auto it = kw.find("desc_conf_mode"); it != kw.end() && !IsNone(it->second)) {
      ParseConfMode(it->second, "desc_conf_mode", &c.desc_conf_min, &c.desc_conf_max);
      c.desc_conf_mode_source = "desc_conf_mode";
    }
    const std::string lf = "downstream_head1.head_local_features.";
    const io::TensorView& fc1 = Need(sd, lf + "fc1.weight");
    const io::TensorView& fc2 = Need(sd, lf + "fc2.weight");
    FREELOC_CHECK(fc1.shape.size() == 2 && fc1.shape[1] == c.enc_dim + c.dec_dim,
                  "MASt3R weights: " << lf << "fc1.weight has shape " << fc1.ShapeString() << ", expected [hidden, "
                                     << c.enc_dim + c.dec_dim << "] (encoder + decoder width)");
    c.local_mlp_hidden = static_cast<int>(fc1.shape[0]);
    const int64_t rows = static_cast<int64_t>(c.local_feat_dim + (c.two_confs ? 1 : 0)) * c.patch_size * c.patch_size;
    FREELOC_CHECK(fc2.shape.size() == 2 && fc2.shape[0] == rows && fc2.shape[1] == c.local_mlp_hidden,
                  "MASt3R: " << lf << "fc2.weight has shape " << fc2.ShapeString() << " but output_mode '"
                             << output_mode << "' and two_confs=" << (c.two_confs ? "True" : "False") << " need ["
                             << rows << ", " << c.local_mlp_hidden << "] ((D + two_confs)·" << c.patch_size << "²); "
                             << "the configuration does not belong to these weights");
  }
  c.Validate();
  return c;
}

}  // namespace freeloc::nn
