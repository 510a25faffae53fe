#include "freeloc/pipeline/relocalizer.h"

#include <chrono>
#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/pipeline/models.h"

namespace freeloc::pipeline {

namespace {
double Ms(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
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
  // Building the stages loads their networks into the per-process caches.
  MakeMatcher(o);
  MakeDepthEstimator(o);
}

// ---------------------------------------------------------------------------------------------------------------
// The relocalizer: the stages, the reference's share once, the query's share per query.

struct Relocalizer::Impl {
  PipelineOptions o;
  std::unique_ptr<Matcher> matcher;
  std::unique_ptr<DepthEstimator> depth;
  std::unique_ptr<PoseSolver> solver;
  CacheStats stats;
  Camera k_ref;
  DepthMap d_ref;
  bool have_ref = false;
  void UpdateStats() {
    matcher->AddStats(&stats);
    depth->AddStats(&stats);
  }
};

Relocalizer::Relocalizer(const PipelineOptions& options)
    : Relocalizer(options, MakeMatcher(options), MakeDepthEstimator(options), MakePoseSolver(options)) {}

Relocalizer::Relocalizer(const PipelineOptions& options, std::unique_ptr<Matcher> matcher,
                         std::unique_ptr<DepthEstimator> depth, std::unique_ptr<PoseSolver> solver)
    : impl_(std::make_unique<Impl>()) {
  FREELOC_CHECK(matcher && depth && solver, "Relocalizer: every stage must be given");
  impl_->o = options;
  impl_->matcher = std::move(matcher);
  impl_->depth = std::move(depth);
  impl_->solver = std::move(solver);
}

Relocalizer::~Relocalizer() = default;
const CacheStats& Relocalizer::stats() const { return impl_->stats; }
const PipelineOptions& Relocalizer::options() const { return impl_->o; }

void Relocalizer::SetReference(const Image& image, const Camera& camera, DepthMap provided) {
  Impl& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  m.k_ref = camera;
  m.d_ref = m.depth->Depth(image, camera, std::move(provided));
  m.matcher->SetReference(image, camera);
  m.stats.reference_ms = Ms(t0);
  m.UpdateStats();
  m.have_ref = true;
}

QueryResult Relocalizer::Relocalize(const Image& image, const Camera& camera, DepthMap provided,
                                    const std::vector<Eigen::Vector4d>* pre, matching::Correspondences* matches) {
  Impl& m = *impl_;
  FREELOC_CHECK(m.have_ref, "Relocalizer::Relocalize before SetReference");
  QueryResult r;
  if (m.depth->needs_provided() && (m.d_ref.empty() || provided.empty())) {
    r.status = "no-depth";
    return r;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const DepthMap d_query = m.depth->Depth(image, camera, std::move(provided));
  r.depth_ms = m.depth->needs_provided() ? 0.0 : Ms(t0);
  const matching::Correspondences c = m.matcher->Match(image, camera, pre, &r);
  m.solver->Solve(c, m.k_ref, camera, m.d_ref, d_query, &r);
  if (matches) *matches = c;
  m.UpdateStats();
  return r;
}

QueryResult RelocalizePair(const Image& ref, const Image& query, const Camera& k_ref, const Camera& k_query,
                           const DepthMap& d_ref, const DepthMap& d_query, const PipelineOptions& o,
                           const std::vector<Eigen::Vector4d>* pre, matching::Correspondences* matches) {
  Relocalizer r(o);
  r.SetReference(ref, k_ref, d_ref);
  return r.Relocalize(query, k_query, d_query, pre, matches);
}

std::vector<QueryResult> RelocalizeScene(const MapfreeScene& scene, const PipelineOptions& o, CacheStats* stats,
                                         const std::function<void(const QueryResult&)>& on_query) {
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
      if (on_query) on_query(r);
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
    if (on_query) on_query(r);
  }
  if (stats) *stats = reloc.stats();
  return out;
}

}  // namespace freeloc::pipeline
