// freeloc — map-free metric relocalization. Entry point: global options, subcommand dispatch, error policy.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "freeloc/cli/commands.h"
#include "freeloc/core/blas_select.h"
#include "freeloc/core/env.h"
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
  const char* off = freeloc::EnvSwitch("FREELOC_BLAS_SELECT");
  if (std::getenv("OPENBLAS_CORETYPE") || (off && std::strcmp(off, "0") == 0)) return;
  for (char** a = argv + 1; *a; ++a)
    if (std::strcmp(*a, "--check-args") == 0) return;  // nothing will run
  bool network = false;
  for (char** a = argv + 1; *a && !network; ++a)
    for (const char* c : {"pointmap", "segment", "depth", "match", "run", "relocalize", "demo"})
      network = network || std::strcmp(*a, c) == 0;
  if (!network) return;
  // FREELOC_BLAS_ASSUME_REPORTED (tests): act as if OpenBLAS had reported that core.
  const char* assume = freeloc::EnvSwitch("FREELOC_BLAS_ASSUME_REPORTED");
  const std::string reported = assume ? assume : freeloc::LoadedOpenBlasCore();
  const std::string pick = freeloc::ChooseOpenBlasCoretype(freeloc::ThisCpu(), reported);
  if (pick.empty()) return;
  setenv("OPENBLAS_CORETYPE", pick.c_str(), 1);
  setenv("FREELOC_BLAS_SELECTED", (reported + " -> " + pick).c_str(), 1);
  execv("/proc/self/exe", argv);  // returns only on failure
}

// Each command's --help ends with examples a user can adapt (the README's, docs/ for more).
void AddExamples(CLI::App& app) {
  static const std::pair<const char*, const char*> kExamples[] = {
      {"relocalize",
       "  freeloc relocalize --ref ref.jpg --query q.jpg --ref-intrinsics 535.4,539.2,320.1,247.6 \\\n"
       "      --query-intrinsics 535.4,539.2,320.1,247.6 --ref-depth ref.png --query-depth q.png\n"
       "  freeloc relocalize --ref phone_a.jpg --query phone_b.jpg --preset mast3r --models ~/models --json\n"
       "  freeloc relocalize --ref a.jpg --query b.jpg --ref-depth a_cm.png --query-depth b_cm.png --depth-unit cm"},
      {"pose",
       "  freeloc pose --matches m.txt --ref-intrinsics 535.4,539.2,320.1,247.6 --query-intrinsics "
       "535.4,539.2,320.1,247.6\n"
       "  freeloc pose --matches m.txt --ref-intrinsics 590,590,270,360 --query-intrinsics 590,590,270,360 \\\n"
       "      --ref-depth r.png --query-depth q.png --solver hybrid --json"},
      {"run",
       "  freeloc run --data mapfree --split val --preset sift-essential --out sub.zip --report report/\n"
       "  freeloc run --data mapfree --split test --preset seed --models ~/models --out seed.zip --resume\n"
       "  mpirun -np 4 freeloc run --data mapfree --split test --preset seed --out seed.zip"},
      {"eval",
       "  freeloc eval --data mapfree --submission sub.zip\n"
       "  freeloc eval --data mapfree --compare a.zip b.zip --report cmp/"},
      {"demo", "  freeloc demo\n  freeloc demo --models ~/models"},
      {"serve", "  freeloc serve --preset mast3r --models ~/models --port 8080 --store anchors/"},
      {"intrinsics", "  freeloc intrinsics phone_a.jpg phone_b.jpg --json"},
      {"options", "  freeloc options --preset seed\n  freeloc options --markdown"},
      {"merge", "  freeloc merge part1.zip part2.zip part3.zip part4.zip --out submission.zip"},
      {"inspect", "  freeloc inspect DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth --filter enc_norm"},
      {"pointmap",
       "  freeloc pointmap --model DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth ref.jpg q.jpg --out pm.safetensors "
       "--matches"},
      {"match",
       "  freeloc match --matcher mast3r --model MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric.pth ref.jpg "
       "q.jpg --out matches.txt"},
      {"segment",
       "  freeloc segment --model seggpt_vit_large.pth --prompt-image ref.jpg --prompt-mask cup.png --target "
       "q.jpg --out q_cup.png"},
      {"depth",
       "  freeloc depth --model metric_depth_vit_large_800k.pth --image q.jpg --intrinsics 590,590,270,360 "
       "--out q.depth.png"}};
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    for (const auto& [name, text] : kExamples)
      if (sub->get_name() == name) sub->footer(std::string("\nExamples:\n") + text);
}

