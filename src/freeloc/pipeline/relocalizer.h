// The relocalization pipeline (DESIGN §1–3). Stages, each chosen by a plain option:
//   matcher  — sift (the benchmark's extractor), dust3r (global reciprocal 3D matches of DUSt3R pointmaps),
//              dust3r+instances (the paper: reference instances proposed on the reference's own pointmap, propagated
//              into the query by SegGPT, DUSt3R re-run per masked instance pair, merged by Eq. 3), precomputed:<name>;
//   depth    — provided:<suffix> (the scene's depth PNGs), metric3d (Metric3D v2 on each image), none;
//   solver   — essential (+ metric scale from depth), pnp, procrustes.
// A `Relocalizer` runs the stages (stages.h: Matcher, DepthEstimator, PoseSolver — built in, or your own): the
// reference frame's work once (its depth, SIFT features or DUSt3R encoding, instance proposals), then only query
// work per query.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/image.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/matching/sift.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/stages.h"

namespace freeloc::pipeline {

// Resolves a preset name into options (then overridable). Throws freeloc::Error naming the preset when unknown.
PipelineOptions ResolvePreset(const std::string& name);
std::vector<std::string> PresetNames();

// Fills the empty model paths that `options` needs from `models_dir` and $FREELOC_MODELS (models.h).
void FindModels(PipelineOptions* options);

class Relocalizer {
 public:
  // Validates `options` and loads the networks it needs (kept for the process). Throws freeloc::Error.
  explicit Relocalizer(const PipelineOptions& options);
  // With stages of your own (stages.h); `options` is only reported back by options().
  Relocalizer(const PipelineOptions& options, std::unique_ptr<Matcher> matcher, std::unique_ptr<DepthEstimator> depth,
              std::unique_ptr<PoseSolver> solver);
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
// `stats` (optional) receives the scene's cache counters; `on_query` (optional) is called after each query.
std::vector<QueryResult> RelocalizeScene(const MapfreeScene& scene, const PipelineOptions& options,
                                         CacheStats* stats = nullptr,
                                         const std::function<void(const QueryResult&)>& on_query = nullptr);

}  // namespace freeloc::pipeline
