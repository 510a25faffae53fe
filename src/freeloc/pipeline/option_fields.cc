// The option fields by name (options.h): one row per field with its text form both ways. This table is what the
// JSON provenance records, the CLI overrides and the Python keywords go through.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <utility>

#include "freeloc/core/error.h"
#include "freeloc/pipeline/options.h"

namespace freeloc::pipeline {

namespace {

std::string Real(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

double ParseReal(const std::string& name, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  FREELOC_OPTION_CHECK(name, !text.empty() && end == text.c_str() + text.size() && errno == 0 && std::isfinite(v),
                       ": '" << text << "' is not a finite number");
  return v;
}

int ParseInt(const std::string& name, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  FREELOC_OPTION_CHECK(
      name, !text.empty() && end == text.c_str() + text.size() && errno == 0 && v >= -(1L << 30) && v <= (1L << 30),
      ": '" << text << "' is not an integer");
  return static_cast<int>(v);
}

template <typename E>
E ParseOptionEnum(const char* name, const std::string& text) {
  E v{};
  FREELOC_OPTION_CHECK(name, TryParseEnum(text, &v), ": '" << text << "' is not one of " << EnumNames<E>());
  return v;
}

// A flag: its spelling, where it is offered and a second spelling.
struct Flag {
  constexpr Flag(const char* name, FlagScope scope, const char* alias = nullptr)
      : name(name), scope(scope), alias(alias) {}
  const char* name;
  FlagScope scope;
  const char* alias;
};
constexpr Flag kNoFlag(nullptr, FlagScope::kNone);

OptionField Field(const char* name, Flag flag, OptionType type, const char* help, std::string choices = "") {
  return {name, flag.name, flag.scope, flag.alias, type, help, std::move(choices)};
}

struct Row {
  OptionField field;
  std::function<std::string(const PipelineOptions&)> get;
  std::function<void(PipelineOptions*, const std::string&)> set;
};

#define FREELOC_TEXT(NAME, FLAG, MEMBER, HELP)                                                     \
  Row {                                                                                            \
    Field(NAME, FLAG, OptionType::kText, HELP), [](const PipelineOptions& o) { return o.MEMBER; }, \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = v; }                            \
  }
#define FREELOC_INT(NAME, FLAG, MEMBER, HELP)                                                                     \
  Row {                                                                                                           \
    Field(NAME, FLAG, OptionType::kInt, HELP), [](const PipelineOptions& o) { return std::to_string(o.MEMBER); }, \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseInt(NAME, v); }                           \
  }
#define FREELOC_REAL(NAME, FLAG, MEMBER, HELP)                                                           \
  Row {                                                                                                  \
    Field(NAME, FLAG, OptionType::kReal, HELP), [](const PipelineOptions& o) { return Real(o.MEMBER); }, \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseReal(NAME, v); }                 \
  }
#define FREELOC_ENUM(NAME, FLAG, MEMBER, HELP)                                                                      \
  Row {                                                                                                             \
    Field(NAME, FLAG, OptionType::kText, HELP, EnumNames<decltype(std::declval<PipelineOptions>().MEMBER)>()),      \
        [](const PipelineOptions& o) { return ToString(o.MEMBER); },                                                \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseOptionEnum<decltype(o->MEMBER)>(NAME, v); } \
  }

