// Metric scale of the translation from depth ("D.Scale", docs/geometry.md): each inlier correspondence is
// back-projected with its depth in both frames, p_r = d_r·K_r⁻¹[u,v,1]ᵀ, p_q = d_q·K_q⁻¹[u',v',1]ᵀ, and gives the
// candidate s_i = (p_q − R·p_r)·t̂ (the translation that best aligns the pair along t̂).
//  * kOfficial — the map-free baseline exactly: depth read at int-truncated pixels (which are also back-projected),
//    every candidate tried as a hypothesis with a fixed 0.1 m window, the first with most support wins, no refit,
//    confidence = that support.
//  * kRobust — freeloc: bilinear depth at the sub-pixel location, a per-candidate window relative to the points'
//    depth (depth noise grows with depth), exhaustive consensus over all candidates weighted by 1/window (a kernel
//    density: precise near points are not outvoted by wide far-point windows), an inverse-variance weighted
//    refit on the consensus set (iterated), and a confidence from the refit's standard error that predicts the
//    scale's accuracy.
//  * kAnchored — the depth anchors the scale instead of voting on a difference of two depths: each inlier is
//    triangulated with the unit-baseline pose, and its depth divided by the triangulated depth says what |t| is
//    (log ratios, median/MAD-trimmed mean). The reference depth anchors; when the query depth's anchoring agrees
//    within a factor 2 the two are combined by their geometric mean. A depth-map scale error of e % becomes e % of
//    |t| (halved in log terms when both agree), not e % of the scene depth as in the vote.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/enum_table.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/geometry/scale_method.h"

namespace freeloc::geometry {

struct ScaleOptions {
  ScaleMethod method = ScaleMethod::kRobust;
  double official_threshold_m = 0.1;  // kOfficial: |s_j − s| < 0.1 m
  double relative_threshold = 0.02;   // kRobust: window = relative_threshold · mean depth of the pair (bench/scale)
  double min_threshold_m = 0.005;     // kRobust: floor of the window
  int refit_iterations = 3;
  int min_inliers = 3;  // kRobust: a scale fewer correspondences agree on is no consensus (one point proves nothing)
  void Validate() const;
};

// What the scale estimate found (EnumTable<geometry::ScaleOutcome> below).
enum class ScaleOutcome {
  kOk,
  kNoValidDepth,  // no correspondence has depth in both frames
  kNoConsensus,   // the depths disagree on the scale
};

struct ScaleResult {
  ScaleOutcome outcome = ScaleOutcome::kNoConsensus;
  bool success() const { return outcome == ScaleOutcome::kOk; }
  double scale = 0;               // metric length of t (signed, along t̂)
  double confidence = 0;          // kOfficial: support count; kRobust: predicted accuracy, higher is better
  int num_candidates = 0;         // correspondences with valid depth in both frames
  int num_inliers = 0;            // consensus size
  double relative_std_error = 0;  // kRobust: standard error of the scale / |scale|
  double std_error_m = 0;         // kRobust: standard error of the scale, metres
  double mean_distance_m = 0;     // kRobust: mean distance to the camera of the consensus points, metres
};

// The depth maps' common scale error, which no disagreement between two maps can show: a prior of 5 % of |t| in
// every metric scale's predicted error (the anchored scale, the hybrid solver, PnP, Procrustes).
constexpr double kCommonDepthScaleError = 0.05;

// Median/MAD-trimmed mean: the mean of the values within max(min_window, 3 robust standard deviations) of the
// median, its standard error (1 with fewer than 2 kept) and the number kept. `v` must not be empty.
struct TrimmedMeanResult {
  double mean = 0, std_error = 0;
  int kept = 0;
};
TrimmedMeanResult TrimmedMean(const std::vector<double>& v, double min_window);

// `px_ref`/`px_query`: the inlier correspondences in original pixels; `query_from_ref` with unit translation.
ScaleResult EstimateMetricScale(const std::vector<Eigen::Vector2d>& px_ref,
                                const std::vector<Eigen::Vector2d>& px_query, const Rigid3d& query_from_ref,
                                const DepthMap& depth_ref, const DepthMap& depth_query, const Camera& ref,
                                const Camera& query, const ScaleOptions& options = {});

// The anchored scale's two halves apart: log |t| as the reference depth map alone and as the query depth map alone
// anchor it (median/MAD-trimmed means of the inliers' log ratios, their standard errors and the points kept; kept 0:
// that map gave none). `query_from_ref`'s translation only gives the direction. Either map may be empty.
struct ScaleAnchors {
  double log_ref = 0, se_ref = 0, log_query = 0, se_query = 0;
  int kept_ref = 0, kept_query = 0;
};
ScaleAnchors AnchorScales(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                          const Rigid3d& query_from_ref, const DepthMap& depth_ref, const DepthMap& depth_query,
                          const Camera& ref, const Camera& query);

// Depth at a sub-pixel location by bilinear interpolation of the 4 neighbours (pixel centres at integers); 0 when
// any neighbour is invalid or the location is outside the map.
float BilinearDepth(const DepthMap& d, double x, double y);

}  // namespace freeloc::geometry

namespace freeloc {
template <>
struct EnumTable<geometry::ScaleOutcome> {
  static constexpr const char* kField = "scale outcome";
  static constexpr EnumEntry<geometry::ScaleOutcome> kEntries[] = {
      {geometry::ScaleOutcome::kOk, "ok"},
      {geometry::ScaleOutcome::kNoValidDepth, "no-valid-depth"},
      {geometry::ScaleOutcome::kNoConsensus, "no-consensus"}};
};
}  // namespace freeloc
