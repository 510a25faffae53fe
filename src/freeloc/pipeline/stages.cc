#include "freeloc/pipeline/stages.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <iomanip>
#include <sstream>
#include <thread>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/timing.h"
#include "freeloc/geometry/absolute_pose.h"
#include "freeloc/geometry/essential.h"
#include "freeloc/geometry/hybrid_pose.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/geometry/rotation_only.h"
#include "freeloc/matching/instance.h"
#include "freeloc/matching/sift.h"
#include "freeloc/pipeline/confidence.h"
#include "freeloc/pipeline/networks.h"

namespace freeloc::pipeline {

namespace {

// ----------------------------------------------------------------------------------------------------------------
// Matchers

class SiftMatcher : public Matcher {
 public:
  void SetReference(const Image& image, const Camera&, const std::vector<uint16_t>*) override {
    ref_ = matching::ExtractSift(image);
  }
  matching::Correspondences Match(const Image& query, const Camera&, const FrameInputs&, QueryResult* r) override {
    const auto t0 = std::chrono::steady_clock::now();
    auto c = matching::MatchSiftFeatures(ref_, matching::ExtractSift(query));
    r->timings.match_ms = MsSince(t0);
    return c;
  }

 private:
  matching::SiftFeatures ref_;
};

class PrecomputedMatcher : public Matcher {
 public:
  explicit PrecomputedMatcher(std::string name) : name_(std::move(name)) {}
  void SetReference(const Image&, const Camera&, const std::vector<uint16_t>*) override {}
  matching::Correspondences Match(const Image&, const Camera&, const FrameInputs& in, QueryResult*) override {
    FREELOC_CHECK(in.correspondences != nullptr, "matcher precomputed:" << name_ << " was given no correspondences");
    return matching::Correspondences::FromRows(*in.correspondences);
  }

