// The relocalization pipeline (DESIGN §1–3). Stages, each chosen by a plain option:
//   matcher  — sift (the benchmark's extractor), dust3r (global reciprocal 3D matches of DUSt3R pointmaps),
//              dust3r+instances (the paper: reference instances proposed on the reference's own pointmap, propagated
//              into the query by SegGPT, DUSt3R re-run per masked instance pair, merged by Eq. 3), precomputed:<name>;
//   depth    — provided:<suffix> (the scene's depth PNGs), metric3d (Metric3D v2 on each image), none;
//   solver   — essential (+ metric scale from depth), pnp, procrustes.
// A `Relocalizer` does the reference frame's work once (its depth, DUSt3R encoding, instance proposals) and then
// only query work per query.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/image.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/matching/proposals.h"
#include "freeloc/matching/sift.h"
#include "freeloc/nn/instance_segmenter.h"

namespace freeloc::pipeline {

struct PipelineOptions {
  std::string preset = "sift-essential";
  std::string matcher = "sift";           // sift | dust3r | dust3r+instances | precomputed:<SIFT|SG|LoFTR|…>
  std::string depth = "provided:sensor";  // provided:<suffix> | metric3d | none
  std::string solver = "essential";       // essential | pnp | procrustes
  std::string scale = "robust";           // robust | official (essential only)
  double threshold_px = -1;               // < 0: the solver's default
  // Networks. Paths left empty are looked up by their published file names in `models_dir`, then in the folders of
  // $FREELOC_MODELS (FindModels); Validate names what is still missing.
  std::string models_dir;
  std::string dust3r_model;    // official .pth or model.safetensors (+ config.json beside it)
  std::string seggpt_model;    // seggpt_vit_large.pth or HF model.safetensors
  std::string metric3d_model;  // metric_depth_vit_{small,large,giant2}_800k.pth or safetensors
  int dust3r_size = 512;       // load_images size
  std::string instance_mode = "mask";     // mask (I ⊙ Mask, the paper) | crop
  int min_instance_matches = 16;          // instances with fewer matches keep the global ones
  matching::ProposalOptions proposals;    // reference instances from the reference pointmap
  nn::InstanceSegmenterOptions segmenter;  // SegGPT propagation and its filters
  std::string device = "cpu";
  int threads = 0;  // 0 = library default

  bool UsesDust3r() const { return matcher == "dust3r" || matcher == "dust3r+instances"; }
  bool UsesSegGpt() const { return matcher == "dust3r+instances"; }
  bool UsesMetric3d() const { return depth == "metric3d"; }
  bool UsesProvidedDepth() const { return depth.rfind("provided:", 0) == 0; }
  void Validate() const;  // throws freeloc::Error naming the option (or the missing weights file)
  std::string Summary() const;
};

// Resolves a preset name into options (then overridable). Throws freeloc::Error naming the preset when unknown.
PipelineOptions ResolvePreset(const std::string& name);
std::vector<std::string> PresetNames();

// Fills the empty model paths that `options` needs from `models_dir` and $FREELOC_MODELS (models.h).
void FindModels(PipelineOptions* options);

struct QueryResult {
  std::string frame;
  bool ok = false;
  std::string status;  // "ok" or why not (too-few-matches, no-consensus, no-depth, scale-…, error: …)
  Rigid3d query_from_ref;
  double confidence = 0;  // essential + robust scale: confidence.h; official scale: its support; pnp/procrustes: inliers
  int matches = 0, inliers = 0;
  int global_matches = 0;                 // dust3r matchers: before the instance merge
  int instances = 0, instances_used = 0;  // reference instances tried / whose matches replaced global ones
  int scale_inliers = 0;                  // correspondences agreeing on the metric scale
  double predicted_translation_m = 0;     // essential + robust scale: the predicted error (confidence.h)
  double predicted_rotation_deg = 0;
  double depth_ms = 0, match_ms = 0, instance_ms = 0, solve_ms = 0;
};

// What the per-scene caches did (for logs and tests).
struct CacheStats {
  int reference_encodings = 0;  // DUSt3R encoder passes of reference-side inputs (global + masked instances)
  int reference_reuses = 0;     // … and the passes saved by reusing them
  int reference_instances = 0;  // instance proposals of the current reference
  int depth_estimates = 0;      // Metric3D passes (reference once per scene + one per query)
  double reference_ms = 0;      // time spent on the current reference's own work
};

class Relocalizer {
 public:
  // Validates `options` and loads the networks it needs (kept for the process). Throws freeloc::Error.
  explicit Relocalizer(const PipelineOptions& options);
  ~Relocalizer();
  Relocalizer(const Relocalizer&) = delete;
  Relocalizer& operator=(const Relocalizer&) = delete;

  // The reference frame; its work (Metric3D depth, instance proposals) runs here, once. `depth`: the provided depth
  // (may be empty; ignored unless the depth stage is provided:<suffix>).
  void SetReference(const Image& image, const Camera& camera, DepthMap depth = {});
  // One query against the current reference. `depth`: the provided query depth (as above); `precomputed`: the
  // correspondences (x_ref, y_ref, x_query, y_query) when the matcher is precomputed; `matches` (optional) receives
  // the correspondences the solver got (original pixels).
  QueryResult Relocalize(const Image& image, const Camera& camera, DepthMap depth = {},
                         const std::vector<Eigen::Vector4d>* precomputed = nullptr,
                         matching::Correspondences* matches = nullptr);
  const CacheStats& stats() const;
  const PipelineOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// One pair (a Relocalizer used once). `depth_ref`/`depth_query` may be empty.
QueryResult RelocalizePair(const Image& ref, const Image& query, const Camera& k_ref, const Camera& k_query,
                           const DepthMap& depth_ref, const DepthMap& depth_query, const PipelineOptions& options,
                           const std::vector<Eigen::Vector4d>* precomputed = nullptr,
                           matching::Correspondences* matches = nullptr);

// Loads (and keeps for the process) the networks `options` names, so that a missing or damaged weights file is
// one error before any work starts rather than a failure of every query. Throws freeloc::Error naming the file.
void LoadModels(const PipelineOptions& options);

// Every query of a map-free scene; the reference's image, depth, encodings and instances are computed once.
// `stats` (optional) receives the scene's cache counters.
std::vector<QueryResult> RelocalizeScene(const MapfreeScene& scene, const PipelineOptions& options,
                                         CacheStats* stats = nullptr);

}  // namespace freeloc::pipeline
