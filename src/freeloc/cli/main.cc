// freeloc — map-free metric relocalization. Entry point: global options, subcommand dispatch, error policy.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "freeloc/cli/commands.h"
#include "freeloc/core/blas_select.h"
#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/version.h"

namespace {

// OpenBLAS picks its kernels when the process loads it, before main. On a CPU it does not know (it then runs generic
// SSE kernels, 3–5× slower), a command that runs networks executes itself again, once, with OPENBLAS_CORETYPE set to
// the kernels this CPU runs (core/blas_select.h). A user-set OPENBLAS_CORETYPE, or FREELOC_BLAS_SELECT=0, is left
// alone; if the exec fails the command goes on with the kernels it has.
void SelectBlasKernels(char** argv) {
  const char* off = std::getenv("FREELOC_BLAS_SELECT");
  if (std::getenv("OPENBLAS_CORETYPE") || (off && std::strcmp(off, "0") == 0)) return;
  for (char** a = argv + 1; *a; ++a)
    if (std::strcmp(*a, "--check-args") == 0) return;  // nothing will run
  bool network = false;
  for (char** a = argv + 1; *a && !network; ++a)
    for (const char* c : {"pointmap", "segment", "depth", "match", "run", "relocalize", "demo"})
      network = network || std::strcmp(*a, c) == 0;
  if (!network) return;
  // FREELOC_BLAS_ASSUME_REPORTED (tests): act as if OpenBLAS had reported that core.
  const char* assume = std::getenv("FREELOC_BLAS_ASSUME_REPORTED");
  const std::string reported = assume ? assume : freeloc::LoadedOpenBlasCore();
  const std::string pick = freeloc::ChooseOpenBlasCoretype(freeloc::ThisCpu(), reported);
  if (pick.empty()) return;
  setenv("OPENBLAS_CORETYPE", pick.c_str(), 1);
  setenv("FREELOC_BLAS_SELECTED", (reported + " -> " + pick).c_str(), 1);
  execv("/proc/self/exe", argv);  // returns only on failure
}

}  // namespace

int main(int argc, char** argv) {
  using namespace freeloc;
  SelectBlasKernels(argv);
  cli::GlobalOptions global;
  cli::RunFn run;

  CLI::App app{std::string("freeloc ") + Version() +
                   " — map-free metric relocalization: the pose of a query photo relative to a reference photo, in "
                   "metres.",
               "freeloc"};
  app.set_version_flag("--version", std::string("freeloc ") + Version());
  cli::AddGlobalFlags(&app, &global);  // --threads, --device, --precision: the option registry's global rows
  std::vector<std::string> limits;
  app.add_option("--limit", limits,
                 "raise or lower an input limit, NAME=VALUE (max_image_pixels, max_zip_member_bytes, "
                 "max_submission_bytes, max_tensors, max_pickle_objects; docs/formats.md)");
  bool check_args = false;
  app.add_flag("--check-args", check_args,
               "check the command line (the command, its flags and the values the parser checks) and exit "
               "without running anything: 0 when it is valid, 2 when not; preset, stage and --set values are "
               "checked when the command runs");
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
  cli::RegisterOptions(app, global, &run);
  cli::RegisterIntrinsics(app, global, &run);
  cli::RegisterServe(app, global, &run);

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

  if (check_args) {
    std::printf("freeloc: the command line is valid (--check-args: nothing was run)\n");
    return 0;
  }
  SetLogLevel(global.quiet ? LogLevel::kError : global.verbose ? LogLevel::kDebug : LogLevel::kInfo);
  if (global.verbose) {
    const std::string core = LoadedOpenBlasCore();
    const char* selected = std::getenv("FREELOC_BLAS_SELECTED");
    const char* user = std::getenv("OPENBLAS_CORETYPE");
    FREELOC_LOG(DEBUG) << "BLAS: "
                       << (core.empty() ? "not OpenBLAS (no core to select)" : "OpenBLAS, " + core + " kernels")
                       << (selected ? std::string(" (selected by freeloc: OpenBLAS reported ") + selected + " on " +
                                          ThisCpu().model_name + ")"
                           : user ? std::string(" (OPENBLAS_CORETYPE=") + user + " set by the user)"
                                  : std::string(" (OpenBLAS's own choice)"));
  }
  if (global.threads() > 0) {
    // Must be set before any threaded library initialises its pool (LibTorch/OpenMP, OpenBLAS).
    const std::string n = std::to_string(global.threads());
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
  } catch (const OptionError& e) {  // an option's error names its flag here (the library names the field)
    std::fprintf(stderr, "freeloc: error: %s\n", SafeText(cli::FlagMessage(e), 4000).c_str());
    return 1;
  } catch (const InputFixError& e) {  // the library names the option; here also its flag
    const std::string flag = cli::FlagOf(e.field());
    std::fprintf(stderr, "freeloc: error: %s [%s]\n", SafeText(e.what(), 4000).c_str(),
                 (flag == e.field() ? "--set " + e.field() + "=" + e.value() : flag + " " + e.value()).c_str());
    return 1;
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
