// The hybrid route (estimate_pose.h): the depth-aware hybrid estimator (geometry/hybrid_pose.h) with the essential
// route as its guard and fallback. Both run; the hybrid model is taken unless it explains clearly fewer
// correspondences epipolarly than the 5-point model does (a depth map that pulls the pose away from what the matches
// say), or fails. Its translation is in reference-depth units; when the query depth agrees on the scale within a
// factor 2, the two anchorings are combined by their geometric mean (t / √s), else the reference's is kept.
//
// The guard searches every set with the dense-set rule (sequential test + give-up, ransac.h), sparse ones included:
// a consensus holding less than its minimum share (a fifth) is the hybrid search's to find — at least a tenth of its
// 10 000 samples are 3-point depth samples, which find a depth-consistent consensus of 15 % with ≥ 96 % — so the
// guard no longer spends the plain search's 100 000 five-point samples (and its weak-support control as many again)
// on a few hundred matches with no consensus. What it gives up: a consensus under a fifth that the depths
// contradict, and some depth-consistent ones of 10–15 % (docs/geometry.md "Sparse sets").
// sprt_min_matches = 0 still means the plain search everywhere.
#include <cmath>
#include <future>
#include <thread>

#include "freeloc/geometry/hybrid_pose.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/pose/routes.h"

namespace freeloc::pose::internal {

namespace {

int GuardSprtMinMatches(const SolveOptions& o) { return o.sprt_min_matches > 0 ? 1 : 0; }

// The hybrid model as the answer: its pose (the two anchorings combined when they agree) and the confidence model
// of every solver (confidence.h) — the scale's standard error from the depth inliers' scatter, and the two
// anchorings' disagreement (half of it left after the geometric mean).
PoseEstimate HybridAnswer(const geometry::HybridPoseResult& h, const Correspondences& c, const Camera& k_ref,
                          const Camera& k_query) {
  PoseEstimate r;
  r.matches = static_cast<int>(c.size());
  r.inliers = h.status.num_inliers;
  r.inlier_mask = h.inliers;
  r.scale_inliers = h.depth_inliers;
  const double log_s = std::log(h.model.scale);
  const bool both = std::abs(log_s) <= std::log(2.0);
  const Eigen::Vector3d t = both ? Eigen::Vector3d(h.model.t / std::sqrt(h.model.scale)) : h.model.t;
  r.query_from_ref = Rigid3d(Eigen::Quaterniond(h.model.R).normalized(), t);
  r.status = Status::kOk;
  r.route = both ? Route::kHybrid : Route::kHybridReferenceDepth;
  const double anchor = both ? 0.5 * std::abs(log_s) : std::abs(log_s);
  const double scale_se = t.norm() * std::sqrt(h.scale_std_error * h.scale_std_error + anchor * anchor +
                                               geometry::kCommonDepthScaleError * geometry::kCommonDepthScaleError);
  r.SetConfidence(Evidence(r.matches, h.status.num_inliers, h.residual_px, MeanFocal(k_ref, k_query), h.mean_depth,
                           h.depth_candidates, h.depth_inliers, scale_se));
  return r;
}

}  // namespace

PoseEstimate HybridRoute(const SolveOptions& o, const Correspondences& c, const Camera& k_ref, const Camera& k_query,
                         const DepthMap& d_ref, const DepthMap& d_query) {
  const int guard_sprt = GuardSprtMinMatches(o);
  if (d_ref.empty() || d_query.empty() || c.size() < 5) {  // no depth model to use: the essential route
    PoseEstimate r = EssentialRoute(o, guard_sprt, c, k_ref, k_query, d_ref, d_query);
    r.route = Route::kEssential;
    return r;
  }
  geometry::HybridPoseOptions ho;
  ho.threshold_px = o.ThresholdPx(SolverKind::kHybrid);
  ho.reprojection_px = o.reprojection_px;
  ho.shifts = o.depth_shifts != 0;
  ho.ransac.sprt_min_data = o.sprt_min_matches;
  // The two searches are independent: the essential route on another core while the hybrid one runs here.
  PoseEstimate ess;
  auto essential = std::async(std::thread::hardware_concurrency() > 1 ? std::launch::async : std::launch::deferred,
                              [&] { ess = EssentialRoute(o, guard_sprt, c, k_ref, k_query, d_ref, d_query); });
  geometry::HybridPoseResult h;
  try {
    const geometry::DepthSamples z = SampleDepths(c, d_ref, d_query);
    h = geometry::EstimateHybridPose(c.ref, c.query, z.ref, z.query, k_ref, k_query, ho);
  } catch (...) {
    essential.get();  // the essential route's error first, as when it ran first
    throw;
  }
  essential.get();
  if (!h.status.success() || h.status.num_inliers < 0.8 * ess.inliers) {
    ess.route = Route::kHybridFellBack;
    return ess;
  }
  return HybridAnswer(h, c, k_ref, k_query);
}

}  // namespace freeloc::pose::internal
