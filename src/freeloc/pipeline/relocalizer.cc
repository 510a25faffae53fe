#include "freeloc/pipeline/relocalizer.h"

#include <chrono>
#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/geometry/absolute_pose.h"
#include "freeloc/geometry/essential.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/matching/instance.h"
#include "freeloc/matching/sift.h"
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
}  // namespace

// ---------------------------------------------------------------------------------------------------------------
// Options and presets

void PipelineOptions::Validate() const {
  FREELOC_CHECK(matcher == "sift" || UsesDust3r() || matcher.rfind("precomputed:", 0) == 0,
                "--matcher '" << matcher << "' is not available; use sift, dust3r, dust3r+instances or "
                              << "precomputed:<name>");
  FREELOC_CHECK(dust3r_size >= 224, "--dust3r-size " << dust3r_size << " is too small; use 224 or 512");
  FREELOC_CHECK(depth == "none" || UsesMetric3d() || (UsesProvidedDepth() && depth.size() > 9),
                "--depth '" << depth << "' is not available; use metric3d, provided:<suffix> or none");
  FREELOC_CHECK(solver == "essential" || solver == "pnp" || solver == "procrustes",
                "--solver '" << solver << "' is unknown; use essential, pnp or procrustes");
  FREELOC_CHECK(solver == "essential" || depth != "none",
                "--solver " << solver << " needs depth (--depth provided:<suffix> or metric3d)");
  FREELOC_CHECK(instance_mode == "mask" || instance_mode == "crop",
                "--instance-mode '" << instance_mode << "' is unknown; use mask or crop");
  geometry::ParseScaleMethod(scale);
  proposals.Validate();
  const auto dirs = ModelDirs(models_dir);
  FREELOC_CHECK(!UsesDust3r() || !dust3r_model.empty(), MissingModelMessage(Network::kDust3r, preset, dirs));
  FREELOC_CHECK(!UsesSegGpt() || !seggpt_model.empty(), MissingModelMessage(Network::kSegGpt, preset, dirs));
  FREELOC_CHECK(!UsesMetric3d() || !metric3d_model.empty(), MissingModelMessage(Network::kMetric3d, preset, dirs));
}

std::string PipelineOptions::Summary() const {
  std::string s = "preset " + preset + ": matcher " + matcher + ", depth " + depth + ", solver " + solver +
                  (solver == "essential" ? ", scale " + scale : "") +
                  (threshold_px > 0 ? ", threshold " + std::to_string(threshold_px) + " px" : "");
  if (UsesDust3r()) s += ", dust3r " + dust3r_model + " at " + std::to_string(dust3r_size);
  if (UsesSegGpt()) s += ", seggpt " + seggpt_model + ", instance-mode " + instance_mode;
  if (UsesMetric3d()) s += ", metric3d " + metric3d_model;
  return s;
}

std::vector<std::string> PresetNames() {
  return {"sift-essential",
          "sift-pnp",
          "sift-procrustes",
          "precomputed:<SIFT|SG|LoFTR>-<essential|pnp|procrustes>",
          "seed",
          "seed-no-instance",
          "seed-provided-depth",
          "dust3r"};
}

PipelineOptions ResolvePreset(const std::string& name) {
  PipelineOptions o;
  o.preset = name;
  if (name == "sift-essential" || name == "sift-pnp" || name == "sift-procrustes") {
    o.matcher = "sift";
    o.solver = name.substr(5);
    if (o.solver == "essential") o.threshold_px = 3.0;  // the benchmark's SIFT threshold
    return o;
  }
  if (name.rfind("precomputed:", 0) == 0) {
    const std::string rest = name.substr(12);
    const size_t dash = rest.rfind('-');
    FREELOC_CHECK(dash != std::string::npos && dash > 0,
                  "preset '" << name << "': write precomputed:<SIFT|SG|LoFTR>-<essential|pnp|procrustes>");
    o.matcher = "precomputed:" + rest.substr(0, dash);
    o.solver = rest.substr(dash + 1);
    if (o.solver == "essential") o.threshold_px = rest.substr(0, dash) == "SIFT" ? 3.0 : 2.0;
    FREELOC_CHECK(o.solver == "essential" || o.solver == "pnp" || o.solver == "procrustes",
                  "preset '" << name << "': the solver '" << o.solver << "' is unknown; use essential, pnp or "
                             << "procrustes");
    return o;
  }
  // The paper's method and its ablations (Table 2), and the DUSt3R baseline.
  if (name == "seed") {
    o.matcher = "dust3r+instances";
    o.depth = "metric3d";
    return o;
  }
  if (name == "seed-no-instance") {
    o.matcher = "dust3r";
    o.depth = "metric3d";
    return o;
  }
  if (name == "seed-provided-depth") {
    o.matcher = "dust3r+instances";
    return o;
  }
  if (name == "dust3r") {
    o.matcher = "dust3r";
    return o;
  }
  FREELOC_THROW("--preset '" << name << "' is unknown; available: sift-essential, sift-pnp, sift-procrustes, "
                             << "precomputed:<SIFT|SG|LoFTR>-<essential|pnp|procrustes>, seed, seed-no-instance, "
                             << "seed-provided-depth, dust3r");
}

