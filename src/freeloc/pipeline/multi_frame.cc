// The Multi Frame track's window (multi_frame.h): every frame through the Relocalizer, the relations to the
// evaluated frame, then the fusion of pose/window_fusion.h.
#include "freeloc/pipeline/multi_frame.h"

#include <algorithm>

#include "freeloc/core/error.h"
#include "freeloc/inputs/working_frame.h"
#include "freeloc/pipeline/relocalizer.h"

namespace freeloc::pipeline {

namespace {

// The anchored |t| of a metric answer as each of its two depth maps alone gives it, from its inliers.
geometry::ScaleAnchors AnchorInliers(const matching::Correspondences& c, const QueryResult& r,
                                     const DepthMap& depth_ref, const DepthMap& depth_query, const Camera& ref,
                                     const Camera& query) {
  if (r.inlier_mask.size() != c.size()) return {};
  std::vector<Eigen::Vector2d> pr, pq;
  for (size_t i = 0; i < c.size(); ++i)
    if (r.inlier_mask[i]) pr.push_back(c.ref[i]), pq.push_back(c.query[i]);
  // The depth maps are at the working resolution (working_frame.h): points and cameras into their pixels.
  const auto to_depth = [](const DepthMap& d, const Camera& k, std::vector<Eigen::Vector2d>* p) {
    if (k.width <= 0 || k.height <= 0 || d.empty() || (d.width == k.width && d.height == k.height)) return k;
    const inputs::PixelScale s{static_cast<double>(k.width) / d.width, static_cast<double>(k.height) / d.height};
    for (auto& x : *p) x = s.ToWorking(x);
    return k.Scaled(d.width, d.height);
  };
  const Camera kr = to_depth(depth_ref, ref, &pr), kq = to_depth(depth_query, query, &pq);
  return geometry::AnchorScales(pr, pq, r.query_from_ref, depth_ref, depth_query, kr, kq);
}

// The evaluated frame's relations to the other frames of its window, from the images: the evaluated frame as the
// reference of a local relocalizer (SIFT where the run's matches are precomputed: those exist only against the
// scene's reference). Returns the time it took.
double ImageRelations(const PipelineOptions& o, const std::vector<WindowFrame>& frames,
                      std::vector<pose::FrameEvidence>* ev) {
  const size_t qi = frames.size() - 1;
  PipelineOptions lo = o;
  lo.track = io::Track::kSingleFrame;
  if (lo.UsesPrecomputed()) lo.matcher = MatcherSpec{};
  Relocalizer local(lo, Relocalizer::kOptionsValidated);  // the run validated them
  FrameInputs qin;
  qin.depth = frames[qi].inputs.depth;
  qin.intrinsics_source = frames[qi].inputs.intrinsics_source;
  local.SetReference(frames[qi].image, frames[qi].camera, std::move(qin));
  double ms = local.stats().reference_ms;
  for (size_t k = 0; k < qi; ++k) {
    if (frames[k].image.empty()) continue;
    FrameInputs in;
    in.depth = frames[k].inputs.depth;
    in.intrinsics_source = frames[k].inputs.intrinsics_source;
    matching::Correspondences rc;
    const QueryResult rel = local.Relocalize(frames[k].image, frames[k].camera, std::move(in), &rc);
    ms += rel.timings.depth_ms + rel.timings.match_ms + rel.timings.solve_ms;
    if (!rel.ok()) continue;
    pose::FrameEvidence& e = (*ev)[k];
    if (rel.metric()) {
      const Camera kq = local.reference_intrinsics().known() ? local.reference_intrinsics().camera : frames[qi].camera;
      const Camera kj = rel.query_intrinsics.known() ? rel.query_intrinsics.camera : frames[k].camera;
      e.relation_anchors = AnchorInliers(rc, rel, local.reference_depth(), local.last_query_depth(), kq, kj);
    }
    e.has_image_relation = true;
    e.image_relation_metric = rel.metric();
    e.image_relation = rel.query_from_ref;
    e.image_relation_rot_sigma_deg = rel.predicted_rotation_deg;
    e.image_relation_position_sigma_m = rel.predicted_translation_m;
  }
  return ms;
}

}  // namespace

QueryResult RelocalizeWindow(Relocalizer& reloc, std::vector<WindowFrame> frames, matching::Correspondences* matches) {
  FREELOC_CHECK(!frames.empty() && frames.size() <= 9, "a window holds 1 to 9 frames, got " << frames.size());
  const PipelineOptions& o = reloc.options();
  const size_t n = frames.size(), qi = n - 1;
  std::vector<QueryResult> to_ref(n);  // each frame against the reference, as a query
  std::vector<pose::FrameEvidence> ev(n);
  for (size_t k = 0; k < n; ++k) {
    WindowFrame& f = frames[k];
    ev[k].name = f.name;
    ev[k].has_device = f.has_device && o.multi_frame.device_poses != DevicePoseUse::kIgnore;
    ev[k].device = f.device_from_query;
    if (f.image.empty()) {  // the caller could not read it: it only loses its vote
      to_ref[k].status = QueryStatus::kError;
      continue;
    }
    matching::Correspondences c;
    to_ref[k] = reloc.Relocalize(f.image, f.camera, f.inputs, &c);
    to_ref[k].frame = f.name;
    const QueryResult& r = to_ref[k];
    if (r.metric()) {
      // The two depth maps' anchorings of this frame's |t| apart (the fusion weighs them separately).
      const Camera kr = reloc.reference_intrinsics().known() ? reloc.reference_intrinsics().camera : f.camera;
      const Camera kq = r.query_intrinsics.known() ? r.query_intrinsics.camera : f.camera;
      ev[k].anchors = AnchorInliers(c, r, reloc.reference_depth(), reloc.last_query_depth(), kr, kq);
    }
    ev[k].to_ref = r;
    if (k == qi && matches) *matches = std::move(c);
  }
  if (n == 1) return to_ref[0];
  const bool need_images =
      o.multi_frame.device_poses != DevicePoseUse::kUse ||
      std::any_of(ev.begin(), ev.end() - 1, [](const pose::FrameEvidence& e) { return !e.has_device; });
  const double relation_ms = need_images && !frames[qi].image.empty() ? ImageRelations(o, frames, &ev) : 0.0;
  const pose::FusedWindow fused = pose::FuseWindow(ev, o.multi_frame.device_poses);
  QueryResult r = to_ref[qi];
  r.frame = frames[qi].name;
  static_cast<pose::PoseEstimate&>(r) = fused;
  r.window = fused.window;
  if (r.ok()) r.submitted_unsolved = false;
  // The cost of the whole window: every frame's stages, the relations counted as solving.
  r.timings.depth_ms = r.timings.match_ms = r.timings.instance_ms = r.timings.solve_ms = 0;
  for (const QueryResult& e : to_ref) {
    r.timings.depth_ms += e.timings.depth_ms;
    r.timings.match_ms += e.timings.match_ms;
    r.timings.instance_ms += e.timings.instance_ms;
    r.timings.solve_ms += e.timings.solve_ms;
  }
  r.timings.solve_ms += relation_ms;
  AnswerUnsolved(o, &r);  // (a solved answer only checked for finite values)
  return r;
}

}  // namespace freeloc::pipeline
