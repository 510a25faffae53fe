#include "freeloc/pipeline/stages.h"

#include <chrono>
#include <cmath>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/geometry/absolute_pose.h"
#include "freeloc/geometry/essential.h"
#include "freeloc/geometry/hybrid_pose.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/matching/instance.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/metric3d.h"
#include "freeloc/nn/runtime.h"
#include "freeloc/nn/seggpt.h"
#include "freeloc/pipeline/confidence.h"
#include "freeloc/pipeline/dust3r_stage.h"
#include "freeloc/pipeline/models.h"

namespace freeloc::pipeline {

namespace {

double Ms(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

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
    r->match_ms = Ms(t0);
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

// DUSt3R global matches; with instances, the paper's instance knowledge on top (Eq. 1–3): reference instances
// (given labels, or proposals from the reference's own pointmap) matched into the query (SegGPT propagation, or the
// query's given labels), DUSt3R re-run per masked pair, instance matches replacing the global ones inside them.
class Dust3rMatcher : public Matcher {
 public:
  Dust3rMatcher(const PipelineOptions& o, std::shared_ptr<nn::Dust3rModel> dust3r,
                std::shared_ptr<nn::SegGptModel> seggpt)
      : o_(o), fn_(dust3r, o.UsesMast3r()), seggpt_(std::move(seggpt)) {
    FREELOC_CHECK(!o.UsesMast3r() || dust3r->config().is_mast3r(),
                  "mast3r_model " << o.mast3r_model
                                  << ": a DUSt3R checkpoint (no local-feature head); give the MASt3R weights "
                                     "(MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric.pth)");
    instance_.mode = o.instance_mode;
    instance_.preprocess.size = o.dust3r_size;
    instance_.match.conf_threshold = o.match_conf_threshold;
    instance_.match.subsample = o.match_subsample;
    instance_.match.threads = o.runtime.threads;
    instance_.descriptors = o.UsesMast3r();
    instance_.fast_nn.subsample = o.mast3r_subsample;
    instance_.fast_nn.threads = o.runtime.threads;
    instance_.descriptor_filter.border = o.mast3r_border;
    instance_.descriptor_filter.min_conf = o.mast3r_conf_threshold;
    instance_.min_matches = o.min_instance_matches;
    instance_.Validate();
  }

  void SetReference(const Image& image, const Camera&, const std::vector<uint16_t>* labels) override {
    ref_ = image;
    fn_.Clear();
    have_last_ = false;
    ref_in_ = PreprocessForDust3r(image, instance_.preprocess);
    ref_masks_.clear();
    if (!o_.UsesInstances()) return;
    if (labels) {
      CheckLabels(*labels, image, "reference");
      ref_masks_ = matching::SplitLabels(*labels);
    } else if (o_.UsesSegGpt()) {
      // Reference instances from the reference's own pointmap: DUSt3R on (reference, reference), its monocular
      // convention; the encoder pass is the one every query reuses.
      const matching::PairPointmaps pm = fn_.Run(ref_in_, ref_in_);
      const auto proposals = matching::ProposeInstances(pm.pts1.data(), pm.conf1.data(), pm.h1, pm.w1, o_.proposals);
      ref_masks_ = matching::SplitLabels(matching::ProposalsToImage(proposals, ref_in_));
    }
  }

  matching::Correspondences Match(const Image& query, const Camera&, const FrameInputs& in, QueryResult* r) override {
    auto t0 = std::chrono::steady_clock::now();
    q_in_ = PreprocessForDust3r(query, instance_.preprocess);
    const Dust3rInput& q_in = q_in_;
    last_ = fn_.Fn()(ref_in_, q_in);
    have_last_ = true;
    std::vector<matching::Correspondence> merged = matching::GlobalCorrespondences(last_, ref_in_, q_in, instance_);
    r->global_matches = static_cast<int>(merged.size());
    r->match_ms = Ms(t0);
    if (o_.UsesInstances() && !ref_masks_.empty()) {
      t0 = std::chrono::steady_clock::now();
      merged = MatchInstances(query, in, merged, r);
      r->instance_ms = Ms(t0);
    }
    matching::Correspondences c;
    for (const auto& m : merged) {
      c.ref.push_back(m.ref);
      c.query.push_back(m.query);
      c.source.push_back(m.source);
    }
    return c;
  }

  bool PairDepth(bool with_query, DepthMap* ref, DepthMap* query) override {
    if (!o_.UsesMast3r() || !have_last_) return false;
    *ref = NetworkDepthToImage(last_.pts1, last_.h1, last_.w1, ref_in_);
    *query = DepthMap();
    if (with_query) {
      const matching::PairPointmaps sw = fn_.RunSwappedLast();
      *query = NetworkDepthToImage(sw.pts1, sw.h1, sw.w1, q_in_);
    }
    return true;
  }

  void AddStats(CacheStats* s) const override {
    s->reference_encodings = fn_.encoded();
    s->reference_reuses = fn_.reused();
    s->reference_instances = static_cast<int>(ref_masks_.size());
  }

 private:
  // z of a network-resolution pointmap (view 1's own camera frame) at every pixel of the original image: the network
  // pixel nearest to each original pixel (DESIGN §2's pixel-centre mapping); 0 outside the crop or behind the camera.
  static DepthMap NetworkDepthToImage(const std::vector<float>& pts, int h, int w, const Dust3rInput& in) {
    DepthMap d(in.orig_width, in.orig_height);
    for (int y = 0; y < d.height; ++y)
      for (int x = 0; x < d.width; ++x) {
        double xn, yn;
        in.ToNetwork(x, y, &xn, &yn);
        const long xi = std::lround(xn), yi = std::lround(yn);
        if (xi < 0 || yi < 0 || xi >= w || yi >= h) continue;
        const float z = pts[(static_cast<size_t>(yi) * w + static_cast<size_t>(xi)) * 3 + 2];
        if (z > 0 && std::isfinite(z)) d.at(x, y) = z;
      }
    return d;
  }

  static void CheckLabels(const std::vector<uint16_t>& labels, const Image& image, const char* frame) {
    FREELOC_CHECK(labels.size() == static_cast<size_t>(image.width) * image.height,
                  "instance labels of the " << frame << ": " << labels.size() << " values for a " << image.width
                                            << "x" << image.height
                                            << " image; give a label image at the photo's resolution");
  }

  // The (reference, query) mask pairs: the query's given labels with the same ids, or SegGPT's propagations.
  std::vector<matching::InstanceMasks> InstancePairs(const Image& query, const FrameInputs& in) const {
    std::vector<matching::InstanceMasks> pairs;
    if (o_.instance_source == InstanceSource::kGiven) {
      FREELOC_CHECK(in.instance_labels != nullptr,
                    "instance_source given: the query has no instance labels; give a label image for each frame");
      CheckLabels(*in.instance_labels, query, "query");
      for (const auto& [id, mq] : matching::SplitLabels(*in.instance_labels))
        for (const auto& [idr, mr] : ref_masks_)
          if (id == idr) pairs.push_back({id, mr, mq});
      return pairs;
    }
    const auto props = nn::InstanceSegmenter(seggpt_, o_.segmenter).Propagate(ref_, ref_masks_, query);
    for (size_t i = 0; i < props.size(); ++i)
      if (props[i].kept) pairs.push_back({props[i].id, ref_masks_[i].second, props[i].query_mask});
    return pairs;
  }

  // Re-runs DUSt3R on each masked pair; the instances with enough matches replace the global ones inside them.
  std::vector<matching::Correspondence> MatchInstances(const Image& query, const FrameInputs& in,
                                                       const std::vector<matching::Correspondence>& global,
                                                       QueryResult* r) {
    const std::vector<matching::InstanceMasks> pairs = InstancePairs(query, in);
    std::vector<matching::InstanceResult> results;
    for (const auto& p : pairs) {
      results.push_back(matching::MatchInstance(ref_, query, p, fn_.Fn(), instance_));
      r->instances_used += results.back().used;
      if (!results.back().used)
        FREELOC_LOG(DEBUG) << "instance " << p.id << " not used: " << results.back().reason;
    }
    r->instances = o_.instance_source == InstanceSource::kGiven ? static_cast<int>(pairs.size())
                                                                : static_cast<int>(ref_masks_.size());
    return matching::MergeMatches(global, results, pairs, ref_.width, ref_.height);
  }

  PipelineOptions o_;
  CachingDust3r fn_;
  std::shared_ptr<nn::SegGptModel> seggpt_;
  matching::InstanceOptions instance_;
  Image ref_;
  Dust3rInput ref_in_, q_in_;
  matching::PairPointmaps last_;  // the last query's global pass (MASt3R depth comes from it)
  bool have_last_ = false;
  std::vector<std::pair<int, std::vector<uint8_t>>> ref_masks_;  // 0/1 at the reference's resolution
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

class Metric3dDepth : public DepthEstimator {
 public:
  explicit Metric3dDepth(std::shared_ptr<nn::Metric3dModel> m) : model_(std::move(m)) {}
  DepthMap Depth(const Image& image, const Camera& camera, DepthMap) override {
    ++passes_;
    return model_->Estimate(image, camera).depth;
  }
  void AddStats(CacheStats* s) const override { s->depth_estimates = passes_; }

 private:
  std::shared_ptr<nn::Metric3dModel> model_;
  int passes_ = 0;
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
  FREELOC_CHECK(outside * 5 <= px.size(),
                frame << " depth: the map is " << d.width << "x" << d.height << " but " << outside << " of " << px.size()
                      << " " << frame << " correspondences lie outside it (up to " << far.x() << ", " << far.y()
                      << "); give the depth map at its image's resolution");
}

// The estimator's reason text → the status enum ("ok", "too-few-matches", "no-consensus", "degenerate").
QueryStatus StatusOf(const std::string& reason) {
  QueryStatus s = QueryStatus::kError;
  FREELOC_CHECK(TryParseEnum(reason, &s) && s != QueryStatus::kError, "solver: unexpected status '" << reason << "'");
  return s;
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
  return ev;
}

// 5-point LO-RANSAC on the correspondences, then the metric scale from both depths on its inliers.
class EssentialSolver : public PoseSolver {
 public:
  explicit EssentialSolver(const PipelineOptions& o) : threshold_px_(o.threshold_px) { scale_.method = o.scale; }

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
    const auto rel = geometry::EstimateRelativePose(c.ref, c.query, k_ref, k_query, ro);
    r->inliers = rel.status.num_inliers;
    r->inlier_mask = rel.inliers;
    r->solve_ms = Ms(t0);
    r->status = StatusOf(rel.status.reason);
    if (!rel.status.success) return;
    r->query_from_ref = rel.query_from_ref;
    r->confidence = rel.status.num_inliers;
    if (d_ref.empty() || d_query.empty()) {
      r->status = QueryStatus::kOkUnitTranslation;
      return;
    }
    Scale(c, rel, k_ref, k_query, d_ref, d_query, r);
    r->solve_ms = Ms(t0);
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
    if (!s.success) {
      r->status = s.reason == "no-valid-depth" ? QueryStatus::kScaleNoValidDepth : QueryStatus::kScaleNoConsensus;
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

  double threshold_px_;
  geometry::ScaleOptions scale_;
};

// The depth-aware hybrid estimator (geometry/hybrid_pose.h) with the essential route as its guard and fallback:
// both run; the hybrid model is taken unless it explains clearly fewer correspondences epipolarly than the
// 5-point model does (a depth map that pulls the pose away from what the matches say), or fails. Its translation is
// in reference-depth units; when the query depth agrees on the scale within a factor 2, the two anchorings are
// combined by their geometric mean (t / √s), else the reference's is kept.
class HybridSolver : public PoseSolver {
 public:
  explicit HybridSolver(const PipelineOptions& o) : essential_(o) {
    if (o.threshold_px > 0) options_.threshold_px = o.threshold_px;
    options_.reprojection_px = o.reprojection_px;
    options_.shifts = o.depth_shifts != 0;
  }

  void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
             const DepthMap& d_query, QueryResult* r) const override {
    const auto t0 = std::chrono::steady_clock::now();
    QueryResult ess = *r;
    essential_.Solve(c, k_ref, k_query, d_ref, d_query, &ess);
    if (d_ref.empty() || d_query.empty() || c.size() < 5) {  // no depth model to use: the essential route
      *r = ess;
      r->route = "essential";
      return;
    }
    std::vector<double> zr(c.size()), zq(c.size());
    for (size_t i = 0; i < c.size(); ++i) {
      zr[i] = geometry::BilinearDepth(d_ref, c.ref[i].x(), c.ref[i].y());
      zq[i] = geometry::BilinearDepth(d_query, c.query[i].x(), c.query[i].y());
    }
    const geometry::HybridPoseResult h = geometry::EstimateHybridPose(c.ref, c.query, zr, zq, k_ref, k_query, options_);
    const bool fits = h.status.success && h.status.num_inliers >= 0.8 * ess.inliers;
    if (!fits) {
      *r = ess;
      r->route = "hybrid>essential";
      r->solve_ms = Ms(t0);
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
    r->solve_ms = Ms(t0);
  }

 private:
  EssentialSolver essential_;
  geometry::HybridPoseOptions options_;
};

// PnP on the reference depth (threshold_px: reprojection inlier threshold) or Procrustes on both depths.
class AbsoluteSolver : public PoseSolver {
 public:
  AbsoluteSolver(bool pnp, double threshold_px) : pnp_(pnp) {
    if (threshold_px > 0) pnp_options_.threshold_px = threshold_px;
  }
  void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
             const DepthMap& d_query, QueryResult* r) const override {
    const auto t0 = std::chrono::steady_clock::now();
    r->matches = static_cast<int>(c.size());
    r->route = pnp_ ? "pnp" : "procrustes";
    CheckDepthCovers(c.ref, d_ref, "reference");
    if (!pnp_) CheckDepthCovers(c.query, d_query, "query");
    const auto m = pnp_ ? geometry::EstimatePnP(c.ref, c.query, d_ref, k_ref, k_query, pnp_options_)
                        : geometry::EstimateProcrustes(c.ref, c.query, d_ref, d_query, k_ref, k_query);
    r->inliers = m.status.num_inliers;
    r->inlier_mask = m.inliers;
    r->status = StatusOf(m.status.reason);
    r->query_from_ref = m.query_from_ref;
    r->confidence = m.confidence;
    if (r->ok()) Confidence(c, k_ref, k_query, d_ref, d_query, r);
    r->solve_ms = Ms(t0);
  }

 private:
  // The confidence model of every solver (confidence.h) from the inliers' residuals: PnP's reprojection error in
  // the query, Procrustes' 3D distance seen from the query (as an angle); the depth's common scale error as prior.
  void Confidence(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query,
                  const DepthMap& d_ref, const DepthMap& d_query, QueryResult* r) const {
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
};

}  // namespace

std::unique_ptr<Matcher> MakeMatcher(const PipelineOptions& o) {
  o.Validate();
  switch (o.matcher.kind) {
    case MatcherKind::kSift: return std::make_unique<SiftMatcher>();
    case MatcherKind::kPrecomputed: return std::make_unique<PrecomputedMatcher>(o.matcher.correspondences);
    case MatcherKind::kDust3r:
    case MatcherKind::kDust3rInstances:
      return std::make_unique<Dust3rMatcher>(o, CachedDust3r(o.dust3r_model, o.dust3r_config, o.runtime),
                                             o.UsesSegGpt() ? CachedSegGpt(o.seggpt_model, o.runtime) : nullptr);
    case MatcherKind::kMast3r:
    case MatcherKind::kMast3rInstances:
      return std::make_unique<Dust3rMatcher>(o, CachedDust3r(o.mast3r_model, "", o.runtime),
                                             o.UsesSegGpt() ? CachedSegGpt(o.seggpt_model, o.runtime) : nullptr);
  }
  FREELOC_THROW("matcher: " << o.matcher.ToString() << " has no implementation");
}

std::unique_ptr<DepthEstimator> MakeDepthEstimator(const PipelineOptions& o) {
  o.Validate();
  switch (o.depth.kind) {
    case DepthKind::kMetric3d: return std::make_unique<Metric3dDepth>(CachedMetric3d(o.metric3d_model, o.runtime));
    case DepthKind::kProvided: return std::make_unique<ProvidedDepth>();
    case DepthKind::kNone: return std::make_unique<NoDepth>();
    case DepthKind::kMast3r: return std::make_unique<NoDepth>();  // the matcher's pair pass gives it (PairDepth)
  }
  FREELOC_THROW("depth: " << o.depth.ToString() << " has no implementation");
}

std::unique_ptr<PoseSolver> MakePoseSolver(const PipelineOptions& o) {
  o.Validate();
  if (o.solver == SolverKind::kEssential) return std::make_unique<EssentialSolver>(o);
  if (o.solver == SolverKind::kHybrid) return std::make_unique<HybridSolver>(o);
  return std::make_unique<AbsoluteSolver>(o.solver == SolverKind::kPnp, o.threshold_px);
}

}  // namespace freeloc::pipeline
