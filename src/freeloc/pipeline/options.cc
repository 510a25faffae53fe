#include "freeloc/pipeline/options.h"

#include <cctype>
#include <cmath>

#include "freeloc/core/error.h"
#include "freeloc/inputs/model_files.h"
#include "freeloc/pipeline/query_result.h"

namespace freeloc::pipeline {

namespace {

// "head:tail" → {head, tail}; {text, ""} without a colon.
std::pair<std::string, std::string> SplitColon(const std::string& text) {
  const size_t c = text.find(':');
  if (c == std::string::npos) return {text, ""};
  return {text.substr(0, c), text.substr(c + 1)};
}
}  // namespace

bool IsFileNamePart(const std::string& s) {
  if (s.empty() || s.size() > 64 || s[0] == '.' || s.find("..") != std::string::npos) return false;
  for (unsigned char c : s)
    if (!std::isalnum(c) && c != '_' && c != '-' && c != '.' && c != '+') return false;
  return true;
}

MatcherSpec MatcherSpec::FromString(const std::string& text) {
  const auto [head, tail] = SplitColon(text);
  MatcherSpec m;
  FREELOC_OPTION_CHECK("matcher", TryParseEnum(head, &m.kind), ": '" << text << "' is not one of " << kMatcherChoices);
  FREELOC_OPTION_CHECK("matcher", (m.kind == MatcherKind::kPrecomputed) == (text.find(':') != std::string::npos),
                       ": '" << text << "' is not one of " << kMatcherChoices);
  FREELOC_OPTION_CHECK("matcher", m.kind != MatcherKind::kPrecomputed || !tail.empty(),
                       ": '" << text << "' names no correspondences; write precomputed:<name> (SIFT, SG, LoFTR, …)");
  // The name becomes a file name (correspondences_<name>.npz): never a path.
  FREELOC_OPTION_CHECK("matcher", m.kind != MatcherKind::kPrecomputed || IsFileNamePart(tail),
                       ": '" << SafeText(text, 100) << "': the correspondence name must be letters, digits, '_', '-', "
                             << "'.' or '+' (it names correspondences_<name>.npz), not a path");
  m.correspondences = tail;
  return m;
}

std::string MatcherSpec::ToString() const {
  return freeloc::ToString(kind) + (kind == MatcherKind::kPrecomputed ? ":" + correspondences : "");
}

DepthSpec DepthSpec::FromString(const std::string& text) {
  const auto [head, tail] = SplitColon(text);
  DepthSpec d;
  FREELOC_OPTION_CHECK("depth", TryParseEnum(head, &d.kind), ": '" << text << "' is not one of " << kDepthChoices);
  FREELOC_OPTION_CHECK("depth", (d.kind == DepthKind::kProvided) == (text.find(':') != std::string::npos),
                       ": '" << text << "' is not one of " << kDepthChoices);
  FREELOC_OPTION_CHECK("depth", d.kind != DepthKind::kProvided || !tail.empty(),
                       ": '" << text << "' names no suffix; write provided:<suffix> (e.g. provided:sensor)");
  // The suffix becomes a file name (frame_xxxxx.<suffix>.png): never a path.
  FREELOC_OPTION_CHECK("depth", d.kind != DepthKind::kProvided || IsFileNamePart(tail),
                       ": '" << SafeText(text, 100) << "': the suffix must be letters, digits, '_', '-', '.' or '+' "
                             << "(it names frame_xxxxx.<suffix>.png), not a path");
  d.suffix = d.kind == DepthKind::kProvided ? tail : "";
  return d;
}

std::string DepthSpec::ToString() const {
  return freeloc::ToString(kind) + (kind == DepthKind::kProvided ? ":" + suffix : "");
}

std::string QueryResult::StatusText() const {
  return freeloc::ToString(status) + (message.empty() ? "" : ": " + message);
}

void SolveOptions::Validate() const {
  pose::SolveOptions::Validate();
  FREELOC_OPTION_CHECK("always_answer", always_answer == 0 || always_answer == 1,
                       ": " << always_answer << " is not 0 or 1");
}

void PointmapMatchOptions::Validate() const {
  FREELOC_OPTION_CHECK("check_intrinsics", check_intrinsics == 0 || check_intrinsics == 1,
                       ": " << check_intrinsics << " is not 0 or 1");
  FREELOC_OPTION_CHECK(
      "dust3r_size", dust3r_size >= 224,
      ": " << dust3r_size << " is too small; use 224, or a multiple of 16 up from it (512 for the released models)");
  FREELOC_OPTION_CHECK("match_subsample", match_subsample >= 1, ": " << match_subsample << " must be >= 1");
  FREELOC_OPTION_CHECK("mast3r_subsample", mast3r_subsample >= 1,
                       ": " << mast3r_subsample << " must be >= 1 (the seed grid step)");
  FREELOC_OPTION_CHECK("mast3r_border", mast3r_border >= 0, ": " << mast3r_border << " must be >= 0 pixels");
  FREELOC_OPTION_CHECK("mast3r_conf_threshold", std::isfinite(mast3r_conf_threshold),
                       ": " << mast3r_conf_threshold << " is not a finite number");
}

void InstanceOptions::Validate() const {
  FREELOC_OPTION_CHECK("min_instance_matches", min_instance_matches >= 0,
                       ": " << min_instance_matches << " is negative");
  proposals.Validate();
}

void MultiFrameOptions::Validate() const {
  FREELOC_OPTION_CHECK("frames", frames >= 1 && frames <= 9,
                       ": " << frames << " is not in 1..9 (a window holds 9 frames)");
}

void ModelFiles::Validate(const PipelineOptions& o) const {
  const auto dirs = inputs::ModelDirs(models_dir);
  FREELOC_CHECK(!o.UsesDust3r() || !dust3r_model.empty(),
                inputs::MissingModelMessage(inputs::Network::kDust3r, o.preset, dirs));
  FREELOC_CHECK(!o.UsesMast3r() || !mast3r_model.empty(),
                inputs::MissingModelMessage(inputs::Network::kMast3r, o.preset, dirs));
  FREELOC_CHECK(!o.UsesSegGpt() || !seggpt_model.empty(),
                inputs::MissingModelMessage(inputs::Network::kSegGpt, o.preset, dirs));
  FREELOC_CHECK(!o.UsesMetric3d() || !metric3d_model.empty(),
                inputs::MissingModelMessage(inputs::Network::kMetric3d, o.preset, dirs));
}

void PipelineOptions::Validate() const {
  FREELOC_OPTION_CHECK("matcher", matcher.kind != MatcherKind::kPrecomputed || !matcher.correspondences.empty(),
                       ": precomputed needs a name (precomputed:<SIFT|SG|LoFTR|…>)");
  FREELOC_OPTION_CHECK("depth", depth.kind != DepthKind::kProvided || !depth.suffix.empty(),
                       ": provided needs a suffix (provided:<suffix>, e.g. provided:sensor)");
  FREELOC_OPTION_CHECK("depth", depth.kind != DepthKind::kMast3r || UsesMast3r(),
                       ": mast3r comes from the MASt3R matcher's pointmaps; use matcher mast3r or mast3r+instances "
                       "(or depth metric3d / provided:<suffix>)");
  FREELOC_OPTION_CHECK(
      "solver", solver == SolverKind::kEssential || solver == SolverKind::kHybrid || depth.kind != DepthKind::kNone,
      ": " << ToString(solver) << " needs depth (depth provided:<suffix> or metric3d)");
  solve.Validate();
  pointmap.Validate();
  instances.Validate();
  multi_frame.Validate();
  inputs.Validate();
  runtime.Validate();
  models.Validate(*this);
}

std::string PipelineOptions::Summary() const {
  std::string s = "preset " + preset + ": matcher " + matcher.ToString() + ", depth " + depth.ToString() + ", solver " +
                  ToString(solver) + (solver == SolverKind::kEssential ? ", scale " + ToString(solve.scale) : "") +
                  (solver == SolverKind::kHybrid ? ", reprojection " + NumberText(solve.reprojection_px) + " px" +
                                                       (solve.depth_shifts ? ", depth shifts" : "")
                                                 : "") +
                  (solve.threshold_px ? ", threshold " + NumberText(*solve.threshold_px) + " px" : "");
  if (UsesDust3r()) s += ", dust3r " + models.dust3r_model + " at " + std::to_string(pointmap.dust3r_size);
  if (UsesMast3r())
    s += ", mast3r " + models.mast3r_model + " at " + std::to_string(pointmap.dust3r_size) + " (subsample " +
         std::to_string(pointmap.mast3r_subsample) + ")";
  if (UsesInstances())
    s += ", instances " + ToString(instances.instance_source) + ", instance-mode " + ToString(instances.instance_mode);
  if (UsesSegGpt()) s += ", seggpt " + models.seggpt_model;
  if (track == io::Track::kMultiFrame)
    s += ", track multi-frame (" + std::to_string(multi_frame.frames) + " frames, device poses " +
         ToString(multi_frame.device_poses) + ")";
  if (UsesMetric3d()) s += ", metric3d " + models.metric3d_model;
  if (UsesPointmapModel() || UsesMetric3d()) s += ", " + ToString(runtime.device) + " " + ToString(runtime.precision);
  return s;
}

}  // namespace freeloc::pipeline