 private:
  std::string name_;
};

// ----------------------------------------------------------------------------------------------------------------
// Depth

class NoDepth : public DepthEstimator {
 public:
  DepthMap Depth(const Image&, const Camera&, DepthMap) override { return {}; }
};

class ProvidedDepth : public DepthEstimator {
 public:
  DepthMap Depth(const Image&, const Camera&, DepthMap provided) override { return provided; }
  bool needs_provided() const override { return true; }
};

// ----------------------------------------------------------------------------------------------------------------
// Solvers

// A depth map must cover the correspondences it is sampled at: a depth of another resolution (a 320×240 map for
// 640×480 matches) would silently give a wrong metric scale. Points a little off the map (noise at the border) are
// fine; more than 20 % of them beyond a 5 % margin is an error.
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

// The estimator's reason text → the status enum ("ok", "too-few-matches", "no-consensus", "degenerate").
QueryStatus StatusOf(geometry::EstimatorOutcome outcome) {
  switch (outcome) {
    case geometry::EstimatorOutcome::kOk: return QueryStatus::kOk;
    case geometry::EstimatorOutcome::kWeakSupport: return QueryStatus::kWeakSupport;
    case geometry::EstimatorOutcome::kTooFewMatches: return QueryStatus::kTooFewMatches;
    case geometry::EstimatorOutcome::kNoConsensus: return QueryStatus::kNoConsensus;
    case geometry::EstimatorOutcome::kDegenerate: return QueryStatus::kDegenerate;
  }
  return QueryStatus::kError;
}

// The evidence confidence.h predicts the pose error from (essential inliers, their Sampson residual, the scale).
PoseEvidence EssentialEvidence(const matching::Correspondences& c, const geometry::RelativePoseResult& rel,
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
  const double focal = 0.25 * (k_ref.fx + k_ref.fy + k_query.fx + k_query.fy);
  PoseEvidence ev;
  ev.matches = static_cast<int>(c.size());
  ev.inliers = rel.status.num_inliers;
  ev.residual_px = focal * std::sqrt(sampson / std::max<size_t>(1, n));
  ev.focal_px = focal;
  ev.mean_depth_m = s.mean_distance_m;
  ev.scale_candidates = s.num_candidates;
  ev.scale_inliers = s.num_inliers;
  ev.scale_std_error_m = s.std_error_m;
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

// Per-correspondence depths for telling competing models apart (0 where a map has none).
geometry::DepthSamples SampleDepths(const matching::Correspondences& c, const DepthMap& d_ref,
                                    const DepthMap& d_query) {
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

// 5-point LO-RANSAC on the correspondences, then the metric scale from both depths on its inliers.
class EssentialSolver : public PoseSolver {
 public:
  explicit EssentialSolver(const PipelineOptions& o)
      : threshold_px_(o.solve.threshold_px), sprt_min_matches_(o.solve.sprt_min_matches) {
    scale_.method = o.solve.scale;
  }

  void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
             const DepthMap& d_query, QueryResult* r) const override {
    const auto t0 = std::chrono::steady_clock::now();
    r->matches = static_cast<int>(c.size());
    r->route = "essential";
    CheckDepthCovers(c.ref, d_ref, "reference");
    CheckDepthCovers(c.query, d_query, "query");
    if (c.size() < 5) {
      r->status = QueryStatus::kTooFewMatches;
      return;
    }
    geometry::RelativePoseOptions ro;
    if (threshold_px_ > 0) ro.threshold_px = threshold_px_;
    ro.ransac.sprt_min_data = sprt_min_matches_;
    const auto rel =
        geometry::EstimateRelativePose(c.ref, c.query, k_ref, k_query, ro, SampleDepths(c, d_ref, d_query));
    r->inliers = rel.status.num_inliers;
    r->inlier_mask = rel.inliers;
    r->timings.solve_ms = MsSince(t0);
    r->status = StatusOf(rel.status.outcome);
    const bool weak = r->weak();
    if (!rel.status.success() && !weak) {
      const geometry::RotationOnlyResult rot =
          geometry::EstimateRotationOnly(c.ref, c.query, k_ref, k_query, ro.threshold_px);
      if (rot.found && rot.num_inliers >= 15 && 2 * static_cast<size_t>(rot.num_inliers) >= c.size())
        NoParallax(c, rot, k_ref, k_query, d_ref, d_query, r);
      r->timings.solve_ms = MsSince(t0);
      return;
    }
    r->query_from_ref = rel.query_from_ref;
    r->confidence = rel.status.num_inliers;
    if (d_ref.empty() || d_query.empty()) {
      r->status = QueryStatus::kOkUnitTranslation;  // weak or not: mapped below
      // Without depth a camera turned in place fits any translation direction: the model found is arbitrary. A
      // rotation that explains the essential inliers as well (its 2D residual within 2.2 × their 1D Sampson error —
      // 1.4–1.8 for noise alone, 3 and more with the parallax of a 1 cm baseline at 3 m) says so instead.
      const geometry::RotationOnlyResult rot =
          geometry::EstimateRotationOnly(c.ref, c.query, k_ref, k_query, ro.threshold_px);
      const double sampson_px = EssentialEvidence(c, rel, geometry::ScaleResult(), k_ref, k_query).residual_px;
      if (!weak && rot.found && rot.num_inliers >= 0.9 * rel.status.num_inliers &&
          rot.residual_px <= 2.2 * std::max(sampson_px, 0.05)) {
        NoParallax(c, rot, k_ref, k_query, d_ref, d_query, r);
        r->confidence = 0;
        r->timings.solve_ms = MsSince(t0);
        return;
      }
    } else {
      Scale(c, rel, k_ref, k_query, d_ref, d_query, r);
    }
    // Weak support: an answer ranked below every supported one (its scale failing leaves no pose at all).
    if (weak && (r->status == QueryStatus::kOk || r->status == QueryStatus::kOkUnitTranslation)) {
      r->status = QueryStatus::kWeakSupport;
      r->confidence = WeakSupportConfidence(r->confidence);
    }
    r->timings.solve_ms = MsSince(t0);
  }

 private:
  void Scale(const matching::Correspondences& c, const geometry::RelativePoseResult& rel, const Camera& k_ref,
             const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query, QueryResult* r) const {
    std::vector<Eigen::Vector2d> a, b;
    for (size_t i = 0; i < c.size(); ++i)
      if (rel.inliers[i]) {
        a.push_back(c.ref[i]);
        b.push_back(c.query[i]);
      }
    const auto s = geometry::EstimateMetricScale(a, b, rel.query_from_ref, d_ref, d_query, k_ref, k_query, scale_);
    r->scale_inliers = s.num_inliers;
    if (!s.success()) {
      r->status = s.outcome == geometry::ScaleOutcome::kNoValidDepth ? QueryStatus::kScaleNoValidDepth
                                                                     : QueryStatus::kScaleNoConsensus;
      return;
    }
    r->query_from_ref.translation *= s.scale;
    r->confidence = s.confidence;  // official: the baseline's support count
    if (scale_.method != geometry::ScaleMethod::kOfficial) {
      const PredictedError pe = PredictPoseError(EssentialEvidence(c, rel, s, k_ref, k_query));
      r->predicted_translation_m = pe.translation_m;
      r->predicted_rotation_deg = pe.rotation_deg;
      r->confidence = ConfidenceFromPredictedError(pe);
    }
    r->status = QueryStatus::kOk;
  }

  // No parallax — the same photo twice, a camera turned in place: every translation direction fits, so the essential
  // search finds no model (or, without depth, an arbitrary one). A rotation explaining at least half of the matches
  // (and 15) is then the answer: with both depths a metric pose, its translation from them
  // (geometry::TranslationFromDepths); without, the status says why (the translation cannot be seen).
  static void NoParallax(const matching::Correspondences& c, const geometry::RotationOnlyResult& rot,
                         const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref, const DepthMap& d_query,
                         QueryResult* r) {
    const double angle = Eigen::AngleAxisd(rot.query_from_ref).angle() * 180 / M_PI;
    r->route = "rotation";
    r->inliers = rot.num_inliers;
    r->inlier_mask = rot.inliers;
    r->query_from_ref = Rigid3d(rot.query_from_ref, Eigen::Vector3d::Zero());
    std::ostringstream what;
    what << "no parallax: " << rot.num_inliers << " of " << c.size() << " matches fit a rotation of " << std::fixed
         << std::setprecision(2) << angle << " degrees alone (the same viewpoint, or a camera turned in place";
    if (d_ref.empty() || d_query.empty()) {
      r->status = QueryStatus::kDegenerate;
      r->message = what.str() + "); without depth maps the translation cannot be seen: give both depth maps";
      return;
    }
    const geometry::DepthTranslation dt =
        geometry::TranslationFromDepths(c.ref, c.query, k_ref, k_query, rot, d_ref, d_query);
    if (!dt.found) {
      r->status = QueryStatus::kScaleNoValidDepth;
      r->message = what.str() + "); too few of its matches have depth in both maps for the translation";
      return;
    }
    r->query_from_ref.translation = dt.t;
    r->scale_inliers = dt.agree;
    PoseEvidence ev;
    ev.matches = static_cast<int>(c.size());
    ev.inliers = rot.num_inliers;
    ev.residual_px = rot.residual_px;
    ev.focal_px = 0.25 * (k_ref.fx + k_ref.fy + k_query.fx + k_query.fy);
    ev.mean_depth_m = dt.mean_depth_m;
    ev.scale_candidates = dt.samples;
    ev.scale_inliers = dt.agree;
    ev.scale_std_error_m = dt.std_error_m;
    const PredictedError pe = PredictPoseError(ev);
    r->predicted_translation_m = pe.translation_m;
    r->predicted_rotation_deg = pe.rotation_deg;
    r->confidence = ConfidenceFromPredictedError(pe);
    r->status = QueryStatus::kOk;
    r->message = what.str() + "): the translation is from the depth maps";
  }

  double threshold_px_;
  int sprt_min_matches_;
  geometry::ScaleOptions scale_;
};

// The depth-aware hybrid estimator (geometry/hybrid_pose.h) with the essential route as its guard and fallback:
// both run; the hybrid model is taken unless it explains clearly fewer correspondences epipolarly than the
// 5-point model does (a depth map that pulls the pose away from what the matches say), or fails. Its translation is
// in reference-depth units; when the query depth agrees on the scale within a factor 2, the two anchorings are
// combined by their geometric mean (t / √s), else the reference's is kept.
//
// The guard searches every set with the dense-set rule (sequential test + give-up, ransac.h), sparse ones included:
// a consensus holding less than its minimum share (a fifth) is the hybrid search's to find — at least a tenth of its
// 10 000 samples are 3-point depth samples, which find a depth-consistent consensus of 15 % with ≥ 96 % — so the
// guard no longer spends the plain search's 100 000 five-point samples (and its weak-support control as many again)
// on a few hundred matches with no consensus. What it gives up: a consensus under a fifth that the depths
// contradict, and some depth-consistent ones of 10–15 % (docs/geometry.md "Sparse sets").
// sprt_min_matches = 0 still means the plain search everywhere.
PipelineOptions GuardOptions(PipelineOptions o) {
  if (o.solve.sprt_min_matches > 0) o.solve.sprt_min_matches = 1;
  return o;
}

class HybridSolver : public PoseSolver {
 public:
  explicit HybridSolver(const PipelineOptions& o) : essential_(GuardOptions(o)) {
    if (o.solve.threshold_px > 0) options_.threshold_px = o.solve.threshold_px;
    options_.reprojection_px = o.solve.reprojection_px;
    options_.shifts = o.solve.depth_shifts != 0;
    options_.ransac.sprt_min_data = o.solve.sprt_min_matches;
  }

  void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
             const DepthMap& d_query, QueryResult* r) const override {
    const auto t0 = std::chrono::steady_clock::now();
    QueryResult ess = *r;
    if (d_ref.empty() || d_query.empty() || c.size() < 5) {  // no depth model to use: the essential route
      essential_.Solve(c, k_ref, k_query, d_ref, d_query, &ess);
      *r = ess;
      r->route = "essential";
      return;
    }
    // The two searches are independent: the essential route on another core while the hybrid one runs here.
    auto essential = std::async(std::thread::hardware_concurrency() > 1 ? std::launch::async : std::launch::deferred,
                                [&] { essential_.Solve(c, k_ref, k_query, d_ref, d_query, &ess); });
    geometry::HybridPoseResult h;
    try {
      const geometry::DepthSamples z = SampleDepths(c, d_ref, d_query);
      h = geometry::EstimateHybridPose(c.ref, c.query, z.ref, z.query, k_ref, k_query, options_);
    } catch (...) {
      essential.get();  // the essential route's error first, as when it ran first
      throw;
    }
    essential.get();
    const bool fits = h.status.success() && h.status.num_inliers >= 0.8 * ess.inliers;
    if (!fits) {
      *r = ess;
      r->route = "hybrid>essential";
      r->timings.solve_ms = MsSince(t0);
      return;
    }
    r->matches = static_cast<int>(c.size());
    r->inliers = h.status.num_inliers;
    r->inlier_mask = h.inliers;
    r->scale_inliers = h.depth_inliers;
    const double log_s = std::log(h.model.scale);
    const bool both = std::abs(log_s) <= std::log(2.0);
    const Eigen::Vector3d t = both ? Eigen::Vector3d(h.model.t / std::sqrt(h.model.scale)) : h.model.t;
    r->query_from_ref = Rigid3d(Eigen::Quaterniond(h.model.R).normalized(), t);
    r->status = QueryStatus::kOk;
    r->route = both ? "hybrid" : "hybrid (reference depth)";
    // The confidence model of every solver (confidence.h): the scale's standard error from the depth inliers'
    // scatter, and the two anchorings' disagreement (half of it left after the geometric mean).
    PoseEvidence ev;
    ev.matches = r->matches;
    ev.inliers = h.status.num_inliers;
    ev.residual_px = h.residual_px;
    ev.focal_px = 0.25 * (k_ref.fx + k_ref.fy + k_query.fx + k_query.fy);
    ev.mean_depth_m = h.mean_depth;
    ev.scale_candidates = h.depth_candidates;
    ev.scale_inliers = h.depth_inliers;
    const double anchor = both ? 0.5 * std::abs(log_s) : std::abs(log_s);
    ev.scale_std_error_m = t.norm() * std::sqrt(h.scale_std_error * h.scale_std_error + anchor * anchor +
                                                geometry::kCommonDepthScaleError * geometry::kCommonDepthScaleError);
    const PredictedError pe = PredictPoseError(ev);
    r->predicted_translation_m = pe.translation_m;
    r->predicted_rotation_deg = pe.rotation_deg;
    r->confidence = ConfidenceFromPredictedError(pe);
    r->timings.solve_ms = MsSince(t0);
  }

 private:
  EssentialSolver essential_;
  geometry::HybridPoseOptions options_;
};

// PnP on the reference depth (threshold_px: reprojection inlier threshold) or Procrustes on both depths.
class AbsoluteSolver : public PoseSolver {
 public:
  AbsoluteSolver(bool pnp, double threshold_px, int sprt_min_matches) : pnp_(pnp) {
    if (threshold_px > 0) pnp_options_.threshold_px = threshold_px;
    pnp_options_.ransac.sprt_min_data = sprt_min_matches;
    procrustes_options_.ransac.sprt_min_data = sprt_min_matches;
  }
  void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
             const DepthMap& d_query, QueryResult* r) const override {
    const auto t0 = std::chrono::steady_clock::now();
    r->matches = static_cast<int>(c.size());
    r->route = pnp_ ? "pnp" : "procrustes";
    CheckDepthCovers(c.ref, d_ref, "reference");
    if (!pnp_) CheckDepthCovers(c.query, d_query, "query");
    const auto m =
        pnp_ ? geometry::EstimatePnP(c.ref, c.query, d_ref, k_ref, k_query, pnp_options_)
             : geometry::EstimateProcrustes(c.ref, c.query, d_ref, d_query, k_ref, k_query, procrustes_options_);
    r->inliers = m.status.num_inliers;
    r->inlier_mask = m.inliers;
    r->status = StatusOf(m.status.outcome);
    r->query_from_ref = m.query_from_ref;
    r->confidence = m.confidence;
    if (r->ok()) Confidence(c, k_ref, k_query, d_ref, d_query, r);
    r->timings.solve_ms = MsSince(t0);
  }

