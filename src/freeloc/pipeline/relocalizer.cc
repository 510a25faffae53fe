#include "freeloc/pipeline/relocalizer.h"

#include <chrono>
#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/geometry/absolute_pose.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/matching/sift.h"
#include "freeloc/nn/runtime.h"
#include "freeloc/pipeline/dust3r_stage.h"

namespace freeloc::pipeline {

namespace {
double Ms(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::shared_ptr<nn::Dust3rModel> Dust3rOf(const PipelineOptions& o) {
  nn::RuntimeOptions rt;
  rt.device = o.device;
  rt.threads = o.threads;
  return CachedDust3r(o.dust3r_model, "", rt);
}
}  // namespace

void LoadModels(const PipelineOptions& o) {
  if (o.matcher == "dust3r") Dust3rOf(o);
}

void PipelineOptions::Validate() const {
  FREELOC_CHECK(matcher == "sift" || matcher == "dust3r" || matcher.rfind("precomputed:", 0) == 0,
                "--matcher '" << matcher << "' is not available; use sift, dust3r or precomputed:<name>");
  FREELOC_CHECK(matcher != "dust3r" || !dust3r_model.empty(),
                "--matcher dust3r needs --dust3r-model FILE (the official DUSt3R .pth or model.safetensors)");
  FREELOC_CHECK(dust3r_size >= 224, "--dust3r-size " << dust3r_size << " is too small; use 224 or 512");
  FREELOC_CHECK(depth == "none" || (depth.rfind("provided:", 0) == 0 && depth.size() > 9),
                "--depth '" << depth << "' is not available; use provided:<suffix> or none");
  FREELOC_CHECK(solver == "essential" || solver == "pnp" || solver == "procrustes",
                "--solver '" << solver << "' is unknown; use essential, pnp or procrustes");
  FREELOC_CHECK(solver == "essential" || depth != "none",
                "--solver " << solver << " needs depth (--depth provided:<suffix>)");
  geometry::ParseScaleMethod(scale);
}

std::string PipelineOptions::Summary() const {
  return "preset " + preset + ": matcher " + matcher + ", depth " + depth + ", solver " + solver +
         (solver == "essential" ? ", scale " + scale : "") +
         (threshold_px > 0 ? ", threshold " + std::to_string(threshold_px) + " px" : "") +
         (matcher == "dust3r" ? ", dust3r " + dust3r_model + " at " + std::to_string(dust3r_size) : "");
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
    o.Validate();
    return o;
  }
  if (name == "dust3r") {  // DUSt3R global matches, essential matrix, provided-depth scale (needs --dust3r-model)
    o.matcher = "dust3r";
    return o;
  }
  if (name == "seed" || name == "seed-no-instance" || name == "seed-provided-depth") {
    FREELOC_THROW("preset '" << name << "' needs the SegGPT instance and Metric3D depth stages, which are not wired "
                             << "into the pipeline in this version; they run on their own with 'freeloc segment' and "
                             << "'freeloc depth'. Presets available now: sift-essential, sift-pnp, sift-procrustes, "
                             << "dust3r, precomputed:<name>-<solver>");
  }
  FREELOC_THROW("--preset '" << name << "' is unknown; available: sift-essential, sift-pnp, sift-procrustes, dust3r, "
                             << "precomputed:<SIFT|SG|LoFTR>-<essential|pnp|procrustes>");
}

QueryResult RelocalizePair(const Image& ref, const Image& query, const Camera& k_ref, const Camera& k_query,
                           const DepthMap& d_ref, const DepthMap& d_query, const PipelineOptions& o,
                           const std::vector<Eigen::Vector4d>* pre) {
  QueryResult r;
  auto t0 = std::chrono::steady_clock::now();
  matching::Correspondences c;
  if (o.matcher == "sift") {
    c = matching::MatchSift(ref, query);
  } else if (o.matcher == "dust3r") {
    const matching::PointmapFn fn = Dust3rPointmapFn(Dust3rOf(o));
    Dust3rPreprocessOptions pp;
    pp.size = o.dust3r_size;
    const Dust3rInput a = PreprocessForDust3r(ref, pp), b = PreprocessForDust3r(query, pp);
    matching::ReciprocalOptions mo;
    mo.threads = o.threads;
    for (const auto& m : matching::GlobalCorrespondences(fn(a, b), a, b, mo)) {
      c.ref.push_back(m.ref);
      c.query.push_back(m.query);
    }
  } else {
    FREELOC_CHECK(pre != nullptr, "matcher " << o.matcher << " needs precomputed correspondences");
    for (const auto& v : *pre) {
      c.ref.emplace_back(v(0), v(1));
      c.query.emplace_back(v(2), v(3));
    }
  }
  r.match_ms = Ms(t0);
  r.matches = static_cast<int>(c.size());
  t0 = std::chrono::steady_clock::now();
  const bool have_depth = !d_ref.empty() && !d_query.empty();
  if (o.solver == "essential") {
    if (c.size() < 5) {
      r.status = "too-few-matches";
      return r;
    }
    geometry::RelativePoseOptions ro;
    if (o.threshold_px > 0) ro.threshold_px = o.threshold_px;
    const auto rel = geometry::EstimateRelativePose(c.ref, c.query, k_ref, k_query, ro);
    r.inliers = rel.status.num_inliers;
    if (!rel.status.success) {
      r.status = rel.status.reason;
      r.solve_ms = Ms(t0);
      return r;
    }
    r.query_from_ref = rel.query_from_ref;
    r.confidence = rel.status.num_inliers;
    if (have_depth) {
      std::vector<Eigen::Vector2d> a, b;
      for (size_t i = 0; i < c.size(); ++i)
        if (rel.inliers[i]) {
          a.push_back(c.ref[i]);
          b.push_back(c.query[i]);
        }
      geometry::ScaleOptions so;
      so.method = geometry::ParseScaleMethod(o.scale);
      const auto s = geometry::EstimateMetricScale(a, b, rel.query_from_ref, d_ref, d_query, k_ref, k_query, so);
      if (!s.success) {
        r.status = "scale-" + s.reason;
        r.solve_ms = Ms(t0);
        return r;
      }
      r.query_from_ref.translation *= s.scale;
      r.confidence = s.confidence;
      r.status = "ok";
    } else {
      r.status = "ok-unit-translation";
    }
    r.ok = true;
  } else {
    const auto m = o.solver == "pnp" ? geometry::EstimatePnP(c.ref, c.query, d_ref, k_ref, k_query)
                                     : geometry::EstimateProcrustes(c.ref, c.query, d_ref, d_query, k_ref, k_query);
    r.inliers = m.status.num_inliers;
    r.status = m.status.reason;
    r.ok = m.status.success;
    r.query_from_ref = m.query_from_ref;
    r.confidence = m.confidence;
  }
  r.solve_ms = Ms(t0);
  return r;
}

std::vector<QueryResult> RelocalizeScene(const MapfreeScene& scene, const PipelineOptions& o) {
  o.Validate();
  LoadModels(o);  // a bad weights file stops the run here instead of failing each query
  const Image ref = scene.LoadImage(scene.reference);
  DepthMap d_ref;
  std::string suffix;
  if (o.depth != "none") {
    suffix = o.depth.substr(9);
    if (std::filesystem::exists(scene.DepthPath(scene.reference, suffix))) {
      d_ref = scene.LoadDepth(scene.reference, suffix);
    } else {
      FREELOC_LOG(WARNING) << scene.name << ": no '" << suffix << "' depth for the reference; every query fails";
    }
  }
  std::vector<std::vector<Eigen::Vector4d>> pre;
  if (o.matcher.rfind("precomputed:", 0) == 0) pre = scene.LoadCorrespondences(o.matcher.substr(12));
  std::vector<QueryResult> out;
  for (size_t i = 0; i < scene.queries.size(); ++i) {
    const MapfreeFrame& q = scene.queries[i];
    QueryResult r;
    try {
      DepthMap d_q;
      if (!suffix.empty() && std::filesystem::exists(scene.DepthPath(q, suffix))) d_q = scene.LoadDepth(q, suffix);
      if (!suffix.empty() && (d_ref.empty() || d_q.empty())) {
        r.status = "no-depth";
      } else {
        r = RelocalizePair(ref, scene.LoadImage(q), scene.reference.camera, q.camera, d_ref, d_q, o,
                           pre.empty() ? nullptr : &pre[i]);
      }
    } catch (const Error& e) {
      // A bad query (corrupt image, …) fails alone; the run goes on.
      r.status = std::string("error: ") + e.what();
      FREELOC_LOG(WARNING) << scene.name << "/" << q.name << ": " << e.what();
    }
    r.frame = q.name;
    out.push_back(r);
  }
  return out;
}

}  // namespace freeloc::pipeline
