// What a query's relocalization gives back (the Relocalizer, the run controller, the records, the service and
// Python): its status, pose and confidence, the support behind it, what its stages cost, which intrinsics it used
// and, on the Multi Frame track, how its window voted. The options that produced it are in options.h.
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/enum_table.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/inputs/input_options.h"
#include "freeloc/pose/pose_estimate.h"
#include "freeloc/pose/window_fusion.h"

namespace freeloc::pipeline {

// What happened to a query (pose/pose_estimate.h: one text form each, EnumTable<pose::Status>).
using QueryStatus = pose::Status;

// Where a frame's intrinsics came from and what they are (inputs/input_options.h).
using inputs::FrameIntrinsics;
using inputs::IntrinsicsSource;

// Multi-frame: how an evaluated frame's window voted (pose/window_fusion.h).
using pose::WindowSummary;
using pose::WindowVote;

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

// A query's answer: its pose estimate (pose/pose_estimate.h: status, message, query_from_ref, route, confidence,
// matches, inliers, scale_inliers, predicted errors, evidence) with the query's context.
struct QueryResult : pose::PoseEstimate {
  std::string frame;
  // The words every surface uses (records, CLI, Python, report, docs): `status` says what happened; a query is
  // *solved* when its status is ok or ok-unit-translation (freeloc stands behind the pose) and *submitted* when a pose
  // for it goes into the submission — solved, or unsolved under always_answer (a weak-support pose with a confidence
  // below 10⁻³, else the prior pose with confidence 0).
  std::string StatusText() const;  // "ok", "no-consensus", "error: <message>" — for people
  // !ok() with always_answer: submitted anyway — a weak-support pose with its (low) confidence, else the prior
  // (identity) with confidence 0.
  bool submitted_unsolved = false;
  bool prior() const { return submitted_unsolved && !weak(); }  // the submitted pose is the prior
  bool submitted() const { return ok() || submitted_unsolved; }
  int global_matches = 0;                 // dust3r matchers: before the instance merge
  int instances = 0, instances_used = 0;  // reference instances tried / whose matches replaced global ones
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

namespace freeloc {}  // namespace freeloc
