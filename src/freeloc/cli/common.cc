// Helpers shared by the subcommands: the option registry's rows as flags, flags in option errors, scene lists.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/relocalizer.h"
#include "freeloc/pipeline/run_controller.h"

namespace freeloc::cli {

namespace {

// Fields that are not pipeline options: the run controller's (pipeline/run_controller.h RunSpec), flags of `run`
// alone, and --set itself.
const std::map<std::string, std::string>& RunFlags() {
  static const std::map<std::string, std::string> flags = {
      {"data", "--data"}, {"out", "--out"}, {"log", "--log"}, {"shard", "--shard"}, {"set", "--set"}};
  return flags;
}

}  // namespace

std::string FlagOf(const std::string& field, const std::map<std::string, std::string>& own) {
  if (const auto it = own.find(field); it != own.end()) return it->second;
  if (const pipeline::OptionField* f = pipeline::FindOptionFieldOrNull(field); f && f->flag) return f->flag;
  if (const auto it = RunFlags().find(field); it != RunFlags().end()) return it->second;
  return field;  // a field without a flag: --set NAME=…
}

std::string FlagMessage(const OptionError& e, const std::map<std::string, std::string>& own) {
  return FlagOf(e.field(), own) + e.detail();
}

namespace {

// Names that become file names (precomputed:<name>[-<solver>], provided:<suffix>) are checked as the flag is parsed:
// a path there is a usage error (exit 2), never a file opened outside the scene.
CLI::Validator FileNameParts() {
  return CLI::Validator(
      [](std::string& v) {
        const size_t colon = v.find(':');
        if (colon == std::string::npos) return std::string();
        const std::string head = v.substr(0, colon);
        std::string name = v.substr(colon + 1);
        if (head == "precomputed" && name.find('-') != std::string::npos && name.find('/') == std::string::npos)
          name = name.substr(0, name.rfind('-'));  // a preset's precomputed:<name>-<solver>
        if ((head == "precomputed" || head == "provided") && !pipeline::IsFileNamePart(name))
          return "'" + name + "' names a file: letters, digits, '_', '-', '.' or '+' only, not a path";
        return std::string();
      },
      "NAME");
}

// Numbers given as flags are counts and sizes: positive — or, for a field whose default is `default` (the
// component's own value: --threshold default, the solver's), that word (or -1, its older spelling) — checked as
// parsed (a usage error, exit 2); each field's own range is the registry's validation.
CLI::Validator Positive(pipeline::OptionType type, const std::string& own) {
  return CLI::Validator(
      [type, own](std::string& v) {
        if (own == "default" && (v == own || v == "-1")) return std::string();
        char* end = nullptr;
        errno = 0;
        const double x = type == pipeline::OptionType::kInt ? static_cast<double>(std::strtol(v.c_str(), &end, 10))
                                                            : std::strtod(v.c_str(), &end);
        const bool ok = end && end != v.c_str() && *end == 0 && errno == 0 && std::isfinite(x) && x > 0;
        return ok ? std::string()
                  : std::string(type == pipeline::OptionType::kInt ? "must be a positive integer"
                                                                   : "must be a positive number") +
                        (own == "default" ? " (or default)" : "");
      },
      type == pipeline::OptionType::kInt ? "N" : "X");
}

// One registry row as a flag of `app`: its spelling(s), its help with its choices and the default preset's value,
// and the checks made as it is parsed.
void AddOptionFlag(CLI::App* app, const pipeline::OptionField& f, std::string* value,
                   const pipeline::PipelineOptions* defaults) {
  std::string names = f.flag;
  if (f.alias) names += std::string(",") + f.alias;
  std::string help = f.help;
  if (!f.choices.empty()) help += "; one of " + f.choices;
  if (defaults) {
    const std::string d = pipeline::GetOption(*defaults, f.name);
    if (!d.empty() && d != "default") help += " (default " + d + ")";
  }
  CLI::Option* opt = app->add_option(names, *value, help);
  if (f.type != pipeline::OptionType::kText) {
    opt->check(Positive(f.type, pipeline::GetOption(pipeline::PipelineOptions(), f.name)));
    // The field's own range (the registry's validation) as parsed, so that --check-args and a typo fail alike.
    const std::string field = f.name;
    opt->check(CLI::Validator(
        [field](std::string& v) {
          try {
            pipeline::PipelineOptions o;
            pipeline::SetOption(&o, field, v);
            o.Validate();
          } catch (const Error& e) {
            const std::string m = e.what();  // "field: …": the flag names it already
            return m.rfind(field + ": ", 0) == 0 ? m.substr(field.size() + 2) : m;
          }
          return std::string();
        },
        "RANGE"));
  }
  if (std::string(f.name) == "preset" || std::string(f.name) == "matcher" || std::string(f.name) == "depth")
    opt->check(FileNameParts());
  // A fixed set of choices (not matcher/depth, which take a name after a colon) is checked as parsed: a usage error.
  if (!f.choices.empty() && f.choices.find('<') == std::string::npos) {
    std::vector<std::string> choices;
    std::stringstream ss(f.choices);
    for (std::string c; std::getline(ss, c, ',');) choices.push_back(c.substr(c.find_first_not_of(' ')));
    const std::string listed = f.choices;
    opt->check(CLI::Validator(
        [choices, listed](std::string& v) {
          return std::find(choices.begin(), choices.end(), v) != choices.end()
                     ? std::string()
                     : "'" + SafeText(v, 40) + "' is not one of " + listed;
        },
        "CHOICE"));
  }
}

}  // namespace

void AddGlobalFlags(CLI::App* app, GlobalOptions* global) {
  for (const pipeline::OptionField& f : pipeline::OptionFields())
    if (f.flag && f.scope == pipeline::FlagScope::kGlobal) AddOptionFlag(app, f, &global->values[f.name], nullptr);
}

int GlobalOptions::threads() const { return Runtime().threads; }

nn::RuntimeOptions GlobalOptions::Runtime() const {
  pipeline::PipelineOptions o;
  for (const auto& [field, value] : values)
    if (!value.empty()) pipeline::SetOption(&o, field, value);
  return o.runtime;
}

void AddPipelineArgs(CLI::App* sub, PipelineArgs* a, const std::string& default_preset, bool stages, bool run) {
  const pipeline::PipelineOptions d = pipeline::ResolvePreset(default_preset);
  for (const pipeline::OptionField& f : pipeline::OptionFields()) {
    if (!f.flag) continue;
    const bool offered = f.scope == pipeline::FlagScope::kSolve ||
                         (stages && f.scope == pipeline::FlagScope::kStages) ||
                         (run && f.scope == pipeline::FlagScope::kRun);
    if (!offered) continue;
    if (std::string(f.name) == "preset") {
      std::string presets;
      for (const std::string& p : pipeline::PresetNames()) presets += (presets.empty() ? "" : ", ") + p;
      sub->add_option(f.flag, a->values[f.name], "default " + default_preset + "; one of " + presets)
          ->check(FileNameParts());
      continue;
    }
    AddOptionFlag(sub, f, &a->values[f.name], &d);
  }
  sub->add_option("--options", a->options_file,
                  "an options file: a run's <out>.json (or its log, or a --json record) — its options, then the flags "
                  "given here over them");
  sub->add_option("--set", a->sets,
                  "override any option field: NAME=VALUE (`freeloc options` lists them with their defaults)")
      ->check(CLI::Validator(
          [](std::string& s) {
            const size_t eq = s.find('=');
            if (eq == std::string::npos || eq == 0) return "'" + SafeText(s, 60) + "' is not NAME=VALUE";
            if (s.substr(0, eq) == "preset")
              return std::string("preset is chosen with --preset (it sets every stage), not --set");
            try {  // the name, the value's type and the field's range, as parsed
              pipeline::PipelineOptions o;
              pipeline::SetOption(&o, s.substr(0, eq), s.substr(eq + 1));
              o.Validate();
            } catch (const Error& e) {
              return std::string(e.what());
            }
            return std::string();
          },
          "NAME=VALUE"));
}

pipeline::PipelineOptions ResolvePipelineArgs(const PipelineArgs& a, const GlobalOptions& g,
                                              const std::string& default_preset,
                                              const std::function<void(pipeline::PipelineOptions*)>& adjust,
                                              bool validate) {
  const auto given = [&a](const char* field) {
    const auto it = a.values.find(field);
    return it == a.values.end() ? std::string() : it->second;
  };
  // An options file: its preset (unless one is given), then its values, then the flags given.
  pipeline::OptionsFile file;
  if (!a.options_file.empty()) file = pipeline::ReadOptionsFile(a.options_file);
  const std::string preset = !given("preset").empty()       ? given("preset")
                             : file.options.count("preset") ? file.options.at("preset")
                                                            : default_preset;
  pipeline::PipelineOptions o = pipeline::ResolvePreset(preset);
  for (const pipeline::OptionField& f : pipeline::OptionFields()) {  // in registry order
    const auto it = file.options.find(f.name);
    if (it != file.options.end() && std::string(f.name) != "preset") pipeline::SetOption(&o, f.name, it->second);
  }
  for (const auto& [name, value] : file.options)  // a name this version does not know is an error
    if (!pipeline::FindOptionFieldOrNull(name))
      FREELOC_THROW(a.options_file << ": '" << SafeText(name, 60) << "' is not an option (freeloc options lists them)");
  for (const pipeline::OptionField& f : pipeline::OptionFields()) {  // in registry order
    const std::string v = given(f.name);
    if (!v.empty() && std::string(f.name) != "preset") pipeline::SetOption(&o, f.name, v);
  }
  o.runtime = g.Runtime();
  for (const std::string& s : a.sets) {
    const size_t eq = s.find('=');
    FREELOC_OPTION_CHECK("set", eq != std::string::npos && eq > 0, ": '" << s << "' is not NAME=VALUE");
    FREELOC_OPTION_CHECK("set", s.substr(0, eq) != "preset",
                         ": preset is chosen with --preset (it sets every stage), not --set");
    pipeline::SetOption(&o, s.substr(0, eq), s.substr(eq + 1));
  }
  if (adjust) adjust(&o);
  pipeline::FindModels(&o);
  if (validate) o.Validate();
  return o;
}

void AddFamilyFlags(CLI::App* sub, const OptionFamily& family, std::map<std::string, std::string>* values,
                    const std::function<void(const std::string&, const std::string&)>& check) {
  for (const FamilyField& f : family.fields) {
    if (f.flag.empty()) continue;
    const std::string name = f.name;
    if (f.type == FieldType::kSwitch) {
      sub->add_flag_callback(
          f.flag, [values, name] { (*values)[name] = "1"; }, f.help);
      continue;
    }
    const std::string help = f.help + (f.default_text.empty() ? "" : " (default " + f.default_text + ")");
    sub->add_option_function<std::string>(
           f.flag, [values, name](const std::string& v) { (*values)[name] = v; }, help)
        ->check(CLI::Validator(
            [check, name](std::string& v) {
              try {
                check(name, v);
              } catch (const Error& e) {
                const std::string m = e.what();  // "field: …": the flag names it already
                return m.rfind(name + ": ", 0) == 0 ? m.substr(name.size() + 2) : m;
              }
              return std::string();
            },
            f.type == FieldType::kInteger  ? "N"
            : f.type == FieldType::kNumber ? "X"
                                           : ""));
  }
}

std::vector<std::string> ResolveScenes(const std::string& data, const std::string& split, const std::string& scenes_csv,
                                       std::string* split_dir) {
  std::vector<std::string> only;
  std::stringstream ss(scenes_csv);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) only.push_back(item);
  return pipeline::ResolveScenes(data, split, only, split_dir);
}

std::vector<uint16_t> ReadLabels(const std::string& path, int width, int height) {
  int lw, lh;
  std::vector<uint16_t> v = io::ReadPng16(path, &lw, &lh);
  FREELOC_CHECK(lw == width && lh == height, path << ": the label image is " << lw << "x" << lh << " but its photo is "
                                                  << width << "x" << height
                                                  << "; give masks at the photo's resolution");
  return v;
}

void ApplyMaskArgs(pipeline::PipelineOptions* o, bool ref_masks, bool query_masks) {
  if (!ref_masks && !query_masks) return;
  FREELOC_CHECK(ref_masks, "--query-masks needs --ref-masks (the reference's instances)");
  FREELOC_CHECK(o->UsesInstances(), "--ref-masks: the matcher "
                                        << o->matcher.ToString()
                                        << " takes no instances; use --matcher dust3r+instances or mast3r+instances");
  o->instances.instance_source = query_masks ? pipeline::InstanceSource::kGiven : pipeline::InstanceSource::kPropagate;
}

}  // namespace freeloc::cli
