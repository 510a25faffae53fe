#include "freeloc/pipeline/stages.h"

#include <chrono>

#include "freeloc/core/error.h"
#include "freeloc/geometry/absolute_pose.h"
#include "freeloc/geometry/essential.h"
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

nn::RuntimeOptions RuntimeOf(const PipelineOptions& o) {
  nn::RuntimeOptions rt;
  rt.device = o.device;
  rt.threads = o.threads;
  return rt;
}

// ----------------------------------------------------------------------------------------------------------------
// Matchers

class SiftMatcher : public Matcher {
 public:
  void SetReference(const Image& image, const Camera&) override { ref_ = matching::ExtractSift(image); }
  matching::Correspondences Match(const Image& query, const Camera&, const std::vector<Eigen::Vector4d>*,
                                  QueryResult* r) override {
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
  void SetReference(const Image&, const Camera&) override {}
  matching::Correspondences Match(const Image&, const Camera&, const std::vector<Eigen::Vector4d>* pre,
                                  QueryResult*) override {
    FREELOC_CHECK(pre != nullptr, "matcher " << name_ << " needs precomputed correspondences");
    matching::Correspondences c;
    for (const auto& v : *pre) {
      c.ref.emplace_back(v(0), v(1));
      c.query.emplace_back(v(2), v(3));
    }
    return c;
  }

 private:
  std::string name_;
};

// DUSt3R global matches; with a SegGPT model, the paper's instance knowledge on top (Eq. 1–3).
class Dust3rMatcher : public Matcher {
 public:
  Dust3rMatcher(const PipelineOptions& o, std::shared_ptr<nn::Dust3rModel> dust3r,
                std::shared_ptr<nn::SegGptModel> seggpt)
      : o_(o), fn_(std::move(dust3r)), seggpt_(std::move(seggpt)) {
    instance_.mode = matching::ParseInstanceMode(o.instance_mode);
    instance_.preprocess.size = o.dust3r_size;
    instance_.match.threads = o.threads;
    instance_.min_matches = o.min_instance_matches;
    instance_.Validate();
  }

  void SetReference(const Image& image, const Camera&) override {
    ref_ = image;
    fn_.Clear();
    ref_in_ = PreprocessForDust3r(image, instance_.preprocess);
    ref_masks_.clear();
    if (seggpt_) {
      // Reference instances from the reference's own pointmap: DUSt3R on (reference, reference), its monocular
      // convention; the encoder pass is the one every query reuses.
      const matching::PairPointmaps pm = fn_.Run(ref_in_, ref_in_);
      const auto labels = matching::ProposeInstances(pm.pts1.data(), pm.conf1.data(), pm.h1, pm.w1, o_.proposals);
      ref_masks_ = matching::SplitLabels(matching::ProposalsToImage(labels, ref_in_));
    }
  }

  matching::Correspondences Match(const Image& query, const Camera&, const std::vector<Eigen::Vector4d>*,
                                  QueryResult* r) override {
    auto t0 = std::chrono::steady_clock::now();
    const Dust3rInput q_in = PreprocessForDust3r(query, instance_.preprocess);
    const matching::PointmapFn fn = fn_.Fn();
    std::vector<matching::Correspondence> merged =
        matching::GlobalCorrespondences(fn(ref_in_, q_in), ref_in_, q_in, instance_.match);
    r->global_matches = static_cast<int>(merged.size());
    r->match_ms = Ms(t0);
    if (seggpt_ && !ref_masks_.empty()) {
      t0 = std::chrono::steady_clock::now();
      // Propagate each reference instance into the query, re-run DUSt3R on each masked pair, and let the instance
      // matches replace the global ones inside the instances that gave enough of them.
      const auto props = nn::InstanceSegmenter(seggpt_, o_.segmenter).Propagate(ref_, ref_masks_, query);
      std::vector<matching::InstanceMasks> pairs;
      for (size_t i = 0; i < props.size(); ++i)
        if (props[i].kept) pairs.push_back({props[i].id, ref_masks_[i].second, props[i].query_mask});
      std::vector<matching::InstanceResult> results;
      for (const auto& p : pairs) {
        results.push_back(matching::MatchInstance(ref_, query, p, fn, instance_));
        r->instances_used += results.back().used;
      }
      r->instances = static_cast<int>(ref_masks_.size());
      merged = matching::MergeMatches(merged, results, pairs, ref_.width, ref_.height);
      r->instance_ms = Ms(t0);
    }
    matching::Correspondences c;
    for (const auto& m : merged) {
      c.ref.push_back(m.ref);
      c.query.push_back(m.query);
    }
    return c;
  }

  void AddStats(CacheStats* s) const override {
    s->reference_encodings = fn_.encoded();
    s->reference_reuses = fn_.reused();
    s->reference_instances = static_cast<int>(ref_masks_.size());
  }

 private:
  PipelineOptions o_;
  CachingDust3r fn_;
  std::shared_ptr<nn::SegGptModel> seggpt_;
  matching::InstanceOptions instance_;
  Image ref_;
  Dust3rInput ref_in_;
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
    return nn::DepthEstimator(model_).Estimate(image, camera);
  }
  void AddStats(CacheStats* s) const override { s->depth_estimates = passes_; }

 private:
  std::shared_ptr<nn::Metric3dModel> model_;
  int passes_ = 0;
};

// ----------------------------------------------------------------------------------------------------------------
// Solvers

