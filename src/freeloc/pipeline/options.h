// The pipeline's options (docs/architecture.md §2): typed (each enum with one string table; text is parsed once, where
// it enters — CLI, preset table, JSON, Python), the option registry that names every field, and the presets. What a
// query gives back is in query_result.h. Light header.
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/enum_table.h"
#include "freeloc/geometry/scale_method.h"
#include "freeloc/inputs/input_options.h"
#include "freeloc/io/track.h"
#include "freeloc/matching/instance_mode.h"
#include "freeloc/matching/proposal_options.h"
#include "freeloc/nn/instance_segmenter_options.h"
#include "freeloc/nn/runtime.h"
#include "freeloc/pose/device_pose_use.h"
#include "freeloc/pose/solve_options.h"

namespace freeloc::pipeline {

// sift (the benchmark's extractor) | dust3r (global reciprocal 3D matches) | dust3r+instances (+ the paper's
// instance knowledge, Eq. 3) | mast3r (MASt3R descriptors, fast reciprocal NN) | mast3r+instances (the same with
// the instance knowledge) | precomputed:<name> (the scene's correspondences_<name>.npz, or rows handed in).
enum class MatcherKind { kSift, kDust3r, kDust3rInstances, kMast3r, kMast3rInstances, kPrecomputed };
// provided:<suffix> (frame_xxxxx.<suffix>.png beside each frame, or maps handed in) | metric3d | mast3r (MASt3R's
// own metric pointmaps of the pair: the reference's z from the (reference, query) pass, the query's from the swapped
// pass) | none.
enum class DepthKind { kProvided, kMetric3d, kMast3r, kNone };
// The pose solver (pose/solve_options.h): essential | pnp | procrustes | hybrid.
using pose::SolverKind;
// Where dust3r+instances / mast3r+instances get their instance masks: kPropagate — the reference's given labels or
// proposals from its own pointmap, propagated into each query by SegGPT; kGiven — label images given for both frames
// (no SegGPT).
enum class InstanceSource { kPropagate, kGiven };
// The benchmark track (io/mapfree.h): multi-frame answers each evaluated frame from its window (multi_frame.h).
using freeloc::io::Track;
// The unit of integer depth maps and what inputs must look like (inputs/input_options.h).
using inputs::DepthUnit;
using inputs::InputOptions;
// Multi-frame: the phone's tracking poses (pose/device_pose_use.h): auto | use | ignore.
using pose::DevicePoseUse;

// A name that becomes part of a file name (precomputed:<name>, provided:<suffix>): letters, digits, '_', '-', '.', '+',
// at most 64, not starting with '.' and without "..": never a path.
bool IsFileNamePart(const std::string& name);

struct MatcherSpec {
  MatcherKind kind = MatcherKind::kSift;
  std::string correspondences;  // kPrecomputed: the name in correspondences_<name>.npz (SIFT, SG, LoFTR, …)
  // "sift" | "dust3r" | "dust3r+instances" | "mast3r" | "mast3r+instances" | "precomputed:<name>"; throws naming the
  // field "matcher".
  static MatcherSpec FromString(const std::string& text);
  std::string ToString() const;
  bool operator==(const MatcherSpec& o) const { return kind == o.kind && correspondences == o.correspondences; }
};

struct DepthSpec {
  DepthKind kind = DepthKind::kProvided;
  std::string suffix = "sensor";  // kProvided: frame_xxxxx.<suffix>.png
  // "provided:<suffix>" | "metric3d" | "mast3r" | "none"; throws naming the field "depth".
  static DepthSpec FromString(const std::string& text);
  std::string ToString() const;
  bool operator==(const DepthSpec& o) const { return kind == o.kind && suffix == o.suffix; }
};

// The pipeline's options in parts that change for one reason each; an option's public name (`--set NAME=…`, Python
// keyword, JSON key) is its field path without the part: solve.threshold_px is "threshold_px",
// instances.proposals.min_area is "proposals.min_area". The route (preset, matcher, depth, solver, track) is at the
// top.

struct PipelineOptions;

// How a pose is solved from the correspondences and the depths (pose/solve_options.h: scale, threshold_px,
// reprojection_px, depth_shifts, sprt_min_matches), and the always-answer rule.
struct SolveOptions : pose::SolveOptions {
  // Every query gets a pose in the submission: a weak-support model is submitted with its pose and a confidence
  // below every ok answer; a query with no model at all with the prior pose (the reference camera's: identity
  // rotation, zero translation) and confidence 0; the status still says which. 0 = submit ok queries only.
  int always_answer = 1;
  void Validate() const;  // throws freeloc::Error naming the option
};

// Which weights files the network stages load. Paths left empty are looked up by their published file names in
// `models_dir`, then in the folders of $FREELOC_MODELS (FindModels); Validate names what is still missing.
struct ModelFiles {
  std::string models_dir;
  std::string dust3r_model;    // official .pth or model.safetensors (+ config.json beside it)
  std::string dust3r_config;   // optional config.json with the constructor arguments
  std::string mast3r_model;    // MASt3R .pth (constructor string inside) or HF model.safetensors + config.json
  std::string seggpt_model;    // seggpt_vit_large.pth or HF model.safetensors
  std::string metric3d_model;  // metric_depth_vit_{small,large,giant2}_800k.pth or safetensors
  void Validate(const PipelineOptions& o) const;  // every network `o` uses has its file, else says where it looked
};

// How the DUSt3R-family matchers turn a pair's pointmaps (and MASt3R's descriptors) into correspondences.
struct PointmapMatchOptions {
  int dust3r_size = 512;            // load_images size (long side)
  double match_conf_threshold = 0;  // reciprocal matching: a pixel is valid if conf >= this
  int match_subsample = 1;          // keep every k-th query pixel
  // MASt3R descriptor matching (naver/mast3r mast3r/fast_nn.py): seed grid step S of the fast reciprocal NN, the border
  // filter (pixels from each network image's edge) and the minimum desc_conf of both pixels (0: none; visloc: 1.001).
  int mast3r_subsample = 8;
  int mast3r_border = 3;
  double mast3r_conf_threshold = 0;
  // Compare intrinsics handed in with the focal the pointmaps give and warn above 5 % (a wrong calibration
  // otherwise gives a wrong pose in silence). Costs the query's swapped decoder pass.
  int check_intrinsics = 1;
  void Validate() const;
};

// The paper's instance knowledge (dust3r+instances, mast3r+instances).
struct InstanceOptions {
  matching::InstanceMode instance_mode = matching::InstanceMode::kMask;
  InstanceSource instance_source = InstanceSource::kPropagate;
  int min_instance_matches = 16;           // instances with fewer matches keep the global ones
  matching::ProposalOptions proposals;     // reference instances from the reference pointmap
  nn::InstanceSegmenterOptions segmenter;  // SegGPT propagation and its filters
  void Validate() const;
};

// The Multi Frame track's windows (multi_frame.h).
struct MultiFrameOptions {
  int frames = 9;  // the last `frames` (1–9) frames of each window
  DevicePoseUse device_poses = DevicePoseUse::kAuto;
  void Validate() const;
};

struct PipelineOptions {
  std::string preset = "sift-essential";  // the preset these options started from (reported, not interpreted)
  MatcherSpec matcher;
  DepthSpec depth;
  SolverKind solver = SolverKind::kEssential;
  io::Track track = io::Track::kSingleFrame;  // run/eval: which queries are answered and how
  SolveOptions solve;
  ModelFiles models;
  PointmapMatchOptions pointmap;
  InstanceOptions instances;
  MultiFrameOptions multi_frame;
  InputOptions inputs;
  nn::RuntimeOptions runtime;  // device, precision, threads of every network stage

