// What a query's relocalization gives back (the Relocalizer, the run controller, the records, the service and
// Python): its status, pose and confidence, the support behind it, what its stages cost, which intrinsics it used
// and, on the Multi Frame track, how its window voted. The options that produced it are in options.h.
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/enum_table.h"
#include "freeloc/core/rigid3d.h"

namespace freeloc::pipeline {

// What happened to a query: one text form each (EnumTable<QueryStatus>), used by the log, JSON records, the CLI
// and the submission (ok poses are submitted; with always_answer every other query too: weak-support with its pose
// and low confidence, the rest as the prior pose with confidence 0).
enum class QueryStatus {
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

// Where a frame's intrinsics came from, in the order freeloc prefers them: handed in (flags, Python), a file
// (intrinsics.txt), the photo's EXIF, the pointmap's focal (DUSt3R/MASt3R). docs/geometry.md "Intrinsics without a
// calibration".
enum class IntrinsicsSource { kNone, kGiven, kFile, kExif, kPointmap };

struct FrameIntrinsics {
  Camera camera;  // all zero while kNone
  IntrinsicsSource source = IntrinsicsSource::kNone;
  int orientation = 0;        // the EXIF orientation the decoder applied to the photo (0: no tag, 1: as stored)
  double pointmap_focal = 0;  // the pointmap's focal when one was estimated (estimate or check), else 0
  bool known() const { return source != IntrinsicsSource::kNone; }
};

// Multi-frame (pipeline/multi_frame.h): what each frame of an evaluated frame's window contributed.
struct WindowVote {
  std::string frame;                         // e.g. "seq1/frame_00011.jpg"
  QueryStatus status = QueryStatus::kError;  // its own relocalization against the reference
  std::string relation = "none";             // how it is tied to the evaluated frame: self | device | images | none
  bool used = false;                         // its rotation and its ray entered the fused pose
  double rotation_dev_deg = -1;              // its rotation vote's distance from the fused rotation (-1: no vote)
  double distance_m = 0;                     // its depth-based distance to the reference camera (0: none)
};
struct WindowSummary {
  int frames = 0, used = 0;
  // The device poses' fate in this window: used | ignored (<why>) | absent | off
  std::string device;
  std::string scale;  // where the metric distance came from: depth | tracker | images | depth+tracker | depth+images
  double depth_distance_m = 0, rig_distance_m = 0;  // the depth maps' and the rig's triangulated distance (0: none)
  std::vector<WindowVote> votes;                    // oldest first, the evaluated frame last
  bool empty() const { return frames == 0; }
};

// What a query's stages cost, milliseconds (the log, the records, the report and bench/relocalize).
struct QueryTimings {
  // decode: reading the photos and depth files (the caller's; `relocalize` both frames'); prepare: the inputs brought
  // to the working resolution and checked (input_checks.h) — `relocalize` adds the reference's own work here.
  double decode_ms = 0, prepare_ms = 0;
  double depth_ms = 0, match_ms = 0, instance_ms = 0, solve_ms = 0;
  // Inside match_ms / instance_ms (network matchers): the global pair's network pass, the query's own-pointmap pass
  // (the pair swapped, run for the focal check or MASt3R's query depth; 0 when nothing asked for it), SegGPT's
  // propagation, the masked pairs' network passes and how many masked pairs ran.
  double pair_ms = 0, own_pass_ms = 0, segment_ms = 0, instance_pass_ms = 0;
  int instance_pairs = 0;
};

struct QueryResult {
  std::string frame;
  QueryStatus status = QueryStatus::kError;
  std::string message;  // kError: which file and what went wrong
  // The words every surface uses (records, CLI, Python, report, docs): `status` says what happened; a query is
  // *solved* when its status is ok or ok-unit-translation (freeloc stands behind the pose) and *submitted* when a pose
  // for it goes into the submission — solved, or unsolved under always_answer (a weak-support pose with a confidence
  // below 10⁻³, else the prior pose with confidence 0).
  bool ok() const { return status == QueryStatus::kOk || status == QueryStatus::kOkUnitTranslation; }
  bool solved() const { return ok(); }
  bool metric() const { return status == QueryStatus::kOk; }
  std::string StatusText() const;  // "ok", "no-consensus", "error: <message>" — for people
  Rigid3d query_from_ref;
  // !ok() with always_answer: submitted anyway — a weak-support pose with its (low) confidence, else the prior
  // (identity) with confidence 0.
  bool submitted_unsolved = false;
  bool weak() const { return status == QueryStatus::kWeakSupport; }
  bool prior() const { return submitted_unsolved && !weak(); }  // the submitted pose is the prior
  bool submitted() const { return ok() || submitted_unsolved; }
  std::string route;  // the solver's route: "essential", "hybrid", "hybrid>essential" (fell back), "pnp", …
  // The confidence model (confidence.h) for every solver; official scale: its support; unit translation: the inlier
  // count; the prior pose: 0.
  double confidence = 0;
  int matches = 0, inliers = 0;
  std::vector<char> inlier_mask;          // per correspondence into the solver (not in the JSON records)
  int global_matches = 0;                 // dust3r matchers: before the instance merge
  int instances = 0, instances_used = 0;  // reference instances tried / whose matches replaced global ones
  int scale_inliers = 0;                  // correspondences agreeing on the metric scale
  double predicted_translation_m = 0;     // the predicted error (confidence.h)
  double predicted_rotation_deg = 0;
  QueryTimings timings;
  FrameIntrinsics ref_intrinsics, query_intrinsics;  // what the solver used, and where it came from
  WindowSummary window;                              // multi-frame only: how the window voted
  // What the plausible-input checks did to this query's inputs (input_checks.h): a resampled depth map, a bound
  // loosened from its default that the input needed; the confidence is lowered for each.
  std::vector<std::string> input_notes;
};

// What the per-scene caches did (for logs and tests).
struct CacheStats {
  int reference_encodings = 0;  // DUSt3R encoder passes of reference-side inputs (global + masked instances)
  int reference_reuses = 0;     // … and the passes saved by reusing them
  int reference_instances = 0;  // instance proposals of the current reference
  int depth_estimates = 0;      // Metric3D passes (reference once per scene + one per query)
  double reference_ms = 0;      // time spent on the current reference's own work
};

}  // namespace freeloc::pipeline

namespace freeloc {
template <>
struct EnumTable<pipeline::IntrinsicsSource> {
  static constexpr const char* kField = "intrinsics source";
  static constexpr EnumEntry<pipeline::IntrinsicsSource> kEntries[] = {
      {pipeline::IntrinsicsSource::kNone, "none"},
      {pipeline::IntrinsicsSource::kGiven, "given"},
      {pipeline::IntrinsicsSource::kFile, "file"},
      {pipeline::IntrinsicsSource::kExif, "exif"},
      {pipeline::IntrinsicsSource::kPointmap, "pointmap"}};
};
template <>
struct EnumTable<pipeline::QueryStatus> {
  static constexpr const char* kField = "status";
  static constexpr EnumEntry<pipeline::QueryStatus> kEntries[] = {
      {pipeline::QueryStatus::kOk, "ok"},
      {pipeline::QueryStatus::kOkUnitTranslation, "ok-unit-translation"},
      {pipeline::QueryStatus::kWeakSupport, "weak-support"},
      {pipeline::QueryStatus::kTooFewMatches, "too-few-matches"},
      {pipeline::QueryStatus::kNoConsensus, "no-consensus"},
      {pipeline::QueryStatus::kDegenerate, "degenerate"},
      {pipeline::QueryStatus::kNoDepth, "no-depth"},
      {pipeline::QueryStatus::kScaleNoValidDepth, "scale-no-valid-depth"},
      {pipeline::QueryStatus::kScaleNoConsensus, "scale-no-consensus"},
      {pipeline::QueryStatus::kError, "error"}};
};
}  // namespace freeloc