// Levenshtein distance, for "did you mean": a typo of a command or a flag.
size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// The nearest of `names` to `typo` (within a third of its length, at least 2 edits), or "".
std::string Nearest(const std::string& typo, const std::vector<std::string>& names) {
  std::string best;
  size_t best_d = std::max<size_t>(2, typo.size() / 3) + 1;
  for (const auto& n : names)
    if (const size_t d = EditDistance(typo, n); d < best_d) {
      best_d = d;
      best = n;
    }
  return best;
}

// A usage error that names the unknown command or flag the user typed, with the nearest real one — CLI11 would say
// "A subcommand is required" for `freeloc relocalise` and "--query is required" for `--querry`. Empty: none found.
std::string UnknownNameMessage(CLI::App& app, int argc, char** argv) {
  std::vector<std::string> commands;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) commands.push_back(sub->get_name());
  CLI::App* sub = nullptr;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("-", 0) == 0) {
      // A global option's value follows it (--threads 2): skip it.
      const CLI::Option* o = app.get_option_no_throw(a.substr(0, a.find('=')));
      if (o && o->get_type_size() != 0 && a.find('=') == std::string::npos) ++i;
      continue;
    }
    for (CLI::App* c : app.get_subcommands([](CLI::App*) { return true; }))
      if (c->get_name() == a) sub = c;
    if (!sub) {
      const std::string near = Nearest(a, commands);
      return "unknown command '" + freeloc::SafeText(a, 60) + "'" +
             (near.empty() ? "" : "; did you mean '" + near + "'?");
    }
    // Its flags: the first unknown one, with the nearest of this command's (and the global) flags.
    std::vector<std::string> flags;
    for (const CLI::App* owner : {static_cast<const CLI::App*>(sub), static_cast<const CLI::App*>(&app)})
      for (const CLI::Option* o : owner->get_options())
        for (const std::string& n : o->get_lnames()) flags.push_back("--" + n);
    for (int j = i + 1; j < argc; ++j) {
      const std::string f = std::string(argv[j]).substr(0, std::string(argv[j]).find('='));
      if (f.rfind("--", 0) != 0 || f == "--") continue;
      if (std::find(flags.begin(), flags.end(), f) != flags.end()) continue;
      const std::string near = Nearest(f, flags);
      return "unknown flag '" + freeloc::SafeText(f, 60) + "' for " + a +
             (near.empty() ? "" : "; did you mean '" + near + "'?");
    }
    return "";
  }
  return "";
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
  std::string limit_names;  // the limits family (core/limits.h)
  for (const FamilyField& f : LimitsFamily().fields) limit_names += (limit_names.empty() ? "" : ", ") + f.name;
  std::string env_names;  // the environment family (core/env.h)
  for (const FamilyField& f : EnvironmentFamily().fields) env_names += (env_names.empty() ? "" : ", ") + f.name;
  app.footer("\nEnvironment: " + env_names +
             " (docs/formats.md \"Option families\"; freeloc options --family environment)");
  app.add_option("--limit", limits, "raise or lower an input limit, NAME=VALUE (" + limit_names + "; docs/formats.md)")
      ->check(CLI::Validator(
          [](std::string& l) {
            const size_t eq = l.find('=');
            if (eq == std::string::npos) return "expected NAME=VALUE, got '" + SafeText(l, 60) + "'";
            try {
              CheckLimit(l.substr(0, eq), l.substr(eq + 1));
            } catch (const Error& e) {
              const std::string m = e.what();
              return m.rfind("limit: ", 0) == 0 ? m.substr(7) : m;
            }
            return std::string();
          },
          "NAME=VALUE"));
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
  AddExamples(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // A value the parser refused names its flag already; the other errors (an extra word, a required flag missing)
    // usually come from a mistyped name: say which, with the nearest.
    const bool value_error =
        dynamic_cast<const CLI::ValidationError*>(&e) != nullptr || dynamic_cast<const CLI::ConversionError*>(&e);
    const std::string unknown = value_error ? std::string() : UnknownNameMessage(app, argc, argv);
    std::fprintf(stderr, "freeloc: usage error: %s\nRun 'freeloc --help' for the commands and their options.\n",
                 unknown.empty() ? e.what() : unknown.c_str());
    return 2;
  }

  if (check_args) {
    std::printf("freeloc: the command line is valid (--check-args: nothing was run)\n");
    return 0;
  }
  SetLogLevel(global.quiet ? LogLevel::kError : global.verbose ? LogLevel::kDebug : LogLevel::kInfo);
  if (global.verbose) {
    const std::string core = LoadedOpenBlasCore();
    const char* selected = freeloc::EnvSwitch("FREELOC_BLAS_SELECTED");
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
