// What a pose estimate is (docs/architecture.md §1, steps 4–6): the pose `query_from_ref`, what happened (`Status`,
// one text form each), the route that made it (`Route`, an enum with its string table), its support, its predicted
// error and confidence (confidence.h) and the evidence that decided them. Every solver front (estimate_pose.h) and the
// Multi Frame fusion (window_fusion.h) return one; the pipeline's QueryResult is one with the query's context added
// (pipeline/query_result.h). Light header.
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/enum_table.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/pose/confidence.h"

namespace freeloc::pose {

// What happened to a query: one text form each (EnumTable<Status>), used by the log, JSON records, the CLI and the
// submission (solved poses are submitted; with always_answer every other query too: weak-support with its pose and
// low confidence, the rest as the prior pose with confidence 0). The pipeline calls it QueryStatus.
enum class Status {
  kOk,                 // metric pose
  kOkUnitTranslation,  // essential without depth: rotation + translation direction (unit norm)
  kWeakSupport,        // a model whose support is not clearly beyond chance: its pose, with a confidence below
                       // every ok answer; submitted under always_answer (never counted as solved)
  kTooFewMatches,
  kNoConsensus,        // the robust estimator found no model
  kDegenerate,         // the inliers span (almost) a single pixel: no geometry
  kNoDepth,            // the depth stage needs provided depth and a frame has none
  kScaleNoValidDepth,  // essential: no inlier has depth in both frames
  kScaleNoConsensus,   // essential: the depths disagree on the scale
  kError,              // an exception inside the query (bad image, bad depth, a network error): see `message`
};

// The route a pose took through the solver fronts (estimate_pose.h): essential (5-point + scale), rotation (no
// parallax: a rotation alone, its translation from the depths), hybrid (both depths anchor it), hybrid with the
// reference depth alone (the query's disagreed on the scale), hybrid fell back to essential, pnp, procrustes.
enum class Route { kNone, kEssential, kRotation, kHybrid, kHybridReferenceDepth, kHybridFellBack, kPnp, kProcrustes };

struct PoseEstimate {
  Status status = Status::kError;
  std::string message;  // why, where a status needs words (kError: which file and what went wrong; no parallax)
  Rigid3d query_from_ref;
  Route route = Route::kNone;
  bool window_fused = false;  // Multi Frame: the window's fusion made this pose (window_fusion.h)
  // The confidence model (confidence.h) for every solver; official scale: its support; unit translation: the inlier
  // count; the prior pose: 0.
  double confidence = 0;
  int matches = 0, inliers = 0;
  std::vector<char> inlier_mask;       // per correspondence into the solver (not in the JSON records)
  int scale_inliers = 0;               // correspondences agreeing on the metric scale
  double predicted_translation_m = 0;  // the predicted error (confidence.h); 0 where no model ran
  double predicted_rotation_deg = 0;
  PoseEvidence evidence;  // what the predicted error was computed from (empty where none was)

  bool ok() const { return status == Status::kOk || status == Status::kOkUnitTranslation; }
  bool solved() const { return ok(); }
  bool metric() const { return status == Status::kOk; }
  bool weak() const { return status == Status::kWeakSupport; }
  // The route as the records and people read it: "essential", "hybrid>essential", "pnp+window", "window", "".
  std::string RouteText() const;
  // Sets route and window_fused from RouteText's form; false when `text` is not one.
  bool SetRouteText(const std::string& text);
  // The predicted error and confidence of `e` by the confidence model (confidence.h), kept with the evidence.
  void SetConfidence(const PoseEvidence& e);
};

}  // namespace freeloc::pose

namespace freeloc {
template <>
struct EnumTable<pose::Status> {
  static constexpr const char* kField = "status";
  static constexpr EnumEntry<pose::Status> kEntries[] = {{pose::Status::kOk, "ok"},
                                                         {pose::Status::kOkUnitTranslation, "ok-unit-translation"},
                                                         {pose::Status::kWeakSupport, "weak-support"},
                                                         {pose::Status::kTooFewMatches, "too-few-matches"},
                                                         {pose::Status::kNoConsensus, "no-consensus"},
                                                         {pose::Status::kDegenerate, "degenerate"},
                                                         {pose::Status::kNoDepth, "no-depth"},
                                                         {pose::Status::kScaleNoValidDepth, "scale-no-valid-depth"},
                                                         {pose::Status::kScaleNoConsensus, "scale-no-consensus"},
                                                         {pose::Status::kError, "error"}};
};
template <>
struct EnumTable<pose::Route> {
  static constexpr const char* kField = "route";
  static constexpr EnumEntry<pose::Route> kEntries[] = {
      {pose::Route::kNone, ""},
      {pose::Route::kEssential, "essential"},
      {pose::Route::kRotation, "rotation"},
      {pose::Route::kHybrid, "hybrid"},
      {pose::Route::kHybridReferenceDepth, "hybrid (reference depth)"},
      {pose::Route::kHybridFellBack, "hybrid>essential"},
      {pose::Route::kPnp, "pnp"},
      {pose::Route::kProcrustes, "procrustes"}};
};
}  // namespace freeloc