void FindModels(PipelineOptions* o) {
  const auto dirs = ModelDirs(o->models_dir);
  if (o->UsesDust3r() && o->dust3r_model.empty()) o->dust3r_model = FindModel(Network::kDust3r, dirs);
  if (o->UsesSegGpt() && o->seggpt_model.empty()) o->seggpt_model = FindModel(Network::kSegGpt, dirs);
  if (o->UsesMetric3d() && o->metric3d_model.empty()) o->metric3d_model = FindModel(Network::kMetric3d, dirs);
}

void LoadModels(const PipelineOptions& o) {
  const nn::RuntimeOptions rt = RuntimeOf(o);
  if (o.UsesDust3r()) CachedDust3r(o.dust3r_model, "", rt);
  if (o.UsesSegGpt()) CachedSegGpt(o.seggpt_model, rt);
  if (o.UsesMetric3d()) CachedMetric3d(o.metric3d_model, rt);
}

// ---------------------------------------------------------------------------------------------------------------
// The relocalizer

struct Relocalizer::Impl {
  PipelineOptions o;
  CacheStats stats;
  std::shared_ptr<nn::Dust3rModel> dust3r;
  std::unique_ptr<CachingDust3r> dust3r_fn;
  std::shared_ptr<nn::SegGptModel> seggpt;
  std::shared_ptr<nn::Metric3dModel> metric3d;
  matching::InstanceOptions instance;
  // The reference: its image and camera, depth, DUSt3R input and instance masks (0/1 at its resolution).
  Image ref;
  Camera k_ref;
  DepthMap d_ref;
  Dust3rInput ref_in;
  std::vector<std::pair<int, std::vector<uint8_t>>> ref_masks;
  matching::SiftFeatures ref_sift;  // matcher sift: the reference's features, extracted once
  bool have_ref = false;

  DepthMap Estimate(const Image& image, const Camera& k) {
    ++stats.depth_estimates;
    return nn::DepthEstimator(metric3d).Estimate(image, k);
  }

  // The final correspondences and the instance counters of `r`.
  matching::Correspondences Match(const Image& query, const std::vector<Eigen::Vector4d>* pre, QueryResult* r);
  void Solve(const matching::Correspondences& c, const Camera& k_query, const DepthMap& d_query, QueryResult* r);
};

Relocalizer::Relocalizer(const PipelineOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.o = options;
  m.o.Validate();
  const nn::RuntimeOptions rt = RuntimeOf(m.o);
  if (m.o.UsesDust3r()) {
    m.dust3r = CachedDust3r(m.o.dust3r_model, "", rt);
    m.dust3r_fn = std::make_unique<CachingDust3r>(m.dust3r);
  }
  if (m.o.UsesSegGpt()) m.seggpt = CachedSegGpt(m.o.seggpt_model, rt);
  if (m.o.UsesMetric3d()) m.metric3d = CachedMetric3d(m.o.metric3d_model, rt);
  m.instance.mode = matching::ParseInstanceMode(m.o.instance_mode);
  m.instance.preprocess.size = m.o.dust3r_size;
  m.instance.match.threads = m.o.threads;
  m.instance.min_matches = m.o.min_instance_matches;
  m.instance.Validate();
}

Relocalizer::~Relocalizer() = default;
const CacheStats& Relocalizer::stats() const { return impl_->stats; }
const PipelineOptions& Relocalizer::options() const { return impl_->o; }

void Relocalizer::SetReference(const Image& image, const Camera& camera, DepthMap depth) {
  Impl& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  m.ref = image;
  m.k_ref = camera;
  m.d_ref = m.o.UsesProvidedDepth() ? std::move(depth) : DepthMap();
  if (m.o.UsesMetric3d()) m.d_ref = m.Estimate(image, camera);
  m.ref_masks.clear();
  if (m.o.matcher == "sift") m.ref_sift = matching::ExtractSift(image);
  if (m.dust3r_fn) {
    m.dust3r_fn->Clear();
    m.ref_in = PreprocessForDust3r(image, m.instance.preprocess);
  }
  if (m.o.UsesSegGpt()) {
    // Reference instances from the reference's own pointmap: DUSt3R on (reference, reference), its monocular
    // convention; the encoder pass is the one every query reuses.
    const matching::PairPointmaps pm = m.dust3r_fn->Run(m.ref_in, m.ref_in);
    const auto labels = matching::ProposeInstances(pm.pts1.data(), pm.conf1.data(), pm.h1, pm.w1, m.o.proposals);
    m.ref_masks = matching::SplitLabels(matching::ProposalsToImage(labels, m.ref_in));
  }
  m.stats.reference_instances = static_cast<int>(m.ref_masks.size());
  m.stats.reference_ms = Ms(t0);
  m.have_ref = true;
}

