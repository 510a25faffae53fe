// The relocalization pipeline (DESIGN §1–3): matchers (the benchmark's SIFT extractor, DUSt3R global reciprocal
// matches, precomputed correspondences), provided depth maps, and the three solvers (essential + metric scale,
// PnP, Procrustes). The seed presets (SegGPT instances, Metric3D depth) are named but report that their stage is
// not wired in yet, so a user never gets a silent fallback.
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/image.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/io/mapfree.h"

namespace freeloc::pipeline {

struct PipelineOptions {
  std::string preset = "sift-essential";
  std::string matcher = "sift";           // sift | dust3r | precomputed:<SIFT|SG|LoFTR|…>
  std::string depth = "provided:sensor";  // provided:<suffix> | none
  std::string solver = "essential";       // essential | pnp | procrustes
  std::string scale = "robust";           // robust | official (essential only)
  double threshold_px = -1;               // < 0: the solver's default
  // matcher dust3r: global reciprocal 3D matches of DUSt3R pointmaps (no instances yet).
  std::string dust3r_model;  // official .pth or model.safetensors
  int dust3r_size = 512;     // load_images size
  std::string device = "cpu";
  int threads = 0;  // 0 = library default
  void Validate() const;
  std::string Summary() const;
};

// Resolves a preset name into options (then overridable). Throws freeloc::Error naming the preset when it is
// unknown, and saying which stage is missing for the network presets.
PipelineOptions ResolvePreset(const std::string& name);
std::vector<std::string> PresetNames();

struct QueryResult {
  std::string frame;
  bool ok = false;
  std::string status;  // "ok" or why not (no-matches, too-few-matches, no-consensus, no-depth, scale-…)
  Rigid3d query_from_ref;
  double confidence = 0;
  int matches = 0, inliers = 0;
  double match_ms = 0, solve_ms = 0;
};

// One pair. `depth_ref`/`depth_query` may be empty (depth "none": the translation then has unit norm and the
// status says so). `precomputed` gives the correspondences when the matcher is precomputed.
QueryResult RelocalizePair(const Image& ref, const Image& query, const Camera& k_ref, const Camera& k_query,
                           const DepthMap& depth_ref, const DepthMap& depth_query, const PipelineOptions& options,
                           const std::vector<Eigen::Vector4d>* precomputed = nullptr);

// Loads (and keeps for the process) the networks `options` names, so that a missing or damaged weights file is
// one error before any work starts rather than a failure of every query. Throws freeloc::Error naming the file.
void LoadModels(const PipelineOptions& options);

// Every query of a map-free scene; the reference image, depth and correspondences are loaded once.
std::vector<QueryResult> RelocalizeScene(const MapfreeScene& scene, const PipelineOptions& options);

}  // namespace freeloc::pipeline
