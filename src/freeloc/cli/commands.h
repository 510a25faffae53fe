// The `freeloc` command line: one file per subcommand, each registering itself on the CLI11 app. Subcommands only
// parse arguments, call the library (pipeline/, eval/, io/) and print (docs/architecture.md §3.2).
// Exit codes: 0 success, 1 input/runtime error, 2 usage error.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "freeloc/nn/runtime.h"
#include "freeloc/pipeline/options.h"

namespace CLI {
class App;
}

namespace freeloc::cli {

struct GlobalOptions {
  int threads = 0;                // 0 = library default
  std::string device = "cpu";     // cpu | cuda
  std::string precision = "fp32"; // fp32 | bf16
  bool quiet = false;
  bool verbose = false;
  nn::RuntimeOptions Runtime() const;  // typed; throws naming the flag
};

// The pipeline's options as flags, shared by run, relocalize, pose and match: a preset, then per-field overrides
// (--matcher, --depth, --solver, …, and --set NAME=VALUE for any option field).
struct PipelineArgs {
  std::string preset;  // empty: the command's default
  std::string matcher, depth, solver, scale, instance_mode;
  std::string models, dust3r_model, dust3r_config, mast3r_model, seggpt_model, metric3d_model;
  double threshold = -1;
  int dust3r_size = 0;
  std::vector<std::string> sets;  // NAME=VALUE
};
// `networks`: also the stage and network flags (--matcher, --depth, --models, --dust3r, …); without them, for a
// command given its correspondences and depth maps (pose). The help shows `default_preset`'s values.
void AddPipelineArgs(CLI::App* sub, PipelineArgs* args, const std::string& default_preset, bool networks = true);
// Preset, overrides, global runtime, `adjust` (a command's own rules), models found; validated. Errors name the
// flag ("--solver: …").
pipeline::PipelineOptions ResolvePipelineArgs(const PipelineArgs& args, const GlobalOptions& global,
                                              const std::string& default_preset,
                                              const std::function<void(pipeline::PipelineOptions*)>& adjust = nullptr);
// Runs `fn`; a freeloc::Error whose message names an option field is rethrown with the field's flag.
pipeline::PipelineOptions WithFlagNames(const std::function<pipeline::PipelineOptions()>& fn);
// The message with a leading option field ("depth provided:x: …", "solver: …") replaced by its flag.
std::string NameFlags(std::string message);

// The scenes of `data`/`split` (all, or the comma-separated `scenes_csv`); see pipeline::ResolveScenes.
std::vector<std::string> ResolveScenes(const std::string& data, const std::string& split, const std::string& scenes_csv,
                                       std::string* split_dir);

// Each Register* a subcommand whose callback stores the function to run in `*run`.
using RunFn = std::function<int()>;
void RegisterInspect(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterEval(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterPose(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterPointmap(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterMatch(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterOptions(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterSegment(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterDepth(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterRun(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterRelocalize(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterDemo(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterMerge(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterIntrinsics(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterServe(CLI::App& app, const GlobalOptions& global, RunFn* run);

}  // namespace freeloc::cli

namespace freeloc::cli {
// An instance label PNG (8 or 16 bit; 0 = background, k = instance k) that must be `width`×`height`.
std::vector<uint16_t> ReadLabels(const std::string& path, int width, int height);
// Masks given on the command line: both frames' labels → instance_source given; the reference's only → its
// instances are propagated by SegGPT. Throws when the matcher takes no instances.
void ApplyMaskArgs(pipeline::PipelineOptions* o, bool ref_masks, bool query_masks);
}  // namespace freeloc::cli
