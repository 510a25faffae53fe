// The pipeline's stages as interfaces (docs/architecture.md §1–3), so a library user can plug in their own: a Matcher
// gives correspondences between the reference and a query, a DepthEstimator the metric depth of a frame, a PoseSolver
// the pose from both. The Matcher does its reference-frame share once in SetReference (the Relocalizer runs the
// DepthEstimator on the reference once); the rest runs per query. The built-in
// implementations are made from PipelineOptions (MakeMatcher, MakeDepthEstimator, MakePoseSolver) — the same
// objects behind `freeloc run`, `relocalize`, `pose`, `match` and the Python bindings. Light header.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/image.h"
#include "freeloc/inputs/intrinsics.h"
#include "freeloc/matching/correspondences.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/query_result.h"

namespace freeloc::pipeline {

// What a frame brings besides its image and camera; everything optional.
struct FrameInputs {
  DepthMap
      depth;  // provided depth (used when the depth stage is provided:<suffix>), in the image's displayed orientation
  // Instance label image at the frame's resolution (0 = none, k = instance k): the reference's instances for
  // dust3r+instances (instead of proposals), and the query's with instance_source given.
  const std::vector<uint16_t>* instance_labels = nullptr;
  // Query only, matcher precomputed: the correspondences (x_ref, y_ref, x_query, y_query) in original pixels.
  const std::vector<Eigen::Vector4d>* correspondences = nullptr;
  // Where the camera handed in with the frame came from (reported in the record). kPointmap: none was
  // given (the camera handed in is ignored); the Relocalizer estimates the focal from the frame's pointmap
  // (DUSt3R/MASt3R matchers) or refuses.
  IntrinsicsSource intrinsics_source = IntrinsicsSource::kGiven;
  int orientation = 0;  // the EXIF orientation the decoder applied (reported only)
};

// sift (the benchmark's extractor; reference features once) | dust3r (global reciprocal 3D matches; reference
// encoding once) | mast3r (MASt3R descriptors, fast reciprocal NN; reference encoding once) | dust3r+instances /
// mast3r+instances (+ reference instances — given or proposed — propagated by SegGPT or given
// for the query, per-instance DUSt3R, Eq. 3 merge) | precomputed (the rows handed in).
class Matcher {
 public:
  virtual ~Matcher() = default;
  // `instance_labels`: the reference's label image, or nullptr.
  virtual void SetReference(const Image& image, const Camera& camera, const std::vector<uint16_t>* instance_labels) = 0;
  // Correspondences in original pixels; fills r->global_matches, instances, instances_used, match_ms, instance_ms.
  virtual matching::Correspondences Match(const Image& query, const Camera& camera, const FrameInputs& inputs,
                                          QueryResult* r) = 0;
  virtual void AddStats(CacheStats* /*stats*/) const {}
  // The metric depth the matcher's own network gave for the last Match (MASt3R's pointmaps: the reference's z from
  // the (reference, query) pass; with `with_query` also the query's, from a second decoder pass with the query as
  // view 1), each at its frame's resolution (0 = invalid). False when the matcher has none (depth mast3r needs it).
  virtual bool PairDepth(bool /*with_query*/, DepthMap* /*ref*/, DepthMap* /*query*/) { return false; }
  // The focal length (the frame's original pixels, principal point at the image centre) the matcher's network gives
  // from the frame's own pointmap (geometry/focal_from_pointmap.h): the reference's from its (reference, reference)
  // pass after SetReference, the query's from the last Match's swapped pass. 0 when the matcher has no pointmaps or
  // they give no focal.
  virtual double ReferenceFocal() { return 0; }
  virtual double QueryFocal() { return 0; }
  // The network time of the query's own-pointmap pass since the last Match (run on demand by QueryFocal or
  // PairDepth; 0 until then).
  virtual double own_pass_ms() const { return 0; }
};

// metric3d (Metric3D v2 on the image) | provided (the depth handed in) | none (always empty). Depth `mast3r` comes
// from the matcher's pair instead (Matcher::PairDepth).
class DepthEstimator {
 public:
  virtual ~DepthEstimator() = default;
  // `provided`: the frame's provided depth, possibly empty. Returns the depth to use (empty: none).
  virtual DepthMap Depth(const Image& image, const Camera& camera, DepthMap provided) = 0;
  virtual bool needs_provided() const { return false; }  // a frame without provided depth cannot be solved
  virtual void AddStats(CacheStats* /*stats*/) const {}
};

// essential (+ metric scale when both depths exist) | hybrid (depth-aware, essential fallback) | pnp (reference
// depth) | procrustes (both depths). Fills
// r->status, query_from_ref, confidence, matches, inliers, scale_inliers, predicted errors, solve_ms.
class PoseSolver {
 public:
  virtual ~PoseSolver() = default;
  virtual void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query,
                     const DepthMap& d_ref, const DepthMap& d_query, QueryResult* r) const = 0;
};

// The built-in stages `options` names (options validated; networks loaded and kept for the process).
std::unique_ptr<Matcher> MakeMatcher(const PipelineOptions& options);
std::unique_ptr<DepthEstimator> MakeDepthEstimator(const PipelineOptions& options);
std::unique_ptr<PoseSolver> MakePoseSolver(const PipelineOptions& options);

// The choice as the Relocalizer takes it: the camera to hand in, and the frame's source and orientation.
inline Camera ApplyIntrinsics(const inputs::IntrinsicsChoice& c, FrameInputs* in) {
  in->intrinsics_source = c.source;
  in->orientation = c.orientation;
  return c.camera;
}

}  // namespace freeloc::pipeline
