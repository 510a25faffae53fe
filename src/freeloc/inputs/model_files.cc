#include "freeloc/inputs/model_files.h"

#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "freeloc/core/env.h"

namespace freeloc::inputs {

const char* NetworkName(Network n) {
  switch (n) {
    case Network::kDust3r: return "DUSt3R";
    case Network::kMast3r: return "MASt3R";
    case Network::kSegGpt: return "SegGPT";
    case Network::kMetric3d: return "Metric3D v2";
  }
  return "?";
}

const char* NetworkOption(Network n) {
  switch (n) {
    case Network::kDust3r: return "dust3r_model";
    case Network::kMast3r: return "mast3r_model";
    case Network::kSegGpt: return "seggpt_model";
    case Network::kMetric3d: return "metric3d_model";
  }
  return "?";
}

std::vector<std::string> PublishedNames(Network n) {
  switch (n) {
    case Network::kDust3r:  // naver/dust3r checkpoint; HF naver/DUSt3R_ViTLarge_BaseDecoder_512_dpt
      return {"DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth", "DUSt3R_ViTLarge_BaseDecoder_512_dpt/model.safetensors"};
    case Network::kMast3r:  // naver/mast3r checkpoint; HF naver/MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric
      return {"MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric.pth",
              "MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric/model.safetensors"};
    case Network::kSegGpt:  // BAAI/SegGPT release; HF BAAI/seggpt-vit-large
      return {"seggpt_vit_large.pth", "seggpt-vit-large/model.safetensors"};
    case Network::kMetric3d:  // HF JUGGHM/Metric3D: the most accurate variant present first
      return {"metric_depth_vit_giant2_800k.pth", "metric_depth_vit_large_800k.pth", "metric_depth_vit_small_800k.pth"};
  }
  return {};
}

std::vector<std::string> ModelDirs(const std::string& models_dir) {
  std::vector<std::string> dirs;
  if (!models_dir.empty()) dirs.push_back(models_dir);
  if (const char* env = EnvSwitch("FREELOC_MODELS")) {
    std::stringstream ss(env);
    for (std::string d; std::getline(ss, d, ':');)
      if (!d.empty()) dirs.push_back(d);
  }
  return dirs;
}

std::string FindModel(Network n, const std::vector<std::string>& dirs) {
  for (const auto& d : dirs)
    for (const auto& name : PublishedNames(n)) {
      const auto p = std::filesystem::path(d) / name;
      std::error_code ec;
      if (std::filesystem::is_regular_file(p, ec)) return p.string();
    }
  return "";
}

std::string MissingModelMessage(Network n, const std::string& preset, const std::vector<std::string>& dirs) {
  std::string names, where;
  for (const auto& s : PublishedNames(n)) names += (names.empty() ? "" : " or ") + s;
  for (const auto& d : dirs) where += (where.empty() ? "" : ", ") + d;
  return std::string("preset ") + preset + " needs the " + NetworkName(n) + " weights: looked for " + names +
         (dirs.empty() ? " but neither models_dir nor $FREELOC_MODELS is set" : " in " + where) +
         "; download them as docs/models.md says and set models_dir to their folder (or " + NetworkOption(n) +
         " to the file); presets that need no weights: sift-essential, sift-pnp, sift-procrustes, "
         "precomputed:<SIFT|SG|LoFTR>-<essential|pnp|procrustes|hybrid>";
}

}  // namespace freeloc::inputs
