// The relocalization pipeline (docs/architecture.md §1–3). A `Relocalizer` runs the stages (stages.h: Matcher,
// DepthEstimator, PoseSolver — built in from PipelineOptions, or your own): the reference frame's work once (its depth,
// SIFT features or DUSt3R encoding, instance proposals), then only query work per query. Every entry point — `freeloc
// relocalize`, `pose`, `match`, `run` (run_controller.h) and the Python bindings — goes through it.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/image.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/matching/correspondences.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/query_result.h"
#include "freeloc/pipeline/stages.h"

namespace freeloc::pipeline {

// Fills the empty model paths that `options` needs from `models_dir` and $FREELOC_MODELS (models.h).
void FindModels(PipelineOptions* options);

class Relocalizer {
 public:
  // Validates `options` and loads the networks it needs (kept for the process). Throws freeloc::Error.
  explicit Relocalizer(const PipelineOptions& options);
  // The same for options an entry point has validated already (ExecuteRun, the service): one validation per run.
  enum OptionsValidated { kOptionsValidated };
  Relocalizer(const PipelineOptions& options, OptionsValidated);
  // With stages of your own (stages.h); `options` is only reported back by options().
  Relocalizer(const PipelineOptions& options, std::unique_ptr<Matcher> matcher, std::unique_ptr<DepthEstimator> depth,
              std::unique_ptr<PoseSolver> solver);
  ~Relocalizer();
  Relocalizer(const Relocalizer&) = delete;
  Relocalizer& operator=(const Relocalizer&) = delete;

  // The reference frame; its work (depth, features or encoding, instance proposals) runs here, once.
  void SetReference(const Image& image, const Camera& camera, FrameInputs inputs);
  void SetReference(const Image& image, const Camera& camera, DepthMap depth = {}) {
    FrameInputs in;
    in.depth = std::move(depth);
    SetReference(image, camera, std::move(in));
  }
  // One query against the current reference. `matches` (optional) receives the correspondences the solver got
  // (original pixels). Estimator failures are statuses (answered with the prior pose under always_answer);
  // exceptions (bad input, network errors) propagate.
  QueryResult Relocalize(const Image& image, const Camera& camera, FrameInputs inputs,
                         matching::Correspondences* matches = nullptr);
  QueryResult Relocalize(const Image& image, const Camera& camera, DepthMap depth = {},
                         const std::vector<Eigen::Vector4d>* precomputed = nullptr,
                         matching::Correspondences* matches = nullptr) {
    FrameInputs in;
    in.depth = std::move(depth);
    in.correspondences = precomputed;
    return Relocalize(image, camera, std::move(in), matches);
  }
  // Only the matching stage (what `freeloc match` runs): the correspondences of the query against the reference.
  matching::Correspondences Match(const Image& image, const Camera& camera, const FrameInputs& inputs, QueryResult* r);

  const CacheStats& stats() const;
  const PipelineOptions& options() const;
  // The depth the solver used for the current reference and for the last query (empty: none) — for reports.
  const DepthMap& reference_depth() const;
  // The current reference's intrinsics as resolved (the pointmap's camera when it gave them) and their source.
  const FrameIntrinsics& reference_intrinsics() const;
  const DepthMap& last_query_depth() const;

 private:
  QueryResult Solve(const Image& image, const Camera& camera, FrameInputs inputs, matching::Correspondences* matches);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The always-answer rule (PipelineOptions::always_answer): an unsolved `r` is submitted (submitted_unsolved = true,
// status kept) — a weak-support result with its own pose and low confidence, any other with the prior pose (identity)
// and confidence 0. Solved results and always_answer 0 are left as they are. A result whose pose or confidence is not
// finite becomes status error (its message says so) first: a submission never receives it.
void AnswerUnsolved(const PipelineOptions& options, QueryResult* r);

// One pair (a Relocalizer used once). `depth_ref`/`depth_query` may be empty.
QueryResult RelocalizePair(const Image& ref, const Image& query, const Camera& k_ref, const Camera& k_query,
                           const DepthMap& depth_ref, const DepthMap& depth_query, const PipelineOptions& options,
                           const std::vector<Eigen::Vector4d>* precomputed = nullptr,
                           matching::Correspondences* matches = nullptr);

// A pose from correspondences handed in (`freeloc pose`, Python's estimate_relative_pose) by `options`' solver: the
// depth maps (either may be empty) and the intrinsics through the input checks (input_checks.h; a depth map's size
// stands for its image's), then the solver and the always-answer rule.
QueryResult SolveCorrespondences(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query,
                                 DepthMap d_ref, DepthMap d_query, const PipelineOptions& options);

// Loads (and keeps for the process) the networks `options` names, so that a missing or damaged weights file is
// one error before any work starts rather than a failure of every query. Throws freeloc::Error naming the file.
void LoadModels(const PipelineOptions& options);

}  // namespace freeloc::pipeline
