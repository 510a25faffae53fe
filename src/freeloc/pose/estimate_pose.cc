#include "freeloc/pose/estimate_pose.h"

#include <algorithm>

#include "freeloc/core/error.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/pose/routes.h"

namespace freeloc::pose {

PoseEstimate EstimatePose(SolverKind solver, const SolveOptions& o, const Correspondences& c, const Camera& k_ref,
                          const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query) {
  switch (solver) {
    case SolverKind::kEssential:
      return internal::EssentialRoute(o, o.sprt_min_matches, c, k_ref, k_query, d_ref, d_query);
    case SolverKind::kHybrid: return internal::HybridRoute(o, c, k_ref, k_query, d_ref, d_query);
    case SolverKind::kPnp:
    case SolverKind::kProcrustes:
      return internal::AbsoluteRoute(solver == SolverKind::kPnp, o, c, k_ref, k_query, d_ref, d_query);
  }
  FREELOC_THROW("solver: " << ToString(solver) << " has no implementation");
}

namespace internal {

Status StatusOf(geometry::EstimatorOutcome outcome) {
  switch (outcome) {
    case geometry::EstimatorOutcome::kOk: return Status::kOk;
    case geometry::EstimatorOutcome::kWeakSupport: return Status::kWeakSupport;
    case geometry::EstimatorOutcome::kTooFewMatches: return Status::kTooFewMatches;
    case geometry::EstimatorOutcome::kNoConsensus: return Status::kNoConsensus;
    case geometry::EstimatorOutcome::kDegenerate: return Status::kDegenerate;
  }
  return Status::kError;
}

// A depth map of another resolution (a 320×240 map for 640×480 matches) would silently give a wrong metric scale.
// Points a little off the map (noise at the border) are fine; more than 20 % of them beyond a 5 % margin is an error.
void CheckDepthCovers(const std::vector<Eigen::Vector2d>& px, const DepthMap& d, const char* frame) {
  if (d.empty() || px.empty()) return;
  const double mx = 0.05 * d.width + 2, my = 0.05 * d.height + 2;
  size_t outside = 0;
  Eigen::Vector2d far = Eigen::Vector2d::Zero();
  for (const auto& p : px)
    if (p.x() < -mx || p.y() < -my || p.x() > d.width + mx || p.y() > d.height + my) {
      ++outside;
      far = far.cwiseMax(p);
    }
  FREELOC_CHECK(outside * 5 <= px.size(), frame << " depth: the map is " << d.width << "x" << d.height << " but "
                                                << outside << " of " << px.size() << " " << frame
                                                << " correspondences lie outside it (up to " << far.x() << ", "
                                                << far.y() << "); give the depth map at its image's resolution");
}

geometry::DepthSamples SampleDepths(const Correspondences& c, const DepthMap& d_ref, const DepthMap& d_query) {
  geometry::DepthSamples d;
  if (!d_ref.empty()) {
    d.ref.resize(c.size());
    for (size_t i = 0; i < c.size(); ++i) d.ref[i] = geometry::BilinearDepth(d_ref, c.ref[i].x(), c.ref[i].y());
  }
  if (!d_query.empty()) {
    d.query.resize(c.size());
    for (size_t i = 0; i < c.size(); ++i) d.query[i] = geometry::BilinearDepth(d_query, c.query[i].x(), c.query[i].y());
  }
  return d;
}

double MeanFocal(const Camera& k_ref, const Camera& k_query) {
  return 0.25 * (k_ref.fx + k_ref.fy + k_query.fx + k_query.fy);
}

PoseEvidence Evidence(int matches, int inliers, double residual_px, double focal_px, double mean_depth_m,
                      int scale_candidates, int scale_inliers, double scale_std_error_m) {
  PoseEvidence e;
  e.matches = matches;
  e.inliers = inliers;
  e.residual_px = residual_px;
  e.focal_px = focal_px;
  e.mean_depth_m = mean_depth_m;
  e.scale_candidates = scale_candidates;
  e.scale_inliers = scale_inliers;
  e.scale_std_error_m = scale_std_error_m;
  return e;
}

}  // namespace internal

std::string PoseEstimate::RouteText() const {
  if (!window_fused) return ToString(route);
  return route == Route::kNone ? "window" : ToString(route) + "+window";
}

bool PoseEstimate::SetRouteText(const std::string& text) {
  static const std::string kWindow = "+window";
  window_fused = text == "window" || (text.size() > kWindow.size() &&
                                      text.compare(text.size() - kWindow.size(), kWindow.size(), kWindow) == 0);
  if (text == "window") {
    route = Route::kNone;
    return true;
  }
  return TryParseEnum(window_fused ? text.substr(0, text.size() - kWindow.size()) : text, &route);
}

void PoseEstimate::SetConfidence(const PoseEvidence& e) {
  evidence = e;
  const PredictedError pe = PredictPoseError(e);
  predicted_translation_m = pe.translation_m;
  predicted_rotation_deg = pe.rotation_deg;
  confidence = ConfidenceFromPredictedError(pe);
}

}  // namespace freeloc::pose
