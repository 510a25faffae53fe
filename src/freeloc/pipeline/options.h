// The pipeline's plain types: the options (stages, networks, presets resolve into them), a query's result, and the
// per-scene cache counters. Light header.
#pragma once

#include <string>

#include "freeloc/core/rigid3d.h"
#include "freeloc/matching/proposals.h"
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

}  // namespace freeloc::pipeline
