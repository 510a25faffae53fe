// The essential route (estimate_pose.h): 5-point LO-RANSAC on the correspondences, then the metric scale from both
// depths on its inliers; a pair without parallax answered by its rotation.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "freeloc/geometry/essential.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/rotation_only.h"
#include "freeloc/pose/routes.h"

namespace freeloc::pose::internal {

namespace {

// The evidence confidence.h predicts the pose error from (essential inliers, their Sampson residual, the scale).
PoseEvidence EssentialEvidence(const Correspondences& c, const geometry::RelativePoseResult& rel,
                               const geometry::ScaleResult& s, const Camera& k_ref, const Camera& k_query) {
  const Eigen::Matrix3d E =
      geometry::Skew(rel.query_from_ref.translation) * rel.query_from_ref.rotation.toRotationMatrix();
  double sampson = 0;
  size_t n = 0;
  for (size_t i = 0; i < c.size(); ++i)
    if (rel.inliers[i]) {
      sampson += geometry::SampsonSquared(E, k_ref.Unproject(c.ref[i].x(), c.ref[i].y()),
                                          k_query.Unproject(c.query[i].x(), c.query[i].y()));
      ++n;
    }
  const double focal = MeanFocal(k_ref, k_query);
  PoseEvidence ev =
      Evidence(static_cast<int>(c.size()), rel.status.num_inliers, focal * std::sqrt(sampson / std::max<size_t>(1, n)),
               focal, s.mean_distance_m, s.num_candidates, s.num_inliers, s.std_error_m);
  if (rel.status.competitors > 0) {
    // The runner-up at the same metric scale: its rotation and camera-centre distance from the answer.
    const Rigid3d& a = rel.query_from_ref;
    const Rigid3d& b = rel.runner_up;
    ev.rival_plausibility = rel.status.runner_up_plausibility;
    ev.rival_rotation_deg = RotationAngleDeg(a.rotation, b.rotation);
    ev.rival_translation_m =
        std::abs(s.scale) * (a.rotation.conjugate() * a.translation - b.rotation.conjugate() * b.translation).norm();
  }
  return ev;
}

// The metric scale of the essential model from both depths on its inliers: the pose made metric, or the scale's
// failure as the status.
void Scale(const Correspondences& c, const geometry::RelativePoseResult& rel, const Camera& k_ref,
           const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query, geometry::ScaleMethod method,
           PoseEstimate* r) {
  std::vector<Eigen::Vector2d> a, b;
  for (size_t i = 0; i < c.size(); ++i)
    if (rel.inliers[i]) {
      a.push_back(c.ref[i]);
      b.push_back(c.query[i]);
    }
  geometry::ScaleOptions so;
  so.method = method;
  const auto s = geometry::EstimateMetricScale(a, b, rel.query_from_ref, d_ref, d_query, k_ref, k_query, so);
  r->scale_inliers = s.num_inliers;
  if (!s.success()) {
    r->status =
        s.outcome == geometry::ScaleOutcome::kNoValidDepth ? Status::kScaleNoValidDepth : Status::kScaleNoConsensus;
    return;
  }
  r->query_from_ref.translation *= s.scale;
  r->confidence = s.confidence;  // official: the baseline's support count
  if (method != geometry::ScaleMethod::kOfficial) r->SetConfidence(EssentialEvidence(c, rel, s, k_ref, k_query));
  r->status = Status::kOk;
}

// No parallax — the same photo twice, a camera turned in place: every translation direction fits, so the essential
// search finds no model (or, without depth, an arbitrary one). A rotation explaining at least half of the matches
// (and 15) is then the answer: with both depths a metric pose, its translation from them
// (geometry::TranslationFromDepths); without, the status says why (the translation cannot be seen).
void NoParallax(const Correspondences& c, const geometry::RotationOnlyResult& rot, const Camera& k_ref,
                const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query, PoseEstimate* r) {
  const double angle = Eigen::AngleAxisd(rot.query_from_ref).angle() * 180 / M_PI;
  r->route = Route::kRotation;
  r->inliers = rot.num_inliers;
  r->inlier_mask = rot.inliers;
  r->query_from_ref = Rigid3d(rot.query_from_ref, Eigen::Vector3d::Zero());
  std::ostringstream what;
  what << "no parallax: " << rot.num_inliers << " of " << c.size() << " matches fit a rotation of " << std::fixed
       << std::setprecision(2) << angle << " degrees alone (the same viewpoint, or a camera turned in place";
  if (d_ref.empty() || d_query.empty()) {
    r->status = Status::kDegenerate;
    r->message = what.str() + "); without depth maps the translation cannot be seen: give both depth maps";
    return;
  }
  const geometry::DepthTranslation dt =
      geometry::TranslationFromDepths(c.ref, c.query, k_ref, k_query, rot, d_ref, d_query);
  if (!dt.found) {
    r->status = Status::kScaleNoValidDepth;
    r->message = what.str() + "); too few of its matches have depth in both maps for the translation";
    return;
  }
  r->query_from_ref.translation = dt.t;
  r->scale_inliers = dt.agree;
  r->SetConfidence(Evidence(static_cast<int>(c.size()), rot.num_inliers, rot.residual_px, MeanFocal(k_ref, k_query),
                            dt.mean_depth_m, dt.samples, dt.agree, dt.std_error_m));
  r->status = Status::kOk;
  r->message = what.str() + "): the translation is from the depth maps";
}

// A rotation alone explains the pair when it fits at least half of the matches (and 15).
bool RotationExplains(const geometry::RotationOnlyResult& rot, size_t matches) {
  return rot.found && rot.num_inliers >= 15 && 2 * static_cast<size_t>(rot.num_inliers) >= matches;
}

}  // namespace

PoseEstimate EssentialRoute(const SolveOptions& o, int sprt_min_matches, const Correspondences& c, const Camera& k_ref,
                            const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query) {
  PoseEstimate r;
  r.matches = static_cast<int>(c.size());
  r.route = Route::kEssential;
  CheckDepthCovers(c.ref, d_ref, "reference");
  CheckDepthCovers(c.query, d_query, "query");
  if (c.size() < 5) {
    r.status = Status::kTooFewMatches;
    return r;
  }
  geometry::RelativePoseOptions ro;
  ro.threshold_px = o.ThresholdPx(SolverKind::kEssential);
  ro.ransac.sprt_min_data = sprt_min_matches;
  const auto rel = geometry::EstimateRelativePose(c.ref, c.query, k_ref, k_query, ro, SampleDepths(c, d_ref, d_query));
  r.inliers = rel.status.num_inliers;
  r.inlier_mask = rel.inliers;
  r.status = StatusOf(rel.status.outcome);
  const bool weak = r.weak();
  if (!rel.status.success() && !weak) {
    const geometry::RotationOnlyResult rot =
        geometry::EstimateRotationOnly(c.ref, c.query, k_ref, k_query, ro.threshold_px);
    if (RotationExplains(rot, c.size())) NoParallax(c, rot, k_ref, k_query, d_ref, d_query, &r);
    return r;
  }
  r.query_from_ref = rel.query_from_ref;
  r.confidence = rel.status.num_inliers;
  if (d_ref.empty() || d_query.empty()) {
    r.status = Status::kOkUnitTranslation;  // weak or not: mapped below
    // Without depth a camera turned in place fits any translation direction: the model found is arbitrary. A
    // rotation that explains the essential inliers as well (its 2D residual within 2.2 × their 1D Sampson error —
    // 1.4–1.8 for noise alone, 3 and more with the parallax of a 1 cm baseline at 3 m) says so instead.
    const geometry::RotationOnlyResult rot =
        geometry::EstimateRotationOnly(c.ref, c.query, k_ref, k_query, ro.threshold_px);
    const double sampson_px = EssentialEvidence(c, rel, geometry::ScaleResult(), k_ref, k_query).residual_px;
    if (!weak && rot.found && rot.num_inliers >= 0.9 * rel.status.num_inliers &&
        rot.residual_px <= 2.2 * std::max(sampson_px, 0.05)) {
      NoParallax(c, rot, k_ref, k_query, d_ref, d_query, &r);
      r.confidence = 0;
      return r;
    }
  } else {
    Scale(c, rel, k_ref, k_query, d_ref, d_query, o.scale, &r);
  }
  // Weak support: an answer ranked below every supported one (its scale failing leaves no pose at all).
  if (weak && r.ok()) {
    r.status = Status::kWeakSupport;
    r.confidence = WeakSupportConfidence(r.confidence);
  }
  return r;
}

}  // namespace freeloc::pose::internal