class EssentialSolver : public PoseSolver {
 public:
  explicit EssentialSolver(const PipelineOptions& o) : threshold_px_(o.threshold_px) {
    scale_.method = geometry::ParseScaleMethod(o.scale);
  }
  void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
             const DepthMap& d_query, QueryResult* r) const override {
    const auto t0 = std::chrono::steady_clock::now();
    r->matches = static_cast<int>(c.size());
    if (c.size() < 5) {
      r->status = "too-few-matches";
      return;
    }
    geometry::RelativePoseOptions ro;
    if (threshold_px_ > 0) ro.threshold_px = threshold_px_;
    const auto rel = geometry::EstimateRelativePose(c.ref, c.query, k_ref, k_query, ro);
    r->inliers = rel.status.num_inliers;
    r->solve_ms = Ms(t0);
    if (!rel.status.success) {
      r->status = rel.status.reason;
      return;
    }
    r->query_from_ref = rel.query_from_ref;
    r->confidence = rel.status.num_inliers;
    if (d_ref.empty() || d_query.empty()) {
      r->status = "ok-unit-translation";
      r->ok = true;
      return;
    }
    std::vector<Eigen::Vector2d> a, b;
    const Eigen::Matrix3d E =
        geometry::Skew(rel.query_from_ref.translation) * rel.query_from_ref.rotation.toRotationMatrix();
    double sampson = 0;
    for (size_t i = 0; i < c.size(); ++i)
      if (rel.inliers[i]) {
        a.push_back(c.ref[i]);
        b.push_back(c.query[i]);
        sampson += geometry::SampsonSquared(E, k_ref.Unproject(c.ref[i].x(), c.ref[i].y()),
                                            k_query.Unproject(c.query[i].x(), c.query[i].y()));
      }
    const auto s = geometry::EstimateMetricScale(a, b, rel.query_from_ref, d_ref, d_query, k_ref, k_query, scale_);
    r->scale_inliers = s.num_inliers;
    r->solve_ms = Ms(t0);
    if (!s.success) {
      r->status = "scale-" + s.reason;
      return;
    }
    r->query_from_ref.translation *= s.scale;
    r->confidence = s.confidence;  // official: the baseline's support count
    if (scale_.method == geometry::ScaleMethod::kRobust) {
      const double focal = 0.25 * (k_ref.fx + k_ref.fy + k_query.fx + k_query.fy);
      PoseEvidence ev;
      ev.matches = static_cast<int>(c.size());
      ev.inliers = rel.status.num_inliers;
      ev.residual_px = focal * std::sqrt(sampson / std::max<size_t>(1, a.size()));
      ev.focal_px = focal;
      ev.mean_depth_m = s.mean_distance_m;
      ev.scale_candidates = s.num_candidates;
      ev.scale_inliers = s.num_inliers;
      ev.scale_std_error_m = s.std_error_m;
      const PredictedError pe = PredictPoseError(ev);
      r->predicted_translation_m = pe.translation_m;
      r->predicted_rotation_deg = pe.rotation_deg;
      r->confidence = ConfidenceFromPredictedError(pe);
    }
    r->status = "ok";
    r->ok = true;
  }

 private:
  double threshold_px_;
  geometry::ScaleOptions scale_;
};

class AbsoluteSolver : public PoseSolver {
 public:
  explicit AbsoluteSolver(bool pnp) : pnp_(pnp) {}
  void Solve(const matching::Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
             const DepthMap& d_query, QueryResult* r) const override {
    const auto t0 = std::chrono::steady_clock::now();
    r->matches = static_cast<int>(c.size());
    const auto m = pnp_ ? geometry::EstimatePnP(c.ref, c.query, d_ref, k_ref, k_query)
                        : geometry::EstimateProcrustes(c.ref, c.query, d_ref, d_query, k_ref, k_query);
    r->inliers = m.status.num_inliers;
    r->status = m.status.reason;
    r->ok = m.status.success;
    r->query_from_ref = m.query_from_ref;
    r->confidence = m.confidence;
    r->solve_ms = Ms(t0);
  }

 private:
  bool pnp_;
};

}  // namespace

std::unique_ptr<Matcher> MakeMatcher(const PipelineOptions& o) {
  o.Validate();
  if (o.matcher == "sift") return std::make_unique<SiftMatcher>();
  if (o.UsesDust3r()) {
    const nn::RuntimeOptions rt = RuntimeOf(o);
    return std::make_unique<Dust3rMatcher>(o, CachedDust3r(o.dust3r_model, "", rt),
                                           o.UsesSegGpt() ? CachedSegGpt(o.seggpt_model, rt) : nullptr);
  }
  return std::make_unique<PrecomputedMatcher>(o.matcher);
}

std::unique_ptr<DepthEstimator> MakeDepthEstimator(const PipelineOptions& o) {
  o.Validate();
  if (o.UsesMetric3d()) return std::make_unique<Metric3dDepth>(CachedMetric3d(o.metric3d_model, RuntimeOf(o)));
  if (o.UsesProvidedDepth()) return std::make_unique<ProvidedDepth>();
  return std::make_unique<NoDepth>();
}

std::unique_ptr<PoseSolver> MakePoseSolver(const PipelineOptions& o) {
  o.Validate();
  if (o.solver == "essential") return std::make_unique<EssentialSolver>(o);
  return std::make_unique<AbsoluteSolver>(o.solver == "pnp");
}

}  // namespace freeloc::pipeline