const std::vector<Row>& Rows() {
  static const std::vector<Row> rows = {
      FREELOC_TEXT("preset", Flag("--preset", FlagScope::kSolve), preset,
                   "the preset the options started from (docs/pipeline.md \"Presets\")"),
      Row{Field("matcher", Flag("--matcher", FlagScope::kStages), OptionType::kText,
                "how correspondences are found (docs/pipeline.md \"Stages\")", kMatcherChoices),
          [](const PipelineOptions& o) { return o.matcher.ToString(); },
          [](PipelineOptions* o, const std::string& v) { o->matcher = MatcherSpec::FromString(v); }},
      Row{Field("depth", Flag("--depth", FlagScope::kStages), OptionType::kText,
                "where each frame's metric depth map comes from", kDepthChoices),
          [](const PipelineOptions& o) { return o.depth.ToString(); },
          [](PipelineOptions* o, const std::string& v) { o->depth = DepthSpec::FromString(v); }},
      FREELOC_ENUM("solver", Flag("--solver", FlagScope::kSolve), solver, "the pose solver"),
      FREELOC_ENUM("scale", Flag("--scale", FlagScope::kSolve), scale,
                   "metric scale of essential (and hybrid's fallback)"),
      FREELOC_REAL("threshold_px", Flag("--threshold", FlagScope::kSolve), threshold_px,
                   "inlier threshold in pixels (> 0); -1: the solver's default"),
      FREELOC_REAL("reprojection_px", kNoFlag, reprojection_px,
                   "hybrid: reprojection threshold through the depths, px"),
      FREELOC_INT("depth_shifts", kNoFlag, depth_shifts, "hybrid: 1 = also estimate each depth map's shift"),
      FREELOC_INT("always_answer", kNoFlag, always_answer,
                  "1 = unsolved queries are submitted: a weak-support pose with its low confidence, else the prior "
                  "pose with confidence 0"),
      FREELOC_INT("check_intrinsics", kNoFlag, check_intrinsics,
                  "dust3r/mast3r: 1 = warn when given intrinsics differ from the pointmap's focal by > 5 %"),
      FREELOC_TEXT("models_dir", Flag("--models", FlagScope::kStages), models_dir,
                   "folder holding the published weights files (then $FREELOC_MODELS; see docs/models.md)"),
      FREELOC_TEXT("dust3r_model", Flag("--dust3r", FlagScope::kStages, "--dust3r-model"), dust3r_model,
                   "DUSt3R weights (.pth, or model.safetensors)"),
      FREELOC_TEXT("dust3r_config", Flag("--dust3r-config", FlagScope::kStages), dust3r_config,
                   "DUSt3R config.json (optional)"),
      FREELOC_TEXT("mast3r_model", Flag("--mast3r", FlagScope::kStages, "--mast3r-model"), mast3r_model,
                   "MASt3R weights (.pth with its constructor string, or model.safetensors + config.json)"),
      FREELOC_TEXT("seggpt_model", Flag("--seggpt", FlagScope::kStages), seggpt_model,
                   "SegGPT weights (seggpt_vit_large.pth, or model.safetensors)"),
      FREELOC_TEXT("metric3d_model", Flag("--metric3d", FlagScope::kStages), metric3d_model,
                   "Metric3D v2 weights (metric_depth_vit_*_800k.pth, …)"),
      FREELOC_INT("dust3r_size", Flag("--dust3r-size", FlagScope::kStages), dust3r_size,
                  "DUSt3R/MASt3R input size, long side (224, or a multiple of 16 ≥ 224; the released models: 512)"),
      FREELOC_REAL("match_conf_threshold", kNoFlag, match_conf_threshold, "reciprocal matching: minimum confidence"),
      FREELOC_INT("match_subsample", kNoFlag, match_subsample, "reciprocal matching: every k-th query pixel"),
      FREELOC_INT("mast3r_subsample", kNoFlag, mast3r_subsample, "MASt3R fast reciprocal NN: seed grid step"),
      FREELOC_INT("mast3r_border", kNoFlag, mast3r_border, "MASt3R matches: pixels dropped at each network image edge"),
      FREELOC_REAL("mast3r_conf_threshold", kNoFlag, mast3r_conf_threshold,
                   "MASt3R matches: minimum desc_conf (0: none)"),
      FREELOC_ENUM("instance_mode", Flag("--instance-mode", FlagScope::kStages), instance_mode,
                   "how an instance's pixels are fed to the pointmap network"),
      FREELOC_ENUM("instance_source", kNoFlag, instance_source,
                   "where the query's instances come from: propagated by SegGPT or given masks"),
      FREELOC_INT("min_instance_matches", kNoFlag, min_instance_matches, "instances with fewer matches are not used"),
      FREELOC_REAL("proposals.conf_quantile", kNoFlag, proposals.conf_quantile,
                   "drop this quantile of least confident pixels"),
      FREELOC_REAL("proposals.depth_jump", kNoFlag, proposals.depth_jump, "relative depth step that breaks a surface"),
      FREELOC_REAL("proposals.normal_angle_deg", kNoFlag, proposals.normal_angle_deg,
                   "normal change that breaks a surface"),
      FREELOC_REAL("proposals.min_area", kNoFlag, proposals.min_area, "smallest instance, fraction of the image"),
      FREELOC_INT("proposals.max_instances", kNoFlag, proposals.max_instances, "most reference instances"),
      FREELOC_INT("segmenter.max_batch", kNoFlag, segmenter.max_batch, "SegGPT instances per network call"),
      FREELOC_REAL("segmenter.min_score", kNoFlag, segmenter.min_score, "drop propagations painted weaker than this"),
      FREELOC_REAL("segmenter.min_area_ratio", kNoFlag, segmenter.min_area_ratio,
                   "query/reference area ratio, lower bound"),
      FREELOC_REAL("segmenter.max_area_ratio", kNoFlag, segmenter.max_area_ratio,
                   "query/reference area ratio, upper bound"),
      FREELOC_ENUM("device", Flag("--device", FlagScope::kGlobal), runtime.device, "where networks run"),
      FREELOC_ENUM("precision", Flag("--precision", FlagScope::kGlobal), runtime.precision,
                   "network arithmetic: fp32 (parity) or bf16"),
      FREELOC_INT("threads", Flag("--threads", FlagScope::kGlobal), runtime.threads,
                  "CPU threads for inference and geometry; 0: library default"),
      FREELOC_ENUM("track", Flag("--track", FlagScope::kRun), track,
                   "the benchmark track a run answers: every query alone, or each evaluated frame (linear positions 9, "
                   "19, …) fused from its window of 9 frames (docs/pipeline.md \"Multi Frame\")"),
      FREELOC_INT(
          "frames", Flag("--frames", FlagScope::kRun), frames,
          "multi-frame: use the last K (1–9) frames of each window; 1 = the single-frame answer on the same queries"),
      FREELOC_ENUM("device_poses", Flag("--device-poses", FlagScope::kRun), device_poses,
                   "multi-frame: the phone's tracking poses — auto: used where they agree with the images; use: "
                   "trusted; ignore: never read"),
  };
  return rows;
}

