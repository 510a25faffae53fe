// `freeloc pose`: a pose from a correspondence file (`x_ref y_ref x_query y_query` per line, pixels) and each
// frame's intrinsics, by the pipeline's PoseSolver — the same solver, status and confidence `freeloc run` gives for
// the same correspondences, depths and options (`run --save-matches` writes its correspondences in this format).
#include <CLI/CLI.hpp>
#include <cstdio>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/correspondence_file.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/relocalizer.h"
#include "freeloc/pipeline/stages.h"

namespace freeloc::cli {

namespace {

struct PoseArgs {
  PipelineArgs pipeline;
  std::string matches, ref_intr, query_intr, ref_depth, query_depth;
  bool json = false;
};

// Without --preset: pipeline::CorrespondenceDefaults (precomputed:SIFT-essential, as a run on the benchmark's
// correspondences); the correspondences are the file's, depth the files given (provided) or none.
pipeline::PipelineOptions Options(const PoseArgs& a, const GlobalOptions& g) {
  return ResolvePipelineArgs(
      a.pipeline, g, pipeline::CorrespondenceDefaults().preset, [&](pipeline::PipelineOptions* o) {
        *o = pipeline::ForCorrespondences(*o, !a.ref_depth.empty());
        FREELOC_CHECK(
            a.ref_depth.empty() == a.query_depth.empty() || o->solver == pipeline::SolverKind::kPnp,
            "give both --ref-depth and --query-depth (or neither); only --solver pnp uses the reference depth "
            "alone");
      });
}

void PrintText(const pipeline::QueryResult& q, const pipeline::PipelineOptions& o) {
  const auto qv = q.query_from_ref.QuaternionWxyz();
  const auto& t = q.query_from_ref.translation;
  std::printf("%s\n", o.Summary().c_str());
  std::printf("status:      %s\n", q.StatusText().c_str());
  std::printf("qvec (wxyz): %.9f %.9f %.9f %.9f\n", qv[0], qv[1], qv[2], qv[3]);
  std::printf("tvec:        %.6f %.6f %.6f %s\n", t.x(), t.y(), t.z(),
              q.metric()  ? "(metres)"
              : q.prior() ? "(the prior pose, submitted with confidence 0: not solved)"
              : q.weak()  ? "(weak support: a low-confidence answer, ranked below every ok one)"
                          : "(unit norm: no depth given, translation direction only)");
  std::printf("inliers:     %d of %d (%d agree on the scale)\n", q.inliers, q.matches, q.scale_inliers);
  std::printf("confidence:  %.6g\n", q.confidence);
  for (const std::string& note : q.input_notes) std::printf("inputs:      %s\n", note.c_str());
}

int RunPose(const PoseArgs& a, const GlobalOptions& g) {
  const pipeline::PipelineOptions o = Options(a, g);
  const Camera kr = Camera::FromString(a.ref_intr, "--ref-intrinsics");
  const Camera kq = Camera::FromString(a.query_intr, "--query-intrinsics");
  const matching::Correspondences c = matching::Correspondences::FromRows(io::ReadCorrespondenceFile(a.matches));
  DepthMap dr, dq;
  if (!a.ref_depth.empty()) dr = io::ReadDepthPng(a.ref_depth);
  if (!a.query_depth.empty()) dq = io::ReadDepthPng(a.query_depth);
  const pipeline::QueryResult q = pipeline::SolveCorrespondences(c, kr, kq, std::move(dr), std::move(dq), o);
  if (a.json) {
    std::printf("%s\n", pipeline::QueryRecordJson("", q, &o, 2).c_str());
  } else {
    PrintText(q, o);
  }
  return q.ok() ? 0 : 1;
}

}  // namespace

void RegisterPose(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto a = std::make_shared<PoseArgs>();
  auto* sub = app.add_subcommand(
      "pose", "Estimate query_from_ref from a correspondence file (x_ref y_ref x_query y_query per line)");
  sub->add_option("--matches", a->matches, "correspondence file, pixels of each frame")->required();
  sub->add_option("--ref-intrinsics", a->ref_intr, "fx,fy,cx,cy of the reference frame")->required();
  sub->add_option("--query-intrinsics", a->query_intr, "fx,fy,cx,cy of the query frame")->required();
  sub->add_option("--ref-depth", a->ref_depth, "reference depth PNG (uint16 mm)");
  sub->add_option("--query-depth", a->query_depth, "query depth PNG (uint16 mm)");
  sub->add_flag("--json", a->json, "one JSON record (docs/formats.md) with the resolved options");
  // Without --preset the benchmark's correspondence baseline; with a run's --preset (and its saved matches) the
  // answer that run gave.
  AddPipelineArgs(sub, &a->pipeline, pipeline::CorrespondenceDefaults().preset, /*networks=*/false);
  sub->callback([a, run, &global] { *run = [a, &global] { return RunPose(*a, global); }; });
}

}  // namespace freeloc::cli
