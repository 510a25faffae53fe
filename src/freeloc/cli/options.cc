// `freeloc options`: every option field of the pipeline (the names `--set` and Python take), its flag, and its value
// — the defaults, or what a preset resolves to. `--markdown` prints the table docs/formats.md shows, from the same
// option table (pipeline/options.h), so the docs cannot drift from the code; `--family` the other families (run,
// service, limits, environment: core/option_family.h) the same way.
#include "freeloc/pipeline/options.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "freeloc/cli/commands.h"
#include "freeloc/core/env.h"
#include "freeloc/core/limits.h"
#include "freeloc/pipeline/run_fields.h"
#include "freeloc/service/service_fields.h"

namespace freeloc::cli {

namespace {

struct OptionsArgs {
  std::string preset;
  std::string family;
  bool markdown = false, json = false;
};

// The option families besides the pipeline's (core/option_family.h), by name.
const OptionFamily& Family(const std::string& name) {
  if (name == "run") return pipeline::RunFamily();
  if (name == "service") return service::ServiceFamily();
  if (name == "limits") return LimitsFamily();
  if (name == "environment") return EnvironmentFamily();
  throw OptionError("family",
                    ": '" + SafeText(name, 40) + "' is not one of pipeline, run, service, limits, environment");
}

int RunFamilyListing(const OptionsArgs& a) {
  const OptionFamily& f = Family(a.family);
  if (a.json) {
    nlohmann::ordered_json j = {{"name", f.name}, {"set_by", f.set_by}, {"fields", nlohmann::ordered_json::array()}};
    for (const FamilyField& x : f.fields)
      j["fields"].push_back({{"name", x.name},
                             {"flag", x.flag},
                             {"type", FieldTypeText(x.type)},
                             {"default", x.default_text},
                             {"help", x.help}});
    std::printf("%s\n", j.dump().c_str());
  } else if (a.markdown) {
    std::printf("%s", FamilyMarkdown(f).c_str());
  } else {
    std::printf("# %s options (set by %s)\n", f.name.c_str(), f.set_by.c_str());
    for (const FamilyField& x : f.fields)
      std::printf("%-22s %-22s %s%s\n", x.name.c_str(), x.flag.c_str(), x.help.c_str(),
                  x.default_text.empty() ? "" : (" (default " + x.default_text + ")").c_str());
  }
  return 0;
}

int RunOptions(const OptionsArgs& a) {
  if (!a.family.empty() && a.family != "pipeline") return RunFamilyListing(a);
  if (a.json) {
    nlohmann::ordered_json j = {{"name", "pipeline"}, {"fields", nlohmann::ordered_json::array()}};
    for (const auto& f : pipeline::OptionFields())
      j["fields"].push_back({{"name", f.name}, {"flag", f.flag ? f.flag : ""}, {"help", f.help}});
    std::printf("%s\n", j.dump().c_str());
    return 0;
  }
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
  auto* sub = app.add_subcommand(
      "options", "List every pipeline option: name (for --set), value, meaning, flag (--family: the other families)");
  sub->add_option("--preset", a->preset, "show the values this preset resolves to (default: the defaults)");
  sub->add_option("--family", a->family,
                  "another option family: run, service, limits or environment (default: the pipeline's)")
      ->check(CLI::IsMember({"pipeline", "run", "service", "limits", "environment"}));
  sub->add_flag("--markdown", a->markdown, "the option table as Markdown (as docs/formats.md shows it)");
  sub->add_flag("--json", a->json, "the family's fields as JSON (name, flag, type, default, help)");
  sub->callback([a, run] { *run = [a] { return RunOptions(*a); }; });
}

}  // namespace freeloc::cli