  bool UsesDust3r() const {
    return matcher.kind == MatcherKind::kDust3r || matcher.kind == MatcherKind::kDust3rInstances;
  }
  bool UsesMast3r() const {
    return matcher.kind == MatcherKind::kMast3r || matcher.kind == MatcherKind::kMast3rInstances;
  }
  bool UsesPointmapModel() const { return UsesDust3r() || UsesMast3r(); }  // the DUSt3R-family matcher stage
  bool UsesInstances() const {
    return matcher.kind == MatcherKind::kDust3rInstances || matcher.kind == MatcherKind::kMast3rInstances;
  }
  bool UsesSegGpt() const { return UsesInstances() && instances.instance_source == InstanceSource::kPropagate; }
  bool UsesMetric3d() const { return depth.kind == DepthKind::kMetric3d; }
  bool UsesProvidedDepth() const { return depth.kind == DepthKind::kProvided; }
  bool UsesMast3rDepth() const { return depth.kind == DepthKind::kMast3r; }
  bool UsesPrecomputed() const { return matcher.kind == MatcherKind::kPrecomputed; }
  // The working resolution's long side for this matcher (InputOptions), 0: full resolution.
  int WorkingMaxSide() const { return UsesPointmapModel() ? inputs.network_max_side : inputs.max_side; }
  // Throws freeloc::Error naming the option field and the allowed values (or the missing weights file).
  void Validate() const;
  std::string Summary() const;  // one line for people: "preset …: matcher …, depth …, solver …"
};

}  // namespace freeloc::pipeline