matching::Correspondences Relocalizer::Impl::Match(const Image& query, const std::vector<Eigen::Vector4d>* pre,
                                                   QueryResult* r) {
  matching::Correspondences c;
  auto t0 = std::chrono::steady_clock::now();
  if (o.matcher == "sift") {
    c = matching::MatchSiftFeatures(ref_sift, matching::ExtractSift(query));
  } else if (o.UsesDust3r()) {
    const Dust3rInput q_in = PreprocessForDust3r(query, instance.preprocess);
    const matching::PointmapFn fn = dust3r_fn->Fn();
    std::vector<matching::Correspondence> merged =
        matching::GlobalCorrespondences(fn(ref_in, q_in), ref_in, q_in, instance.match);
    r->global_matches = static_cast<int>(merged.size());
    r->match_ms = Ms(t0);
    t0 = std::chrono::steady_clock::now();
    if (o.UsesSegGpt() && !ref_masks.empty()) {
      // Eq. 1–3: propagate each reference instance into the query, re-run DUSt3R on each masked pair, and let the
      // instance matches replace the global ones inside the instances that gave enough of them.
      const auto props = nn::InstanceSegmenter(seggpt, o.segmenter).Propagate(ref, ref_masks, query);
      std::vector<matching::InstanceMasks> pairs;
      for (size_t i = 0; i < props.size(); ++i)
        if (props[i].kept) pairs.push_back({props[i].id, ref_masks[i].second, props[i].query_mask});
      std::vector<matching::InstanceResult> results;
      for (const auto& p : pairs) {
        results.push_back(matching::MatchInstance(ref, query, p, fn, instance));
        r->instances_used += results.back().used;
      }
      r->instances = static_cast<int>(ref_masks.size());
      merged = matching::MergeMatches(merged, results, pairs, ref.width, ref.height);
      r->instance_ms = Ms(t0);
    }
    for (const auto& m : merged) {
      c.ref.push_back(m.ref);
      c.query.push_back(m.query);
    }
    return c;
  } else {
    FREELOC_CHECK(pre != nullptr, "matcher " << o.matcher << " needs precomputed correspondences");
    for (const auto& v : *pre) {
      c.ref.emplace_back(v(0), v(1));
      c.query.emplace_back(v(2), v(3));
    }
  }
  r->match_ms = Ms(t0);
  return c;
}

