// freeloc — map-free metric relocalization. Entry point: global options, subcommand dispatch, error policy.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
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
  std::vector<std::string> limits;
  app.add_option("--limit", limits,
                 "raise or lower an input limit, NAME=VALUE (max_image_pixels, max_zip_member_bytes, "
                 "max_submission_bytes, max_tensors, max_pickle_objects; docs/formats.md)");
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
    for (const auto& l : limits) {
      const size_t eq = l.find('=');
      if (eq == std::string::npos) throw Error("--limit: expected NAME=VALUE, got '" + SafeText(l) + "'");
      SetLimit(l.substr(0, eq), l.substr(eq + 1));
    }
    return run ? run() : 2;
  } catch (const Error& e) {
    std::fprintf(stderr, "freeloc: error: %s\n", SafeText(e.what(), 4000).c_str());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr,
                 "freeloc: error: out of memory; the input is larger than this machine can hold (see the limits in "
                 "docs/formats.md, or use a machine with more memory)\n");
    return 1;
  } catch (const std::exception& e) {
    // Foreign exceptions (LibTorch, OpenCV, the standard library): their first line only, never a backtrace.
    std::string what = e.what();
    what = what.substr(0, what.find('\n'));
    std::fprintf(stderr, "freeloc: error: %s\n", SafeText(what, 1000).c_str());
    return 1;
  }
}
