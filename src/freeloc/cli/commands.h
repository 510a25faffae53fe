// The `freeloc` command line: one file per subcommand, each registering itself on the CLI11 app. Subcommands only
// parse arguments, call the library (pipeline/, eval/, io/) and print (docs/architecture.md §3.2).
// Exit codes: 0 success, 1 input/runtime error, 2 usage error.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "freeloc/core/error.h"
#include "freeloc/core/option_family.h"
#include "freeloc/nn/runtime.h"
#include "freeloc/pipeline/options.h"

namespace CLI {
class App;
}

namespace freeloc::cli {

// The global flags (--threads, --device, --precision: the option registry's kGlobal rows) as given, by field name.
struct GlobalOptions {
  std::map<std::string, std::string> values;  // field → text as given (empty: not given)
  bool quiet = false;
  bool verbose = false;
  int threads() const;                 // 0 = library default
  nn::RuntimeOptions Runtime() const;  // typed through the option registry
};
// The registry's kGlobal rows as flags of `app`, checked as parsed (choices; counts positive).
void AddGlobalFlags(CLI::App* app, GlobalOptions* global);

// The pipeline's options as flags, generated from the option registry (pipeline/options.h): a preset, then the
// rows whose flag is offered to the command, and --set NAME=VALUE for any option field.
struct PipelineArgs {
  std::map<std::string, std::string> values;  // field → text as given (empty: the preset's)
  std::vector<std::string> sets;              // NAME=VALUE
  std::string options_file;                   // --options FILE: a run's provenance (pipeline::ReadOptionsFile)
};
// The kSolve rows; with `stages` also the kStages rows (matcher, depth, networks) — without them for a command
// given its correspondences and depth maps (pose); with `run` also the kRun rows (track, frames, device poses).
// The help shows `default_preset`'s values.
void AddPipelineArgs(CLI::App* sub, PipelineArgs* args, const std::string& default_preset, bool stages = true,
                     bool run = false);
// Preset, overrides, global runtime, `adjust` (a command's own rules), models found; validated when `validate`
// (false where the library entry point the command calls validates them itself: one validation per run).
pipeline::PipelineOptions ResolvePipelineArgs(const PipelineArgs& args, const GlobalOptions& global,
                                              const std::string& default_preset,
                                              const std::function<void(pipeline::PipelineOptions*)>& adjust = nullptr,
                                              bool validate = true);

// A family's fields (core/option_family.h) as flags of `sub` — each with its row's help and default, checked as
// parsed by `check(name, value)` (the family's setter on a scratch value: a usage error) — their values as given
// into `values` by field name ("1" for a switch given).
void AddFamilyFlags(CLI::App* sub, const OptionFamily& family, std::map<std::string, std::string>* values,
                    const std::function<void(const std::string&, const std::string&)>& check);

// The flag of an option field (the registry's, or a run field's: --data, --out, --log, --shard); `own` maps a
// command's own spellings first (match: dust3r_size → --size).
std::string FlagOf(const std::string& field, const std::map<std::string, std::string>& own = {});
// An option error as the command line says it: the flag, then the library's detail ("--solver: 'x' is not …").
std::string FlagMessage(const OptionError& e, const std::map<std::string, std::string>& own = {});

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