namespace freeloc {
template <>
struct EnumTable<pipeline::MatcherKind> {
  static constexpr const char* kField = "matcher";
  static constexpr EnumEntry<pipeline::MatcherKind> kEntries[] = {
      {pipeline::MatcherKind::kSift, "sift"},
      {pipeline::MatcherKind::kDust3r, "dust3r"},
      {pipeline::MatcherKind::kDust3rInstances, "dust3r+instances"},
      {pipeline::MatcherKind::kMast3r, "mast3r"},
      {pipeline::MatcherKind::kMast3rInstances, "mast3r+instances"},
      {pipeline::MatcherKind::kPrecomputed, "precomputed"}};
};
template <>
struct EnumTable<pipeline::DepthKind> {
  static constexpr const char* kField = "depth";
  static constexpr EnumEntry<pipeline::DepthKind> kEntries[] = {{pipeline::DepthKind::kProvided, "provided"},
                                                                {pipeline::DepthKind::kMetric3d, "metric3d"},
                                                                {pipeline::DepthKind::kMast3r, "mast3r"},
                                                                {pipeline::DepthKind::kNone, "none"}};
};
template <>
struct EnumTable<pipeline::InstanceSource> {
  static constexpr const char* kField = "instance_source";
  static constexpr EnumEntry<pipeline::InstanceSource> kEntries[] = {
      {pipeline::InstanceSource::kPropagate, "propagate"}, {pipeline::InstanceSource::kGiven, "given"}};
};
}  // namespace freeloc

namespace freeloc::pipeline {

// Every option field by name — the names the JSON records, the CLI's overrides and Python keywords use (nested
// options with a dot: "proposals.max_instances", "segmenter.min_score"). Values are text, parsed by the field's
// type; errors name the field and what it takes.
enum class OptionType { kText, kInt, kReal };
// The text forms of the two stage specs (MatcherSpec, DepthSpec), which take a name after a colon.
inline constexpr const char* kMatcherChoices =
    "sift, dust3r, dust3r+instances, mast3r, mast3r+instances, precomputed:<name>";
inline constexpr const char* kDepthChoices = "provided:<suffix>, metric3d, mast3r, none";
// Which command lines carry an option's flag: kGlobal — `freeloc` itself, before the command (checked as parsed);
// kSolve — every command that solves a pose (run, relocalize, demo, serve, pose); kStages — those that also choose
// the matcher and depth stages and their networks (all of them but pose); kRun — `freeloc run` alone.
enum class FlagScope { kNone, kGlobal, kSolve, kStages, kRun };
struct OptionField {
  const char* name;
  const char* flag;   // the command-line flag that sets it, nullptr: only `--set NAME=…`
  FlagScope scope;    // where the flag is offered (kNone without a flag)
  const char* alias;  // a second spelling of the flag (e.g. --dust3r-model), nullptr: none
  OptionType type;
  const char* help;
  std::string choices;  // "a, b, c" for the fields with a fixed set of values (from their enum tables), else empty
};
const std::vector<OptionField>& OptionFields();
// A number as the options and records write it: the shortest text that reads back as exactly `v` (0.3, 100).
std::string NumberText(double v);
void SetOption(PipelineOptions* options, const std::string& name, const std::string& value);
std::string GetOption(const PipelineOptions& options, const std::string& name);
const OptionField& FindOptionField(const std::string& name);  // throws naming the options when unknown
const OptionField* FindOptionFieldOrNull(const std::string& name);
// The option table as Markdown (name, flag, type, default of a default-constructed PipelineOptions, help): what
// docs/formats.md shows and `freeloc options --markdown` prints; a test keeps the two equal.
std::string OptionTableMarkdown();

// Presets (the paper's method, its ablations and the benchmark's baselines) as option sets; overridable field by
// field. Throws freeloc::Error naming the preset and the available ones when unknown.
PipelineOptions ResolvePreset(const std::string& name);
// With "precomputed:<SIFT|SG|LoFTR>-<essential|pnp|procrustes|hybrid>" as one.
std::vector<std::string> PresetNames();

// A pose from correspondences handed in (`freeloc pose`, Python's estimate_relative_pose): without a preset the
// benchmark's correspondence baseline, precomputed:SIFT-essential (essential, 3 px, anchored scale) — the answer
// `freeloc run --preset precomputed:SIFT-essential` gives for the same rows and depths; ForCorrespondences then
// points the matcher at the rows handed in and the depth stage at the maps handed in (provided) or none.
PipelineOptions CorrespondenceDefaults();
PipelineOptions ForCorrespondences(PipelineOptions options, bool have_depth);

}  // namespace freeloc::pipeline
