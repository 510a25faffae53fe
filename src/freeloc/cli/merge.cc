// `freeloc merge`: joins the submissions of `freeloc run --shard i/n` into one submission ZIP.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <map>
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
  std::map<std::string, std::string> files, owner;  // entry → bytes, entry → the input it came from
  for (const auto& path : m.inputs) {
    const ZipContents zip = ZipContents::Read(path);
    for (const auto& name : zip.names) {
      FREELOC_CHECK(name.size() > 9 && name.rfind("pose_", 0) == 0 && name.substr(name.size() - 4) == ".txt",
                    path << ": entry '" << name << "' is not a pose_<scene>.txt file; merge only submission ZIPs");
      FREELOC_CHECK(!owner.count(name), path << ": " << name << " is also in " << owner[name]
                                             << "; the inputs must be disjoint shards of one run");
      owner[name] = path;
      files[name] = zip.files.at(name);
    }
  }
  WriteZipAtomic(m.out, files);
  std::printf("merged %zu scenes from %zu submissions into %s\n", files.size(), m.inputs.size(), m.out.c_str());
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
