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

#define FREELOC_TEXT(NAME, MEMBER, HELP)                                                          \
  Row {                                                                                           \
    {NAME, OptionType::kText, HELP}, [](const PipelineOptions& o) { return o.MEMBER; },          \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = v; }                            \
  }
#define FREELOC_INT(NAME, MEMBER, HELP)                                                           \
  Row {                                                                                           \
    {NAME, OptionType::kInt, HELP}, [](const PipelineOptions& o) { return std::to_string(o.MEMBER); }, \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseInt(NAME, v); }            \
  }
#define FREELOC_REAL(NAME, MEMBER, HELP)                                                          \
  Row {                                                                                           \
    {NAME, OptionType::kReal, HELP}, [](const PipelineOptions& o) { return Real(o.MEMBER); },    \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseReal(NAME, v); }           \
  }
#define FREELOC_ENUM(NAME, MEMBER, HELP)                                                          \
  Row {                                                                                           \
    {NAME, OptionType::kText, HELP}, [](const PipelineOptions& o) { return ToString(o.MEMBER); }, \
        [](PipelineOptions* o, const std::string& v) { o->MEMBER = ParseEnum<decltype(o->MEMBER)>(v, NAME); } \
  }

const std::vector<Row>& Rows() {
  static const std::vector<Row> rows = {
      FREELOC_TEXT("preset", preset, "the preset the options started from (reported)"),
      Row{{"matcher", OptionType::kText, "sift | dust3r | dust3r+instances | mast3r | mast3r+instances | precomputed:<name>"},
          [](const PipelineOptions& o) { return o.matcher.ToString(); },
          [](PipelineOptions* o, const std::string& v) { o->matcher = MatcherSpec::FromString(v); }},
      Row{{"depth", OptionType::kText, "provided:<suffix> | metric3d | mast3r | none"},
          [](const PipelineOptions& o) { return o.depth.ToString(); },
          [](PipelineOptions* o, const std::string& v) { o->depth = DepthSpec::FromString(v); }},
      FREELOC_ENUM("solver", solver, "essential | pnp | procrustes | hybrid"),
      FREELOC_ENUM("scale", scale, "robust | official | anchored (essential, hybrid fallback)"),
      FREELOC_REAL("threshold_px", threshold_px, "inlier threshold in pixels; < 0: the solver's default"),
      FREELOC_REAL("reprojection_px", reprojection_px, "hybrid: reprojection threshold through the depths, px"),
      FREELOC_INT("depth_shifts", depth_shifts, "hybrid: 1 = also estimate each depth map's shift"),
      FREELOC_INT("always_answer", always_answer, "1 = unsolved queries get the prior pose, confidence 0"),
      FREELOC_TEXT("models_dir", models_dir, "folder of the published weights files"),
      FREELOC_TEXT("dust3r_model", dust3r_model, "DUSt3R weights file"),
      FREELOC_TEXT("dust3r_config", dust3r_config, "DUSt3R config.json (optional)"),
      FREELOC_TEXT("mast3r_model", mast3r_model, "MASt3R weights file (.pth or model.safetensors)"),
      FREELOC_TEXT("seggpt_model", seggpt_model, "SegGPT weights file"),
      FREELOC_TEXT("metric3d_model", metric3d_model, "Metric3D v2 weights file"),
      FREELOC_INT("dust3r_size", dust3r_size, "DUSt3R input size (224 or 512)"),
      FREELOC_REAL("match_conf_threshold", match_conf_threshold, "reciprocal matching: minimum confidence"),
      FREELOC_INT("match_subsample", match_subsample, "reciprocal matching: every k-th query pixel"),
      FREELOC_INT("mast3r_subsample", mast3r_subsample, "MASt3R fast reciprocal NN: seed grid step"),
      FREELOC_INT("mast3r_border", mast3r_border, "MASt3R matches: pixels dropped at each network image edge"),
      FREELOC_REAL("mast3r_conf_threshold", mast3r_conf_threshold, "MASt3R matches: minimum desc_conf (0: none)"),
      FREELOC_ENUM("instance_mode", instance_mode, "mask | crop"),
      FREELOC_ENUM("instance_source", instance_source, "propagate | given"),
      FREELOC_INT("min_instance_matches", min_instance_matches, "instances with fewer matches are not used"),
      FREELOC_REAL("proposals.conf_quantile", proposals.conf_quantile, "drop this quantile of least confident pixels"),
      FREELOC_REAL("proposals.depth_jump", proposals.depth_jump, "relative depth step that breaks a surface"),
      FREELOC_REAL("proposals.normal_angle_deg", proposals.normal_angle_deg, "normal change that breaks a surface"),
      FREELOC_REAL("proposals.min_area", proposals.min_area, "smallest instance, fraction of the image"),
      FREELOC_INT("proposals.max_instances", proposals.max_instances, "most reference instances"),
      FREELOC_INT("segmenter.max_batch", segmenter.max_batch, "SegGPT instances per network call"),
      FREELOC_REAL("segmenter.min_score", segmenter.min_score, "drop propagations painted weaker than this"),
      FREELOC_REAL("segmenter.min_area_ratio", segmenter.min_area_ratio, "query/reference area ratio, lower bound"),
      FREELOC_REAL("segmenter.max_area_ratio", segmenter.max_area_ratio, "query/reference area ratio, upper bound"),
      FREELOC_ENUM("device", runtime.device, "cpu | cuda"),
      FREELOC_ENUM("precision", runtime.precision, "fp32 | bf16"),
      FREELOC_INT("threads", runtime.threads, "CPU threads of the networks; 0: library default"),
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

}  // namespace freeloc::pipeline
