// The absolute routes (estimate_pose.h): PnP on the reference depth (the threshold: reprojection inliers in the
// query) or Procrustes on both depths (geometry/absolute_pose.h).
#include <cmath>

#include "freeloc/geometry/absolute_pose.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/pose/routes.h"

namespace freeloc::pose::internal {

namespace {

// The confidence model of every solver (confidence.h) from the inliers' residuals: PnP's reprojection error in the
// query, Procrustes' 3D distance seen from the query (as an angle); the depth's common scale error as prior.
void AbsoluteConfidence(bool pnp, const Correspondences& c, const Camera& k_ref, const Camera& k_query,
                        const DepthMap& d_ref, const DepthMap& d_query, PoseEstimate* r) {
  const Rigid3d& T = r->query_from_ref;
  double sq = 0, depth = 0;
  int n = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    if (!r->inlier_mask[i]) continue;
    const double zr = geometry::BilinearDepth(d_ref, c.ref[i].x(), c.ref[i].y());
    if (!(zr > 0)) continue;
    const Eigen::Vector3d Y = T * (zr * k_ref.Unproject(c.ref[i].x(), c.ref[i].y()));
    if (!(Y.z() > 0)) continue;
    if (pnp) {
      sq += (k_query.Project(Y) - c.query[i]).squaredNorm();
    } else {
      const double zq = geometry::BilinearDepth(d_query, c.query[i].x(), c.query[i].y());
      if (!(zq > 0)) continue;
      const Eigen::Vector3d Q = zq * k_query.Unproject(c.query[i].x(), c.query[i].y());
      sq += (Q - Y).squaredNorm() / (Y.z() * Y.z()) * k_query.fx * k_query.fy;  // metres → pixels at that depth
    }
    depth += zr;
    ++n;
  }
  if (n == 0) return;
  r->SetConfidence(Evidence(static_cast<int>(c.size()), r->inliers, std::sqrt(sq / n), 0.5 * (k_query.fx + k_query.fy),
                            depth / n, 0, 0, geometry::kCommonDepthScaleError * T.translation.norm()));
}

}  // namespace

PoseEstimate AbsoluteRoute(bool pnp, const SolveOptions& o, const Correspondences& c, const Camera& k_ref,
                           const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query) {
  PoseEstimate r;
  r.matches = static_cast<int>(c.size());
  r.route = pnp ? Route::kPnp : Route::kProcrustes;
  CheckDepthCovers(c.ref, d_ref, "reference");
  if (!pnp) CheckDepthCovers(c.query, d_query, "query");
  geometry::MetricPoseResult m;
  if (pnp) {
    geometry::PnPOptions po;
    po.threshold_px = o.ThresholdPx(SolverKind::kPnp);
    po.ransac.sprt_min_data = o.sprt_min_matches;
    m = geometry::EstimatePnP(c.ref, c.query, d_ref, k_ref, k_query, po);
  } else {
    geometry::ProcrustesOptions po;
    po.ransac.sprt_min_data = o.sprt_min_matches;
    m = geometry::EstimateProcrustes(c.ref, c.query, d_ref, d_query, k_ref, k_query, po);
  }
  r.inliers = m.status.num_inliers;
  r.inlier_mask = m.inliers;
  r.status = StatusOf(m.status.outcome);
  r.query_from_ref = m.query_from_ref;
  r.confidence = m.confidence;
  if (r.ok()) AbsoluteConfidence(pnp, c, k_ref, k_query, d_ref, d_query, &r);
  return r;
}

}  // namespace freeloc::pose::internal
