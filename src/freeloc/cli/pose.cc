// `freeloc pose`: a pose from a correspondence file (`x_ref y_ref x_query y_query` per line, pixels) and each
// frame's intrinsics — essential matrix + metric scale from depth (or unit translation without depth), PnP or
// Procrustes.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/geometry/absolute_pose.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/io/pyparse.h"

namespace freeloc::cli {

namespace {

struct PoseOptions {
  std::string matches, ref_intr, query_intr, ref_depth, query_depth, solver = "essential", scale = "robust";
  double threshold = -1;
  bool json = false;
};

void ReadMatches(const std::string& path, std::vector<Eigen::Vector2d>* a, std::vector<Eigen::Vector2d>* b) {
  std::ifstream f(path);
  FREELOC_CHECK(f.good(), path << ": cannot open the correspondence file");
  std::string line;
  int ln = 0;
  while (std::getline(f, line)) {
    ++ln;
    const std::string s = py::Strip(line);
    if (s.empty() || s[0] == '#') continue;
    std::istringstream is(s);
    std::vector<double> v;
    std::string tok;
    while (is >> tok) {
      double x;
      FREELOC_CHECK(py::ParseFloat(tok, &x), path << " line " << ln << ": '" << tok << "' is not a number");
      v.push_back(x);
    }
    FREELOC_CHECK(v.size() == 4,
                  path << " line " << ln << ": expected 4 numbers 'x_ref y_ref x_query y_query', got " << v.size());
    FREELOC_CHECK(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]) && std::isfinite(v[3]),
                  path << " line " << ln << ": non-finite coordinate; remove NaN/inf rows");
    a->emplace_back(v[0], v[1]);
    b->emplace_back(v[2], v[3]);
  }
}

