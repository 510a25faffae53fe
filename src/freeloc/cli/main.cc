// freeloc — map-free metric relocalization. Entry point: global options, subcommand dispatch, error policy.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/version.h"

int main(int argc, char** argv) {
  using namespace freeloc;
  cli::GlobalOptions global;
  cli::RunFn run;

  CLI::App app{std::string("freeloc ") + Version() +
                   " — map-free metric relocalization: the pose of a query photo relative to a reference photo, in "
                   "metres.",
               "freeloc"};
  app.set_version_flag("--version", std::string("freeloc ") + Version());
  app.add_option("--threads", global.threads, "CPU threads for inference and geometry (default: library default)")
      ->check(CLI::PositiveNumber);
  app.add_option("--device", global.device, "where networks run: cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}));
  app.add_option("--precision", global.precision, "network arithmetic: fp32 (default, parity) or bf16")
      ->check(CLI::IsMember({"fp32", "bf16"}));
  auto* quiet = app.add_flag("-q,--quiet", global.quiet, "only errors; no progress bars");
  app.add_flag("-v,--verbose", global.verbose, "debug logging")->excludes(quiet);
  app.require_subcommand(1);
  app.fallthrough();

  cli::RegisterInspect(app, global, &run);
  cli::RegisterEval(app, global, &run);
  cli::RegisterPose(app, global, &run);
  cli::RegisterPointmap(app, global, &run);
  cli::RegisterMatch(app, global, &run);
  cli::RegisterSegment(app, global, &run);
  cli::RegisterDepth(app, global, &run);
  cli::RegisterRun(app, global, &run);
  cli::RegisterRelocalize(app, global, &run);
  cli::RegisterDemo(app, global, &run);
  cli::RegisterMerge(app, global, &run);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "freeloc: usage error: %s\nRun 'freeloc --help' for the commands and their options.\n",
                 e.what());
    return 2;
  }

  SetLogLevel(global.quiet ? LogLevel::kError : global.verbose ? LogLevel::kDebug : LogLevel::kInfo);
  if (global.threads > 0) {
    // Must be set before any threaded library initialises its pool (LibTorch/OpenMP, OpenBLAS).
    const std::string n = std::to_string(global.threads);
    setenv("OMP_NUM_THREADS", n.c_str(), 1);
    setenv("OPENBLAS_NUM_THREADS", n.c_str(), 1);
  }
  try {
    return run ? run() : 2;
  } catch (const Error& e) {
    std::fprintf(stderr, "freeloc: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "freeloc: error: %s\n", e.what());
    return 1;
  }
}
