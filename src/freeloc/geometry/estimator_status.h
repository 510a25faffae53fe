// What a robust pose estimator of geometry/ reports: one typed outcome (with its text forms in one table) and the
// diagnostics of the search. The pipeline maps the outcome onto its own query status; nothing parses text.
#pragma once

#include "freeloc/core/enum_table.h"
#include "freeloc/geometry/ransac.h"

namespace freeloc::geometry {

enum class EstimatorOutcome {
  kOk,
  kWeakSupport,    // a model whose support is not clearly beyond chance: the pose is returned, success() false
  kTooFewMatches,  // fewer correspondences than the estimator's min_inliers (or its minimal sample)
  kNoConsensus,    // no model, or one whose support is what chance gives
  kDegenerate,     // the support cannot determine the model (collinear inliers, an implausible translation)
};

// Competing models (competing_models.h): what decided between the winner and a distinct model with nearly its
// support. kNone: there was no competitor; kSupport: nothing else told them apart.
enum class CompetitorDecision { kNone, kSupport, kCheirality, kDepth };

struct EstimatorStatus {
  EstimatorOutcome outcome = EstimatorOutcome::kNoConsensus;
  bool success() const { return outcome == EstimatorOutcome::kOk; }
  int chance_inliers = 0;  // inliers of the final model on shuffled pairs (what chance alone gives)
  int shuffled_best = -1;  // weak support only: the best search model's inliers on shuffled pairs (−1: not run)
  RansacStop stop = RansacStop::kNoModel;
  int num_matches = 0;
  int iterations = 0;
  int num_inliers = 0;
  int local_optimizations = 0;
  double refinement_cost = 0;  // robust cost after the final refinement
  // Competing models: how many distinct models had nearly the winner's support, what decided between them, and
  // how plausible the strongest loser stayed (its evidence ÷ the winner's, 0–1; 0 without competitor).
  int competitors = 0;
  CompetitorDecision decided_by = CompetitorDecision::kNone;
  double runner_up_plausibility = 0;
  int runner_up_inliers = 0;
  double time_ms = 0;
};

}  // namespace freeloc::geometry

namespace freeloc {
template <>
struct EnumTable<geometry::EstimatorOutcome> {
  static constexpr const char* kField = "estimator outcome";
  static constexpr EnumEntry<geometry::EstimatorOutcome> kEntries[] = {
      {geometry::EstimatorOutcome::kOk, "ok"},
      {geometry::EstimatorOutcome::kWeakSupport, "weak-support"},
      {geometry::EstimatorOutcome::kTooFewMatches, "too-few-matches"},
      {geometry::EstimatorOutcome::kNoConsensus, "no-consensus"},
      {geometry::EstimatorOutcome::kDegenerate, "degenerate"}};
};
template <>
struct EnumTable<geometry::CompetitorDecision> {
  static constexpr const char* kField = "decided by";
  static constexpr EnumEntry<geometry::CompetitorDecision> kEntries[] = {
      {geometry::CompetitorDecision::kNone, "none"},
      {geometry::CompetitorDecision::kSupport, "support"},
      {geometry::CompetitorDecision::kCheirality, "cheirality"},
      {geometry::CompetitorDecision::kDepth, "depth"}};
};
}  // namespace freeloc
