// Helpers shared by the subcommands: the pipeline's options as flags, flag names in errors, scene lists.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdlib>
#include <regex>
#include <sstream>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/pipeline/run_controller.h"
#include "freeloc/pipeline/relocalizer.h"

namespace freeloc::cli {

namespace {

// Option fields → the flags that set them: the option table's own column (pipeline/options.h), plus the run
// controller's fields that are flags of `run` alone.
const std::vector<std::pair<std::string, std::string>>& Flags() {
  static const std::vector<std::pair<std::string, std::string>> flags = [] {
    std::vector<std::pair<std::string, std::string>> f;
    for (const pipeline::OptionField& o : pipeline::OptionFields())
      if (o.flag) f.emplace_back(o.name, o.flag);
    for (const char* run_field : {"shard", "data", "out", "log"}) f.emplace_back(run_field, std::string("--") + run_field);
    return f;
  }();
  return flags;
}

}  // namespace

// "field: …" → "--flag: …"; other fields named in the text get "(--flag)" after them.
std::string NameFlags(std::string m) {
  for (const auto& [f, flag] : Flags()) {  // a leading "field:" or "field " names the flag
    if (m.size() > f.size() && m.compare(0, f.size(), f) == 0 && (m[f.size()] == ':' || m[f.size()] == ' ')) {
      m = flag + m.substr(f.size());
      break;
    }
  }
  for (const auto& [field, flag] : Flags()) {
    if (field.find('_') == std::string::npos) continue;  // only unambiguous names
    const std::regex word("\\b" + field + "\\b(?! \\()");
    m = std::regex_replace(m, word, field + " (" + flag + ")");
  }
  return m;
}

namespace {

void Apply(pipeline::PipelineOptions* o, const char* field, const std::string& value) {
  if (!value.empty()) pipeline::SetOption(o, field, value);
}

}  // namespace

nn::RuntimeOptions GlobalOptions::Runtime() const {
  nn::RuntimeOptions rt;
  rt.device = ParseEnum<nn::Device>(device, "--device");
  rt.precision = ParseEnum<nn::Precision>(precision, "--precision");
  rt.threads = threads;
  return rt;
}

pipeline::PipelineOptions WithFlagNames(const std::function<pipeline::PipelineOptions()>& fn) {
  try {
    return fn();
  } catch (const Error& e) {
    throw Error(NameFlags(e.what()));
  }
}

namespace {

// A pipeline flag's help: the option table's text and the default preset's value (one source for both).
std::string FlagHelp(const char* field, const pipeline::PipelineOptions& defaults) {
  const std::string value = pipeline::GetOption(defaults, field);
  return std::string(pipeline::FindOptionField(field).help) +
         (value.empty() || value == "-1" ? std::string() : " (default " + value + ")");
}

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

}  // namespace

void AddPipelineArgs(CLI::App* sub, PipelineArgs* a, const std::string& default_preset, bool networks) {
  const pipeline::PipelineOptions d = pipeline::ResolvePreset(default_preset);
  std::string presets;
  for (const std::string& p : pipeline::PresetNames()) presets += (presets.empty() ? "" : ", ") + p;
  sub->add_option("--preset", a->preset, "default " + default_preset + "; one of " + presets)->check(FileNameParts());
  if (networks) {  // a command given correspondences and depth maps (pose) has no matcher or depth stage to choose
    sub->add_option("--matcher", a->matcher, "override: " + FlagHelp("matcher", d))->check(FileNameParts());
    sub->add_option("--depth", a->depth, "override: " + FlagHelp("depth", d))->check(FileNameParts());
  }
  sub->add_option("--solver", a->solver, "override: " + FlagHelp("solver", d));
  sub->add_option("--scale", a->scale, "override: " + FlagHelp("scale", d));
  sub->add_option("--threshold", a->threshold, "override: inlier threshold in pixels (> 0; default: the preset's, else the solver's)")
      ->check(CLI::Validator(
          [](std::string& v) {
            char* end = nullptr;
            const double x = std::strtod(v.c_str(), &end);
            return (end && *end == 0 && std::isfinite(x) && x > 0) ? std::string()
                                                                  : std::string("must be a positive number of pixels");
          },
          "PX"));
  sub->add_option("--set", a->sets,
                  "override any option field: NAME=VALUE (`freeloc options` lists them with their defaults)");
  if (!networks) return;
  sub->add_option("--instance-mode", a->instance_mode, "override: " + FlagHelp("instance_mode", d));
  sub->add_option("--models", a->models,
                  "folder holding the published weights files (then $FREELOC_MODELS; see docs/models.md)");
  sub->add_option("--dust3r,--dust3r-model", a->dust3r_model, "DUSt3R weights (.pth, or model.safetensors)");
  sub->add_option("--dust3r-config", a->dust3r_config, "DUSt3R config.json (optional)");
  sub->add_option("--mast3r,--mast3r-model", a->mast3r_model,
                  "MASt3R weights (.pth with its constructor string, or model.safetensors + config.json)");
  sub->add_option("--seggpt", a->seggpt_model, "SegGPT weights (seggpt_vit_large.pth, or model.safetensors)");
  sub->add_option("--metric3d", a->metric3d_model, "Metric3D v2 weights (metric_depth_vit_*_800k.pth, …)");
  sub->add_option("--dust3r-size", a->dust3r_size, FlagHelp("dust3r_size", d));
}

pipeline::PipelineOptions ResolvePipelineArgs(const PipelineArgs& a, const GlobalOptions& g,
                                              const std::string& default_preset,
                                              const std::function<void(pipeline::PipelineOptions*)>& adjust) {
  return WithFlagNames([&] {
    pipeline::PipelineOptions o = pipeline::ResolvePreset(a.preset.empty() ? default_preset : a.preset);
    Apply(&o, "matcher", a.matcher);
    Apply(&o, "depth", a.depth);
    Apply(&o, "solver", a.solver);
    Apply(&o, "scale", a.scale);
    Apply(&o, "instance_mode", a.instance_mode);
    if (a.threshold > 0) o.threshold_px = a.threshold;
    o.models_dir = a.models;
    Apply(&o, "dust3r_model", a.dust3r_model);
    Apply(&o, "dust3r_config", a.dust3r_config);
    Apply(&o, "mast3r_model", a.mast3r_model);
    Apply(&o, "seggpt_model", a.seggpt_model);
    Apply(&o, "metric3d_model", a.metric3d_model);
    if (a.dust3r_size > 0) o.dust3r_size = a.dust3r_size;
    o.runtime = g.Runtime();
    for (const std::string& s : a.sets) {
      const size_t eq = s.find('=');
      FREELOC_CHECK(eq != std::string::npos && eq > 0, "--set: '" << s << "' is not NAME=VALUE");
      pipeline::SetOption(&o, s.substr(0, eq), s.substr(eq + 1));
    }
    if (adjust) adjust(&o);
    pipeline::FindModels(&o);
    o.Validate();
    return o;
  });
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
  std::vector<uint16_t> v = ReadPng16(path, &lw, &lh);
  FREELOC_CHECK(lw == width && lh == height, path << ": the label image is " << lw << "x" << lh << " but its photo is "
                                                  << width << "x" << height
                                                  << "; give masks at the photo's resolution");
  return v;
}

void ApplyMaskArgs(pipeline::PipelineOptions* o, bool ref_masks, bool query_masks) {
  if (!ref_masks && !query_masks) return;
  FREELOC_CHECK(ref_masks, "--query-masks needs --ref-masks (the reference's instances)");
  FREELOC_CHECK(o->UsesInstances(), "--ref-masks: the matcher " << o->matcher.ToString()
                                        << " takes no instances; use --matcher dust3r+instances or mast3r+instances");
  o->instance_source = query_masks ? pipeline::InstanceSource::kGiven : pipeline::InstanceSource::kPropagate;
}

}  // namespace freeloc::cli
