// The option fields by name (options.h): one row per field with its text form both ways. This table is what the
// JSON provenance records, the CLI overrides and the Python keywords go through.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>

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
  FREELOC_CHECK(!text.empty() && end == text.c_str() + text.size() && errno == 0 && std::isfinite(v),
                name << ": '" << text << "' is not a finite number");
  return v;
}

int ParseInt(const std::string& name, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  FREELOC_CHECK(!text.empty() && end == text.c_str() + text.size() && errno == 0 && v >= -(1L << 30) &&
                    v <= (1L << 30),
                name << ": '" << text << "' is not an integer");
  return static_cast<int>(v);
}

struct Row {
  OptionField field;
  std::function<std::string(const PipelineOptions&)> get;
  std::function<void(PipelineOptions*, const std::string&)> set;
};

#define FREELOC_TEXT(NAME, FLAG, MEMBER, HELP)                                                          \
  Row {                                                                                           \
    {NAME, FLAG, OptionType::kText, HELP}, [](const PipelineOptions& o) { return o.MEMBER; },          \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = v; }                            \
  }
#define FREELOC_INT(NAME, FLAG, MEMBER, HELP)                                                           \
  Row {                                                                                           \
    {NAME, FLAG, OptionType::kInt, HELP}, [](const PipelineOptions& o) { return std::to_string(o.MEMBER); }, \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseInt(NAME, v); }            \
  }
#define FREELOC_REAL(NAME, FLAG, MEMBER, HELP)                                                          \
  Row {                                                                                           \
    {NAME, FLAG, OptionType::kReal, HELP}, [](const PipelineOptions& o) { return Real(o.MEMBER); },    \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseReal(NAME, v); }           \
  }
#define FREELOC_ENUM(NAME, FLAG, MEMBER, HELP)                                                          \
  Row {                                                                                           \
    {NAME, FLAG, OptionType::kText, HELP}, [](const PipelineOptions& o) { return ToString(o.MEMBER); }, \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseEnum<decltype(o->MEMBER)>(v, NAME); } \
  }