 private:
  // The confidence model of every solver (confidence.h) from the inliers' residuals: PnP's reprojection error in
  // the query, Procrustes' 3D distance seen from the query (as an angle); the depth's common scale error as prior.
  void Confidence(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
                  const DepthMap& d_query, QueryResult* r) const {
    const Rigid3d& T = r->query_from_ref;
    double sq = 0, depth = 0;
    int n = 0;
    for (size_t i = 0; i < c.size(); ++i) {
      if (!r->inlier_mask[i]) continue;
      const double zr = geometry::BilinearDepth(d_ref, c.ref[i].x(), c.ref[i].y());
      if (!(zr > 0)) continue;
      const Eigen::Vector3d Y = T * (zr * k_ref.Unproject(c.ref[i].x(), c.ref[i].y()));
      if (!(Y.z() > 0)) continue;
      if (pnp_) {
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
    PoseEvidence ev;
    ev.matches = static_cast<int>(c.size());
    ev.inliers = r->inliers;
    ev.residual_px = std::sqrt(sq / n);
    ev.focal_px = 0.5 * (k_query.fx + k_query.fy);
    ev.mean_depth_m = depth / n;
    ev.scale_std_error_m = geometry::kCommonDepthScaleError * T.translation.norm();
    const PredictedError pe = PredictPoseError(ev);
    r->predicted_translation_m = pe.translation_m;
    r->predicted_rotation_deg = pe.rotation_deg;
    r->confidence = ConfidenceFromPredictedError(pe);
  }

  bool pnp_;
  geometry::PnPOptions pnp_options_;
  geometry::ProcrustesOptions procrustes_options_;
};

}  // namespace

std::unique_ptr<Matcher> MakeMatcher(const PipelineOptions& o) {
  switch (o.matcher.kind) {
    case MatcherKind::kSift: return std::make_unique<SiftMatcher>();
    case MatcherKind::kPrecomputed: return std::make_unique<PrecomputedMatcher>(o.matcher.correspondences);
    case MatcherKind::kDust3r:
    case MatcherKind::kDust3rInstances:
    case MatcherKind::kMast3r:
    case MatcherKind::kMast3rInstances:
      return Networks().make_matcher(o);  // loads the networks module (LibTorch) on first use
  }
  FREELOC_THROW("matcher: " << o.matcher.ToString() << " has no implementation");
}

std::unique_ptr<DepthEstimator> MakeDepthEstimator(const PipelineOptions& o) {
  switch (o.depth.kind) {
    case DepthKind::kMetric3d: return Networks().make_depth_estimator(o);
    case DepthKind::kProvided: return std::make_unique<ProvidedDepth>();
    case DepthKind::kNone: return std::make_unique<NoDepth>();
    case DepthKind::kMast3r: return std::make_unique<NoDepth>();  // the matcher's pair pass gives it (PairDepth)
  }
  FREELOC_THROW("depth: " << o.depth.ToString() << " has no implementation");
}

std::unique_ptr<PoseSolver> MakePoseSolver(const PipelineOptions& o) {
  if (o.solver == SolverKind::kEssential) return std::make_unique<EssentialSolver>(o);
  if (o.solver == SolverKind::kHybrid) return std::make_unique<HybridSolver>(o);
  return std::make_unique<AbsoluteSolver>(o.solver == SolverKind::kPnp, o.solve.threshold_px, o.solve.sprt_min_matches);
}

}  // namespace freeloc::pipeline
