// The pose room's options (docs/geometry.md): which solver front turns correspondences and depths into a pose, and
// its thresholds. PipelineOptions holds them as `solver` and `solve` (pipeline/options.h; one row each in
// pipeline/option_table.def). Light header.
#pragma once

#include <optional>

#include "freeloc/core/enum_table.h"
#include "freeloc/geometry/scale_method.h"

namespace freeloc::pose {

// essential (+ metric scale when both depths exist) | pnp (reference depth) | procrustes (both depths) | hybrid
// (depth-aware, essential fallback).
enum class SolverKind { kEssential, kPnp, kProcrustes, kHybrid };

struct SolveOptions {
  // essential (and hybrid's fallback): anchored — the depths anchor |t| (the vote's error grows with
  // depth ÷ baseline); robust — freeloc's scale vote; official — the benchmark's vote.
  geometry::ScaleMethod scale = geometry::ScaleMethod::kAnchored;
  // The inlier threshold, pixels; unset: the solver's own default (DefaultThresholdPx).
  std::optional<double> threshold_px;
  double reprojection_px = 16;  // hybrid: two-way reprojection threshold through the depths, pixels
  int depth_shifts = 0;         // hybrid: 1 = also estimate an additive shift of each depth map
  // Robust searches over at least this many matches check each hypothesis sequentially and give up on a set with no
  // consensus (geometry/ransac.h, docs/geometry.md "Dense sets"); the hybrid route's essential guard applies the rule
  // to every set (estimate_pose.cc). 0: never — the full search to its budget.
  int sprt_min_matches = 2000;
  void Validate() const;  // throws freeloc::Error naming the option
  // The threshold `solver` runs with: the one set, else its default.
  double ThresholdPx(SolverKind solver) const;
};

// Each solver's own inlier threshold, pixels, where it is written: the geometry options' defaults (essential and
// hybrid: the Sampson error, 1 px; PnP: the benchmark's reprojection threshold, 3 px). Procrustes has none (its
// inliers are 3D distances): PnP's is reported.
double DefaultThresholdPx(SolverKind solver);

}  // namespace freeloc::pose

namespace freeloc {
template <>
struct EnumTable<pose::SolverKind> {
  static constexpr const char* kField = "solver";
  static constexpr EnumEntry<pose::SolverKind> kEntries[] = {{pose::SolverKind::kEssential, "essential"},
                                                             {pose::SolverKind::kPnp, "pnp"},
                                                             {pose::SolverKind::kProcrustes, "procrustes"},
                                                             {pose::SolverKind::kHybrid, "hybrid"}};
};
}  // namespace freeloc