#undef FREELOC_TEXT
#undef FREELOC_INT
#undef FREELOC_REAL
#undef FREELOC_ENUM

const Row* FindRow(const std::string& name) {
  for (const Row& r : Rows())
    if (name == r.field.name) return &r;
  return nullptr;
}

const Row& Find(const std::string& name) {
  if (const Row* r = FindRow(name)) return *r;
  std::string names;
  for (const Row& r : Rows()) names += (names.empty() ? "" : ", ") + std::string(r.field.name);
  FREELOC_THROW(name << ": not an option; the options are " << names);
}

}  // namespace

const std::vector<OptionField>& OptionFields() {
  static const std::vector<OptionField> fields = [] {
    std::vector<OptionField> f;
    for (const Row& r : Rows()) f.push_back(r.field);
    return f;
  }();
  return fields;
}

void SetOption(PipelineOptions* options, const std::string& name, const std::string& value) {
  Find(name).set(options, value);
}

std::string GetOption(const PipelineOptions& options, const std::string& name) { return Find(name).get(options); }

const OptionField& FindOptionField(const std::string& name) { return Find(name).field; }

const OptionField* FindOptionFieldOrNull(const std::string& name) {
  const Row* r = FindRow(name);
  return r ? &r->field : nullptr;
}

namespace {

std::string EscapeCell(const std::string& text) {  // a Markdown table cell: "|" would end it
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

// The shortest text that reads back as `v` (0.3, not 0.29999999999999999): for people, not for the records.
std::string ShortestReal(double v) {
  char buf[32];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

}  // namespace

std::string OptionTableMarkdown() {
  const PipelineOptions defaults;
  std::string md =
      "| option (`--set NAME=…`, Python keyword, JSON key) | flag | type | default | what it sets |\n"
      "|---|---|---|---|---|\n";
  for (const Row& r : Rows()) {
    std::string value = r.get(defaults);
    if (r.field.type == OptionType::kReal) value = ShortestReal(std::strtod(value.c_str(), nullptr));
    const char* type = r.field.type == OptionType::kInt    ? "integer"
                       : r.field.type == OptionType::kReal ? "number"
                                                           : "text";
    std::string flag = r.field.flag ? std::string("`") + r.field.flag + "`" : "–";
    if (r.field.alias) flag += std::string(", `") + r.field.alias + "`";
    const std::string help = r.field.help + (r.field.choices.empty() ? "" : "; one of " + r.field.choices);
    md += std::string("| `") + r.field.name + "` | " + flag + " | " + type + " | " +
          (value.empty() ? "–" : "`" + value + "`") + " | " + EscapeCell(help) + " |\n";
  }
  return md;
}

}  // namespace freeloc::pipeline
