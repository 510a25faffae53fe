// `freeloc merge`: joins the submissions of `freeloc run --shard i/n` into one submission ZIP.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/submission.h"

namespace freeloc::cli {

namespace {

struct MergeOptions {
  std::vector<std::string> inputs;
  std::string out;
};

int RunMerge(const MergeOptions& m) {
  const size_t scenes = io::MergeSubmissions(m.inputs, m.out);
  std::printf("merged %zu scenes from %zu submissions into %s\n", scenes, m.inputs.size(), m.out.c_str());
  return 0;
}

}  // namespace

void RegisterMerge(CLI::App& app, const GlobalOptions& /*global*/, RunFn* run) {
  auto m = std::make_shared<MergeOptions>();
  auto* sub = app.add_subcommand("merge", "Join the submission ZIPs of sharded runs into one (scenes must not repeat)");
  sub->add_option("inputs", m->inputs, "submission ZIPs from freeloc run --shard")->required();
  sub->add_option("--out", m->out, "merged submission ZIP (written atomically)")->required();
  sub->callback([m, run] { *run = [m] { return RunMerge(*m); }; });
}

}  // namespace freeloc::cli
