// The `freeloc` command line: one file per subcommand, each registering itself on the CLI11 app.
// Exit codes: 0 success, 1 input/runtime error, 2 usage error.
#pragma once

#include <functional>
#include <string>

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

// Each Register* adds a subcommand whose callback stores the function to run in `*run`.
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

}  // namespace freeloc::cli