const std::vector<Row>& Rows() {
  static const std::vector<Row> rows = {
      FREELOC_TEXT("preset", "--preset", preset, "the preset the options started from (docs/pipeline.md \"Presets\")"),
      Row{{"matcher", "--matcher", OptionType::kText, "sift | dust3r | dust3r+instances | mast3r | mast3r+instances | precomputed:<name>"},
          [](const PipelineOptions& o) { return o.matcher.ToString(); },
          [](PipelineOptions* o, const std::string& v) { o->matcher = MatcherSpec::FromString(v); }},
      Row{{"depth", "--depth", OptionType::kText, "provided:<suffix> | metric3d | mast3r | none"},
          [](const PipelineOptions& o) { return o.depth.ToString(); },
          [](PipelineOptions* o, const std::string& v) { o->depth = DepthSpec::FromString(v); }},
      FREELOC_ENUM("solver", "--solver", solver, "essential | pnp | procrustes | hybrid"),
      FREELOC_ENUM("scale", "--scale", scale, "anchored | robust | official: metric scale of essential (and hybrid's fallback)"),
      FREELOC_REAL("threshold_px", "--threshold", threshold_px, "inlier threshold in pixels; -1: the solver's default"),
      FREELOC_REAL("reprojection_px", nullptr, reprojection_px, "hybrid: reprojection threshold through the depths, px"),
      FREELOC_INT("depth_shifts", nullptr, depth_shifts, "hybrid: 1 = also estimate each depth map's shift"),
      FREELOC_INT("always_answer", nullptr, always_answer, "1 = unsolved queries are submitted: a weak-support pose with its low confidence, else the prior pose with confidence 0"),
      FREELOC_INT("check_intrinsics", nullptr, check_intrinsics, "dust3r/mast3r: 1 = warn when given intrinsics differ from the pointmap's focal by > 5 %"),
      FREELOC_TEXT("models_dir", "--models", models_dir, "folder of the published weights files"),
      FREELOC_TEXT("dust3r_model", "--dust3r", dust3r_model, "DUSt3R weights file"),
      FREELOC_TEXT("dust3r_config", "--dust3r-config", dust3r_config, "DUSt3R config.json (optional)"),
      FREELOC_TEXT("mast3r_model", "--mast3r", mast3r_model, "MASt3R weights file (.pth or model.safetensors)"),
      FREELOC_TEXT("seggpt_model", "--seggpt", seggpt_model, "SegGPT weights file"),
      FREELOC_TEXT("metric3d_model", "--metric3d", metric3d_model, "Metric3D v2 weights file"),
      FREELOC_INT("dust3r_size", "--dust3r-size", dust3r_size, "DUSt3R/MASt3R input size, long side (224, or a multiple of 16 ≥ 224; the released models: 512)"),
      FREELOC_REAL("match_conf_threshold", nullptr, match_conf_threshold, "reciprocal matching: minimum confidence"),
      FREELOC_INT("match_subsample", nullptr, match_subsample, "reciprocal matching: every k-th query pixel"),
      FREELOC_INT("mast3r_subsample", nullptr, mast3r_subsample, "MASt3R fast reciprocal NN: seed grid step"),
      FREELOC_INT("mast3r_border", nullptr, mast3r_border, "MASt3R matches: pixels dropped at each network image edge"),
      FREELOC_REAL("mast3r_conf_threshold", nullptr, mast3r_conf_threshold, "MASt3R matches: minimum desc_conf (0: none)"),
      FREELOC_ENUM("instance_mode", "--instance-mode", instance_mode, "mask | crop"),
      FREELOC_ENUM("instance_source", nullptr, instance_source, "propagate | given"),
      FREELOC_INT("min_instance_matches", nullptr, min_instance_matches, "instances with fewer matches are not used"),
      FREELOC_REAL("proposals.conf_quantile", nullptr, proposals.conf_quantile, "drop this quantile of least confident pixels"),
      FREELOC_REAL("proposals.depth_jump", nullptr, proposals.depth_jump, "relative depth step that breaks a surface"),
      FREELOC_REAL("proposals.normal_angle_deg", nullptr, proposals.normal_angle_deg, "normal change that breaks a surface"),
      FREELOC_REAL("proposals.min_area", nullptr, proposals.min_area, "smallest instance, fraction of the image"),
      FREELOC_INT("proposals.max_instances", nullptr, proposals.max_instances, "most reference instances"),
      FREELOC_INT("segmenter.max_batch", nullptr, segmenter.max_batch, "SegGPT instances per network call"),
      FREELOC_REAL("segmenter.min_score", nullptr, segmenter.min_score, "drop propagations painted weaker than this"),
      FREELOC_REAL("segmenter.min_area_ratio", nullptr, segmenter.min_area_ratio, "query/reference area ratio, lower bound"),
      FREELOC_REAL("segmenter.max_area_ratio", nullptr, segmenter.max_area_ratio, "query/reference area ratio, upper bound"),
      FREELOC_ENUM("device", "--device", runtime.device, "cpu | cuda"),
      FREELOC_ENUM("precision", "--precision", runtime.precision, "fp32 | bf16"),
      FREELOC_INT("threads", "--threads", runtime.threads, "CPU threads of the networks; 0: library default"),
      FREELOC_ENUM("track", "--track", track, "single-frame | multi-frame: the benchmark track a run answers"),
      FREELOC_INT("frames", "--frames", frames, "multi-frame: use the last K (1–9) frames of each window; 1 = the single-frame answer"),
      FREELOC_ENUM("device_poses", "--device-poses", device_poses, "multi-frame: auto (used where they agree with the images) | use | ignore the phone's tracking poses"),
  };
  return rows;
}

#undef FREELOC_TEXT
#undef FREELOC_INT
#undef FREELOC_REAL
#undef FREELOC_ENUM

const Row& Find(const std::string& name) {
  for (const Row& r : Rows())
    if (name == r.field.name) return r;
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
    const char* type = r.field.type == OptionType::kInt ? "integer" : r.field.type == OptionType::kReal ? "number" : "text";
    md += std::string("| `") + r.field.name + "` | " + (r.field.flag ? std::string("`") + r.field.flag + "`" : "–") +
          " | " + type + " | " + (value.empty() ? "–" : "`" + value + "`") + " | " + EscapeCell(r.field.help) + " |\n";
  }
  return md;
}

}  // namespace freeloc::pipeline
