// `freeloc demo` — PLACEHOLDER until the relocalization pipeline lands (issue: pipeline and CLI). It states what
// the demo will do and exits 0; this is the only placeholder the foundation allows.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "freeloc/cli/commands.h"

namespace freeloc::cli {

void RegisterDemo(CLI::App& app, const GlobalOptions& /*global*/, RunFn* run) {
  auto* sub = app.add_subcommand("demo",
                                 "Relocalize the bundled sample scenes and print the metrics "
                                 "(placeholder until the pipeline lands)");
  sub->callback([run] {
    *run = [] {
      std::printf(
          "freeloc demo: PLACEHOLDER — the relocalization pipeline has not landed yet.\n"
          "When it has, this command will:\n"
          "  1. load the TUM RGB-D sample scenes bundled in the repository (map-free layout, sensor depth),\n"
          "  2. relocalize every query against its reference with the best preset whose models are installed\n"
          "     (sift-essential without weights; the full seed method with DUSt3R, SegGPT and Metric3D),\n"
          "  3. evaluate the poses with the map-free metrics and print the per-query errors and the table.\n"
          "Available today: 'freeloc inspect FILE' lists a checkpoint's tensors and metadata.\n");
      return 0;
    };
  });
}

}  // namespace freeloc::cli
