// The `freeloc` command line: one file per subcommand, each registering itself on the CLI11 app.
// Exit codes: 0 success, 1 input/runtime error, 2 usage error.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "freeloc/matching/sift.h"

namespace CLI {
class App;
}

namespace freeloc::cli {

struct GlobalOptions {
  int threads = 0;             // 0 = library default
  std::string device = "cpu";  // cpu | cuda
  bool quiet = false;
  bool verbose = false;
};

// The split folder under --data (or --data itself) and the scenes to process: all of them, or the
// comma-separated --scenes list (each must exist). Throws freeloc::Error naming what is missing.
std::vector<std::string> ResolveScenes(const std::string& data, const std::string& split, const std::string& scenes_csv,
                                       std::string* split_dir);

// Writes a correspondence file (docs/formats.md: `x_ref y_ref x_query y_query` per line, original pixels), the
// input of `freeloc pose`; atomically.
void WriteCorrespondences(const std::string& path, const matching::Correspondences& c);

// Each Register* a subcommand whose callback stores the function to run in `*run`.
using RunFn = std::function<int()>;
void RegisterInspect(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterEval(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterPose(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterPointmap(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterMatch(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterSegment(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterDepth(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterRun(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterDemo(CLI::App& app, const GlobalOptions& global, RunFn* run);
void RegisterMerge(CLI::App& app, const GlobalOptions& global, RunFn* run);

}  // namespace freeloc::cli
