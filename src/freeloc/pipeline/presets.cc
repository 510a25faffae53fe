// The presets (options.h): the paper's method and its ablations (Table 2), the DUSt3R baseline, and the map-free
// benchmark's baselines, each a set of typed options.
#include "freeloc/core/error.h"
#include "freeloc/pipeline/options.h"

namespace freeloc::pipeline {

namespace {

struct Preset {
  const char* name;
  MatcherKind matcher;
  DepthKind depth;
  SolverKind solver;
  std::optional<double> threshold_px;  // unset: the solver's default
};

// The benchmark's SIFT baseline uses a 3 px essential threshold; dense DUSt3R matches the solver default (1 px).
// The network presets use the hybrid depth-aware solver (bench/baseline, docs/geometry.md); sift-essential
// keeps the benchmark's essential + depth scale (with the anchored scale) unless told --solver hybrid.
constexpr Preset kPresets[] = {
    {"sift-essential", MatcherKind::kSift, DepthKind::kProvided, SolverKind::kEssential, 3.0},
    {"sift-pnp", MatcherKind::kSift, DepthKind::kProvided, SolverKind::kPnp, std::nullopt},
    {"sift-procrustes", MatcherKind::kSift, DepthKind::kProvided, SolverKind::kProcrustes, std::nullopt},
    {"seed", MatcherKind::kDust3rInstances, DepthKind::kMetric3d, SolverKind::kHybrid, std::nullopt},
    {"seed-no-instance", MatcherKind::kDust3r, DepthKind::kMetric3d, SolverKind::kHybrid, std::nullopt},
    {"seed-provided-depth", MatcherKind::kDust3rInstances, DepthKind::kProvided, SolverKind::kHybrid, std::nullopt},
    {"dust3r", MatcherKind::kDust3r, DepthKind::kProvided, SolverKind::kHybrid, std::nullopt},
    // MASt3R routes (docs/pipeline.md "The MASt3R routes"): descriptor matches with its own metric depth (hybrid
    // solver), PnP on the reference pointmap, Metric3D depth instead, and the paper's method with MASt3R in place of
    // DUSt3R.
    {"mast3r", MatcherKind::kMast3r, DepthKind::kMast3r, SolverKind::kHybrid, std::nullopt},
    {"mast3r-pnp", MatcherKind::kMast3r, DepthKind::kMast3r, SolverKind::kPnp, std::nullopt},
    {"mast3r-metric3d", MatcherKind::kMast3r, DepthKind::kMetric3d, SolverKind::kHybrid, std::nullopt},
    {"seed-mast3r", MatcherKind::kMast3rInstances, DepthKind::kMetric3d, SolverKind::kHybrid, std::nullopt},
};
const char kPrecomputedForm[] = "precomputed:<SIFT|SG|LoFTR>-<essential|pnp|procrustes|hybrid>";

std::string AvailablePresets() {
  std::string s;
  for (const Preset& p : kPresets) s += std::string(p.name) + ", ";
  return s + kPrecomputedForm;
}

// precomputed:<name>-<solver>: the scene's correspondences_<name>.npz with that solver; the benchmark's essential
// threshold is 3 px for SIFT and 2 px for the learned matchers.
PipelineOptions ResolvePrecomputed(const std::string& name) {
  const std::string rest = name.substr(12);
  const size_t dash = rest.rfind('-');
  FREELOC_OPTION_CHECK("preset", dash != std::string::npos && dash > 0,
                       ": '" << name << "' is not of the form " << kPrecomputedForm);
  PipelineOptions o;
  o.preset = name;
  o.matcher.kind = MatcherKind::kPrecomputed;
  o.matcher.correspondences = rest.substr(0, dash);
  FREELOC_OPTION_CHECK("preset", IsFileNamePart(o.matcher.correspondences),
                       ": '" << SafeText(name, 100) << "': the correspondence name must be letters, digits, '_', '-', "
                             << "'.' or '+' (it names correspondences_<name>.npz), not a path");
  FREELOC_OPTION_CHECK(
      "preset", TryParseEnum(rest.substr(dash + 1), &o.solver),
      ": '" << name << "': the solver '" << rest.substr(dash + 1) << "' is not one of " << EnumNames<SolverKind>());
  if (o.solver == SolverKind::kEssential || o.solver == SolverKind::kHybrid)
    o.solve.threshold_px = o.matcher.correspondences == "SIFT" ? 3.0 : 2.0;
  return o;
}

}  // namespace

std::vector<std::string> PresetNames() {
  std::vector<std::string> names;
  for (const Preset& p : kPresets) names.push_back(p.name);
  names.insert(names.begin() + 3, kPrecomputedForm);
  return names;
}

PipelineOptions ResolvePreset(const std::string& name) {
  if (name.rfind("precomputed:", 0) == 0) return ResolvePrecomputed(name);
  for (const Preset& p : kPresets) {
    if (name != p.name) continue;
    PipelineOptions o;
    o.preset = name;
    o.matcher.kind = p.matcher;
    o.depth.kind = p.depth;
    o.depth.suffix = p.depth == DepthKind::kProvided ? "sensor" : "";
    o.solver = p.solver;
    o.solve.threshold_px = p.threshold_px;
    return o;
  }
  throw OptionError("preset", ": '" + name + "' is unknown; available: " + AvailablePresets());
}

// The benchmark's correspondence baseline (precomputed:SIFT-essential: essential, 3 px, anchored scale), so `freeloc
// pose` on a run's correspondences gives that run's answer without further flags.
const char kCorrespondencePreset[] = "precomputed:SIFT-essential";

PipelineOptions CorrespondenceDefaults() { return ResolvePreset(kCorrespondencePreset); }

PipelineOptions ForCorrespondences(PipelineOptions o, bool have_depth) {
  o.matcher = MatcherSpec::FromString("precomputed:given");
  o.depth = DepthSpec::FromString(have_depth ? "provided:given" : "none");
  return o;
}

}  // namespace freeloc::pipeline