void Relocalizer::Impl::Solve(const matching::Correspondences& c, const Camera& k_query, const DepthMap& d_query,
                              QueryResult* r) {
  const auto t0 = std::chrono::steady_clock::now();
  r->matches = static_cast<int>(c.size());
  const bool have_depth = !d_ref.empty() && !d_query.empty();
  if (o.solver == "essential") {
    if (c.size() < 5) {
      r->status = "too-few-matches";
      return;
    }
    geometry::RelativePoseOptions ro;
    if (o.threshold_px > 0) ro.threshold_px = o.threshold_px;
    const auto rel = geometry::EstimateRelativePose(c.ref, c.query, k_ref, k_query, ro);
    r->inliers = rel.status.num_inliers;
    if (!rel.status.success) {
      r->status = rel.status.reason;
      r->solve_ms = Ms(t0);
      return;
    }
    r->query_from_ref = rel.query_from_ref;
    r->confidence = rel.status.num_inliers;
    if (have_depth) {
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
      const double focal = 0.25 * (k_ref.fx + k_ref.fy + k_query.fx + k_query.fy);
      geometry::ScaleOptions so;
      so.method = geometry::ParseScaleMethod(o.scale);
      const auto s = geometry::EstimateMetricScale(a, b, rel.query_from_ref, d_ref, d_query, k_ref, k_query, so);
      r->scale_inliers = s.num_inliers;
      if (!s.success) {
        r->status = "scale-" + s.reason;
        r->solve_ms = Ms(t0);
        return;
      }
      r->query_from_ref.translation *= s.scale;
      r->confidence = s.confidence;  // official: the baseline's support count
      if (so.method == geometry::ScaleMethod::kRobust) {
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
    } else {
      r->status = "ok-unit-translation";
    }
    r->ok = true;
  } else {
    const auto m = o.solver == "pnp" ? geometry::EstimatePnP(c.ref, c.query, d_ref, k_ref, k_query)
                                     : geometry::EstimateProcrustes(c.ref, c.query, d_ref, d_query, k_ref, k_query);
    r->inliers = m.status.num_inliers;
    r->status = m.status.reason;
    r->ok = m.status.success;
    r->query_from_ref = m.query_from_ref;
    r->confidence = m.confidence;
  }
  r->solve_ms = Ms(t0);
}

QueryResult Relocalizer::Relocalize(const Image& image, const Camera& camera, DepthMap depth,
                                    const std::vector<Eigen::Vector4d>* pre, matching::Correspondences* matches) {
  Impl& m = *impl_;
  FREELOC_CHECK(m.have_ref, "Relocalizer::Relocalize before SetReference");
  QueryResult r;
  if (m.o.UsesProvidedDepth() && (m.d_ref.empty() || depth.empty())) {
    r.status = "no-depth";
    return r;
  }
  DepthMap d_query = m.o.UsesProvidedDepth() ? std::move(depth) : DepthMap();
  if (m.o.UsesMetric3d()) {
    const auto t0 = std::chrono::steady_clock::now();
    d_query = m.Estimate(image, camera);
    r.depth_ms = Ms(t0);
  }
  const matching::Correspondences c = m.Match(image, pre, &r);
  m.Solve(c, camera, d_query, &r);
  if (matches) *matches = c;
  m.stats.reference_encodings = m.dust3r_fn ? m.dust3r_fn->encoded() : 0;
  m.stats.reference_reuses = m.dust3r_fn ? m.dust3r_fn->reused() : 0;
  return r;
}

QueryResult RelocalizePair(const Image& ref, const Image& query, const Camera& k_ref, const Camera& k_query,
                           const DepthMap& d_ref, const DepthMap& d_query, const PipelineOptions& o,
                           const std::vector<Eigen::Vector4d>* pre, matching::Correspondences* matches) {
  Relocalizer r(o);
  r.SetReference(ref, k_ref, d_ref);
  return r.Relocalize(query, k_query, d_query, pre, matches);
}

std::vector<QueryResult> RelocalizeScene(const MapfreeScene& scene, const PipelineOptions& o, CacheStats* stats) {
  Relocalizer reloc(o);  // validates and loads the networks: a bad weights file stops the run here
  std::string suffix;
  std::vector<QueryResult> out;
  try {
    DepthMap d_ref;
    if (o.UsesProvidedDepth()) {
      suffix = o.depth.substr(9);
      if (std::filesystem::exists(scene.DepthPath(scene.reference, suffix))) {
        d_ref = scene.LoadDepth(scene.reference, suffix);
      } else {
        FREELOC_LOG(WARNING) << scene.name << ": no '" << suffix << "' depth for the reference ("
                             << scene.DepthPath(scene.reference, suffix) << "); every query fails";
      }
    }
    reloc.SetReference(scene.LoadImage(scene.reference), scene.reference.camera, std::move(d_ref));
  } catch (const Error& e) {
    // A missing or damaged reference fails the scene's queries; the run goes on.
    FREELOC_LOG(WARNING) << scene.name << ": reference " << scene.reference.name << ": " << e.what();
    for (const MapfreeFrame& q : scene.queries) {
      QueryResult r;
      r.frame = q.name;
      r.status = std::string("error: reference: ") + e.what();
      out.push_back(r);
    }
    if (stats) *stats = reloc.stats();
    return out;
  }
  std::vector<std::vector<Eigen::Vector4d>> pre;
  if (o.matcher.rfind("precomputed:", 0) == 0) pre = scene.LoadCorrespondences(o.matcher.substr(12));
  for (size_t i = 0; i < scene.queries.size(); ++i) {
    const MapfreeFrame& q = scene.queries[i];
    QueryResult r;
    try {
      DepthMap d_q;
      if (!suffix.empty() && std::filesystem::exists(scene.DepthPath(q, suffix))) d_q = scene.LoadDepth(q, suffix);
      r = reloc.Relocalize(scene.LoadImage(q), q.camera, std::move(d_q), pre.empty() ? nullptr : &pre[i]);
    } catch (const Error& e) {
      // A bad query (corrupt image, …) fails alone; the run goes on.
      r.status = std::string("error: ") + e.what();
      FREELOC_LOG(WARNING) << scene.name << "/" << q.name << ": " << e.what();
    }
    r.frame = q.name;
    out.push_back(r);
  }
  if (stats) *stats = reloc.stats();
  return out;
}

}  // namespace freeloc::pipeline
