// `freeloc options`: every option field of the pipeline (the names `--set` and Python take), its flag, and its value
// — the defaults, or what a preset resolves to. `--markdown` prints the table docs/formats.md shows, from the same
// option table (pipeline/options.h), so the docs cannot drift from the code.
#include "freeloc/pipeline/options.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <memory>

#include "freeloc/cli/commands.h"

namespace freeloc::cli {

namespace {

struct OptionsArgs {
  std::string preset;
  bool markdown = false;
};

int RunOptions(const OptionsArgs& a) {
  if (a.markdown) {
    std::printf("%s", pipeline::OptionTableMarkdown().c_str());
    return 0;
  }
  const pipeline::PipelineOptions o =
      a.preset.empty() ? pipeline::PipelineOptions{} : pipeline::ResolvePreset(a.preset);
  size_t width = 0;
  for (const auto& f : pipeline::OptionFields()) width = std::max(width, std::string(f.name).size());
  std::printf("# options of preset %s (set any with --set NAME=VALUE; flags in brackets)\n", o.preset.c_str());
  for (const auto& f : pipeline::OptionFields()) {
    const std::string value = pipeline::GetOption(o, f.name);
    const std::string choices = f.choices.empty() ? "" : "; one of " + f.choices;
    std::printf("%-*s = %-24s # %s%s%s\n", static_cast<int>(width), f.name, value.empty() ? "\"\"" : value.c_str(),
                f.help, choices.c_str(), f.flag ? (std::string(" [") + f.flag + "]").c_str() : "");
  }
  return 0;
}

}  // namespace

void RegisterOptions(CLI::App& app, const GlobalOptions& /*global*/, RunFn* run) {
  auto a = std::make_shared<OptionsArgs>();
  auto* sub = app.add_subcommand("options", "List every pipeline option: name (for --set), value, meaning, flag");
  sub->add_option("--preset", a->preset, "show the values this preset resolves to (default: the defaults)");
  sub->add_flag("--markdown", a->markdown, "the option table as Markdown (as docs/formats.md shows it)");
  sub->callback([a, run] { *run = [a] { return RunOptions(*a); }; });
}

}  // namespace freeloc::cli
