// `freeloc run` and `freeloc demo`: the run controller (pipeline/run_controller.h) from the command line.
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/eval/report.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/relocalizer.h"
#include "freeloc/pipeline/run_comm.h"
#include "freeloc/pipeline/run_controller.h"
#include "freeloc/pipeline/run_fields.h"

#ifndef FREELOC_DEMO_DIR
#define FREELOC_DEMO_DIR "data/demo"
#endif

namespace freeloc::cli {

namespace {

// Ctrl-C (or SIGTERM) during a run: say where its progress is and how to go on, then end as the signal would (the
// journal is written scene by scene, so nothing more needs saving). The message is made before the run starts:
// only write() and _exit() run in the handler.
char g_interrupt_message[1024];
size_t g_interrupt_length = 0;
void OnInterrupt(int sig) {
  if (g_interrupt_length > 0) {
    const ssize_t written = ::write(STDERR_FILENO, g_interrupt_message, g_interrupt_length);
    (void)written;
  }
  ::_exit(128 + sig);
}
void InterruptHint(const std::string& progress) {
  const int n = std::snprintf(g_interrupt_message, sizeof(g_interrupt_message),
                              "\nfreeloc: interrupted; the finished scenes are in %s — rerun the same command with "
                              "--resume to continue\n",
                              progress.c_str());
  g_interrupt_length = n > 0 ? std::min(static_cast<size_t>(n), sizeof(g_interrupt_message) - 1) : 0;
  struct sigaction sa {};
  sa.sa_handler = OnInterrupt;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

struct RunArgs {
  PipelineArgs pipeline;
  std::map<std::string, std::string> run;  // the run family's fields as given (pipeline/run_fields.h)
};

// The run: an options file's run fields (its data, split, scenes, shard), then the flags given.
pipeline::RunSpec RunSpecOf(const RunArgs& a) {
  pipeline::RunSpec spec;
  if (!a.pipeline.options_file.empty())
    for (const auto& [name, value] : pipeline::ReadOptionsFile(a.pipeline.options_file).run)
      for (const FamilyField& f : pipeline::RunFamily().fields)
        if (f.name == name) pipeline::SetRunField(&spec, name, value);
  for (const auto& [name, value] : a.run) pipeline::SetRunField(&spec, name, value);
  FREELOC_OPTION_CHECK("data", !spec.data.empty(), " is required (or an options file that names it)");
  std::string split_dir;
  if (!spec.scenes.empty()) spec.scenes = pipeline::ResolveScenes(spec.data, spec.split, spec.scenes, &split_dir);
  return spec;
}

int RunRun(const RunArgs& a, const GlobalOptions& g) {
  // Launched by mpirun/srun: the ranks split the scenes and rank 0 writes the outputs (pipeline/run_comm.h).
  const std::unique_ptr<pipeline::RunComm> comm = pipeline::MpiCommFromEnvironment();
  const bool root = !comm || comm->rank() == 0;
  try {
    // Validated once, by ExecuteRun.
    const pipeline::PipelineOptions o =
        ResolvePipelineArgs(a.pipeline, g, "sift-essential", nullptr, /*validate=*/false);
    if (root) FREELOC_LOG(INFO) << o.Summary();
    const pipeline::RunSpec spec = RunSpecOf(a);
    const std::string progress = spec.out + ".progress.jsonl";
    std::error_code ec;
    if (root && !spec.resume && std::filesystem::exists(progress, ec))
      std::fprintf(stderr,
                   "freeloc: warning: %s holds an earlier run's progress; this run starts over and replaces it — "
                   "stop it now (Ctrl-C) and add --resume to continue that run instead\n",
                   SafeText(progress, 300).c_str());
    if (root) InterruptHint(progress);
    const pipeline::RunResult r = pipeline::ExecuteRun(spec, o, nullptr, comm.get());
    if (!root) return 0;
    std::printf("%zu of %zu queries solved in %zu %s, %zu submitted; submission written to %s\n", r.solved, r.queries,
                r.scenes.size(), r.scenes.size() == 1 ? "scene" : "scenes", r.submitted, spec.out.c_str());
    std::string statuses;
    for (const auto& [status, n] : r.statuses)
      statuses += (statuses.empty() ? "" : ", ") + status + " " + std::to_string(n);
    std::printf("statuses: %s\n", statuses.c_str());
    if (r.input_errors == 0) return 0;
    // Queries that failed on input errors (damaged or unreadable files): the submission is written (they carry the
    // prior pose), but the run says so and exits 3, so a script cannot mistake it for a clean run.
    std::fprintf(stderr, "freeloc: %zu of %zu queries failed on input errors (status error)%s:\n", r.input_errors,
                 r.queries, spec.log.empty() ? "" : (", every record in " + spec.log).c_str());
    for (const auto& m : r.input_error_messages) std::fprintf(stderr, "  %s\n", SafeText(m, 300).c_str());
    if (r.input_errors > r.input_error_messages.size())
      std::fprintf(stderr, "  … and %zu more%s\n", r.input_errors - r.input_error_messages.size(),
                   spec.log.empty() ? " (run with --log FILE for every record)" : "");
    return 3;
  } catch (const std::exception& e) {
    if (!comm) throw;
    // One rank cannot go on: say so once per rank and end every rank (none may wait for it forever).
    const auto* option = dynamic_cast<const OptionError*>(&e);
    std::fprintf(stderr, "freeloc: error: rank %d: %s\n", comm->rank(),
                 (option ? FlagMessage(*option) : std::string(e.what())).c_str());
    comm->Abort(1);
  }
  return 1;  // not reached: Abort ends the process
}

// The per-query table of the demo: status, inliers, rotation and camera-centre errors against the ground truth.
void PrintDemoTable(const pipeline::RunResult& r) {
  std::printf("| scene | query | status | inliers | rot err (°) | centre err (cm) |\n|---|---|---|---|---|---|\n");
  for (const auto& name : r.scenes) {
    const io::MapfreeScene& scene = r.loaded.at(name);
    for (const auto& q : r.results.at(name)) {
      const std::string status = ToString(q.status);
      if (!q.ok() || !scene.gt.count(q.frame)) {
        std::printf("| %s | %s | %s | %d | – | – |\n", name.c_str(), q.frame.c_str(), status.c_str(), q.inliers);
        continue;
      }
      const Rigid3d& gt = scene.gt.at(q.frame);
      std::printf("| %s | %s | %s | %d | %.3f | %.2f |\n", name.c_str(), q.frame.c_str(), status.c_str(), q.inliers,
                  RotationAngleDeg(q.query_from_ref.rotation, gt.rotation),
                  100 * (q.query_from_ref.Center() - gt.Center()).norm());
    }
  }
  std::printf("\n");
}

// The best preset whose weights are installed: the full method (seed) when all three networks are found.
std::string DemoPreset(const std::string& models, std::string* missing) {
  pipeline::PipelineOptions seed = pipeline::ResolvePreset("seed");
  seed.models.models_dir = models;
  pipeline::FindModels(&seed);
  if (seed.models.dust3r_model.empty()) *missing += " DUSt3R";
  if (seed.models.seggpt_model.empty()) *missing += " SegGPT";
  if (seed.models.metric3d_model.empty()) *missing += " Metric3D";
  return missing->empty() ? "seed" : "sift-essential";
}

int RunDemo(const std::string& data_dir, const std::string& models, const GlobalOptions& g) {
  std::string missing;
  PipelineArgs args;
  args.values["models_dir"] = models;
  const pipeline::PipelineOptions o =
      ResolvePipelineArgs(args, g, DemoPreset(models, &missing), nullptr, /*validate=*/false);  // by ExecuteRun
  std::printf("freeloc demo — preset %s on the bundled TUM RGB-D scenes (%s)\n", o.preset.c_str(), data_dir.c_str());
  std::printf("(%s)\n", o.Summary().c_str());
  if (!missing.empty())
    std::printf(
        "(the full method, preset seed, needs the DUSt3R, SegGPT and Metric3D weights; not found:%s. Put the\n"
        " published files in a folder and pass --models DIR or set FREELOC_MODELS; see docs/models.md)\n",
        missing.c_str());
  std::printf("\n");
  pipeline::RunSpec spec;
  spec.data = data_dir;
  spec.out = (std::filesystem::temp_directory_path() / ("freeloc_demo_" + std::to_string(getpid()) + ".zip")).string();
  const pipeline::RunResult r = pipeline::ExecuteRun(spec, o);
  PrintDemoTable(r);
  size_t estimated = 0;
  for (const auto& [name, results] : r.results)
    for (const auto& q : results) estimated += q.ok() ? 1 : 0;
  if (estimated > 0) {
    const eval::EvalRun run = eval::RunEvaluation(r.split_dir, r.scenes, spec.out);
    std::printf("%s", eval::MarkdownReport(run).c_str());
  } else {
    // Weights that match nothing (e.g. random test weights) give no consensus anywhere: say so, not a metric table.
    std::printf("(no query got a pose: the matches show no geometric consensus — no metrics to report)\n");
  }
  std::error_code ec;
  std::filesystem::remove(spec.out, ec);
  std::filesystem::remove(spec.out + ".json", ec);
  // What happened to the queries of a scene without depth maps (s00001 in the bundled demo), as it happened.
  for (const auto& name : r.scenes) {
    int no_depth = 0, submitted = 0;
    for (const auto& q : r.results.at(name))
      if (q.status == pipeline::QueryStatus::kNoDepth) {
        ++no_depth;
        submitted += q.submitted() ? 1 : 0;
      }
    if (no_depth == 0) continue;
    if (submitted == no_depth)
      std::printf(
          "\n(%s has no depth maps: its %d queries got no metric pose (status no-depth) and were submitted "
          "with the prior pose, the reference camera's, at confidence 0: the metrics score the evaluated ones "
          "(every 5th frame) as estimates with the prior's error, not as failures.)\n",
          name.c_str(), no_depth);
    else
      std::printf(
          "\n(%s has no depth maps: %d of its queries got no metric pose (status no-depth) and were left out "
          "of the submission; the metrics count them as failures.)\n",
          name.c_str(), no_depth - submitted);
  }
  return 0;
}

}  // namespace

void RegisterRun(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto a = std::make_shared<RunArgs>();
  auto* sub = app.add_subcommand("run", "Relocalize every query of every scene into a map-free submission ZIP");
  // The run family's flags (pipeline/run_fields.cc); --out is required, --data unless an options file names it.
  AddFamilyFlags(sub, pipeline::RunFamily(), &a->run, [](const std::string& name, const std::string& value) {
    pipeline::RunSpec scratch;
    pipeline::SetRunField(&scratch, name, value);
  });
  sub->get_option("--out")->required();
  AddPipelineArgs(sub, &a->pipeline, "sift-essential", /*stages=*/true, /*run=*/true);
  sub->callback([a, run, &global] {
    if (!a->run.count("data") && a->pipeline.options_file.empty())  // a usage error, as CLI11's own are
      throw CLI::RequiredError("--data (or --options FILE naming it)");
    *run = [a, &global] { return RunRun(*a, global); };
  });
}

void RegisterDemo(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto data = std::make_shared<std::string>(FREELOC_DEMO_DIR);
  auto models = std::make_shared<std::string>();
  auto* sub = app.add_subcommand("demo", "Relocalize the bundled TUM sample scenes and print errors and metrics");
  sub->add_option("--data", *data, "demo data (default: the repository's data/demo)");
  sub->add_option("--models", *models, "folder with the published weights (then $FREELOC_MODELS): runs preset seed");
  sub->callback(
      [data, models, run, &global] { *run = [data, models, &global] { return RunDemo(*data, *models, global); }; });
}

}  // namespace freeloc::cli