int RunPose(const PoseOptions& o) {
  const Camera kr = Camera::FromString(o.ref_intr, "--ref-intrinsics");
  const Camera kq = Camera::FromString(o.query_intr, "--query-intrinsics");
  std::vector<Eigen::Vector2d> a, b;
  ReadMatches(o.matches, &a, &b);
  const bool have_depth = !o.ref_depth.empty() && !o.query_depth.empty();
  FREELOC_CHECK(
      o.ref_depth.empty() == o.query_depth.empty() || o.solver == "pnp",
      "give both --ref-depth and --query-depth (or neither); only --solver pnp uses the reference depth alone");
  DepthMap dr, dq;
  if (!o.ref_depth.empty()) dr = ReadDepthPng(o.ref_depth);
  if (!o.query_depth.empty()) dq = ReadDepthPng(o.query_depth);

  Rigid3d pose;
  double confidence = 0;
  int inliers = 0;
  std::string status;
  bool metric = false;
  nlohmann::ordered_json st;
  if (o.solver == "essential") {
    geometry::RelativePoseOptions ro;
    if (o.threshold > 0) ro.threshold_px = o.threshold;
    const auto r = geometry::EstimateRelativePose(a, b, kr, kq, ro);
    pose = r.query_from_ref;
    inliers = r.status.num_inliers;
    confidence = inliers;
    status = r.status.reason;
    st = {{"matches", r.status.num_matches},
          {"iterations", r.status.iterations},
          {"local_optimizations", r.status.local_optimizations},
          {"stop_reason", r.status.stop_reason},
          {"refinement_cost", r.status.refinement_cost},
          {"time_ms", r.status.time_ms}};
    if (r.status.success && have_depth) {
      std::vector<Eigen::Vector2d> ia, ib;
      for (size_t i = 0; i < a.size(); ++i)
        if (r.inliers[i]) {
          ia.push_back(a[i]);
          ib.push_back(b[i]);
        }
      geometry::ScaleOptions so;
      so.method = geometry::ParseScaleMethod(o.scale);
      const auto s = geometry::EstimateMetricScale(ia, ib, r.query_from_ref, dr, dq, kr, kq, so);
      st["scale"] = {{"method", o.scale},
                     {"status", s.reason},
                     {"candidates", s.num_candidates},
                     {"inliers", s.num_inliers},
                     {"value", s.scale}};
      if (s.success) {
        pose.translation *= s.scale;
        confidence = s.confidence;
        metric = true;
      } else {
        status = "scale-" + s.reason;
      }
    }
  } else if (o.solver == "pnp" || o.solver == "procrustes") {
    FREELOC_CHECK(!dr.empty(), "--solver " << o.solver << " needs --ref-depth");
    geometry::MetricPoseResult r;
    if (o.solver == "pnp") {
      geometry::PnPOptions po;
      if (o.threshold > 0) po.threshold_px = o.threshold;
      r = geometry::EstimatePnP(a, b, dr, kr, kq, po);
    } else {
      FREELOC_CHECK(!dq.empty(), "--solver procrustes needs --query-depth too");
      r = geometry::EstimateProcrustes(a, b, dr, dq, kr, kq);
    }
    pose = r.query_from_ref;
    inliers = r.status.num_inliers;
    confidence = r.confidence;
    status = r.status.reason;
    metric = r.status.success;
    st = {{"matches", r.status.num_matches},
          {"iterations", r.status.iterations},
          {"stop_reason", r.status.stop_reason},
          {"time_ms", r.status.time_ms}};
  } else {
    FREELOC_THROW("--solver '" << o.solver << "' is unknown; use essential, pnp or procrustes");
  }
  const auto q = pose.QuaternionWxyz();
  if (o.json) {
    nlohmann::ordered_json j;
    j["qvec"] = {q[0], q[1], q[2], q[3]};
    j["tvec"] = {pose.translation.x(), pose.translation.y(), pose.translation.z()};
    j["confidence"] = confidence;
    j["num_inliers"] = inliers;
    j["status"] = status;
    j["metric"] = metric;
    j["solver"] = o.solver;
    j["details"] = st;
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("solver:      %s\n", o.solver.c_str());
    std::printf("status:      %s\n", status.c_str());
    std::printf("qvec (wxyz): %.9f %.9f %.9f %.9f\n", q[0], q[1], q[2], q[3]);
    std::printf("tvec:        %.6f %.6f %.6f %s\n", pose.translation.x(), pose.translation.y(), pose.translation.z(),
                metric ? "(metres)" : "(unit norm: no depth given, translation direction only)");
    std::printf("inliers:     %d of %zu\n", inliers, a.size());
    std::printf("confidence:  %.6g\n", confidence);
    std::printf("details:     %s\n", st.dump().c_str());
  }
  return status == "ok" ? 0 : 1;
}

}  // namespace

void RegisterPose(CLI::App& app, const GlobalOptions& /*global*/, RunFn* run) {
  auto o = std::make_shared<PoseOptions>();
  auto* sub = app.add_subcommand(
      "pose", "Estimate query_from_ref from a correspondence file (x_ref y_ref x_query y_query per line)");
  sub->add_option("--matches", o->matches, "correspondence file, pixels of each frame")->required();
  sub->add_option("--ref-intrinsics", o->ref_intr, "fx,fy,cx,cy of the reference frame")->required();
  sub->add_option("--query-intrinsics", o->query_intr, "fx,fy,cx,cy of the query frame")->required();
  sub->add_option("--ref-depth", o->ref_depth, "reference depth PNG (uint16 mm)");
  sub->add_option("--query-depth", o->query_depth, "query depth PNG (uint16 mm)");
  sub->add_option("--solver", o->solver, "essential (default), pnp or procrustes")
      ->check(CLI::IsMember({"essential", "pnp", "procrustes"}));
  sub->add_option("--scale", o->scale, "metric scale method for essential: robust (default) or official")
      ->check(CLI::IsMember({"official", "robust"}));
  sub->add_option("--threshold", o->threshold, "inlier threshold in pixels (default: 1 for essential, 3 for pnp)");
  sub->add_flag("--json", o->json, "one JSON object: qvec, tvec, confidence, num_inliers, status");
  sub->callback([o, run] { *run = [o] { return RunPose(*o); }; });
}

}  // namespace freeloc::cli
