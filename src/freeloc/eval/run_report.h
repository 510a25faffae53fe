// The HTML report of a run (`freeloc run --report DIR`): a self-contained static folder — index.html with inline CSS
// and script, JPEG and SVG files beside it, nothing fetched — that opens from disk in any browser: the map-free
// metrics and CDF plots (eval's), per-scene rows, a sortable table of every query, the failures grouped by status,
// and for the worst queries and a sample per scene a detail view: both images side by side with the
// correspondences drawn (inliers green, outliers red, instance matches in their instance's colour), both depth maps
// colour-mapped, a top-down plot of the predicted and ground-truth camera centres, status, confidence and errors.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "freeloc/core/depth_map.h"
#include "freeloc/core/image.h"
#include "freeloc/eval/metrics.h"
#include "freeloc/eval/report.h"

namespace freeloc::eval {

// One query as the report shows it.
struct ReportQuery {
  std::string scene, frame;
  std::string status, message;  // the pipeline's status text, and the error message when there is one
  double confidence = 0;
  int matches = 0, inliers = 0, instances = 0, instances_used = 0;
  bool has_pose = false;    // the query has an estimate, ok or weak-support (submitted priors count as failures)
  bool solved = false;      // status ok or ok-unit-translation (pipeline/query_result.h's words)
  bool submitted = false;   // a pose for it is in the submission (solved, weak-support, or the prior)
  bool has_gt = false;      // the scene has this query's ground truth (gt_centre)
  bool has_errors = false;  // … and the scene has ground truth: `err` holds the official errors
  FrameErrors err;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(), gt_centre = Eigen::Vector3d::Zero();  // in the reference frame
  std::string visual;  // the detail image's file name in the report folder ("" = none)
  // Multi-frame: how the window voted — a summary line, then one row per frame (frame, status, relation, used,
  // rotation deviation, depth distance).
  std::string window;
  std::vector<std::vector<std::string>> window_votes;
};

// How much of a run gets a detail view (docs/report.md): the `worst` largest pose errors (max(t/0.25 m, R/5°)),
// the first `per_scene` queries of each scene, up to `failures` failed queries, at most `max_details` in all.
struct ReportOptions {
  int worst = 20;
  int per_scene = 1;
  int failures = 10;
  int max_details = 200;
  int thumb_width = 640;                      // width of a detail image (both photos side by side)
  int max_lines = 150;                        // correspondences drawn per query (evenly subsampled)
  io::Track track = io::Track::kSingleFrame;  // which frames the metrics score
};

// A depth map as the report and the service page draw it: turbo over the valid depths' 2nd–98th percentile (near
// blue, far red), invalid pixels dark grey; `w`×`h` RGB (0: the map's own size).
Image DepthColourImage(const DepthMap& depth, int w = 0, int h = 0);

// The score that orders queries from worst to best: failures first, then max(t/0.25 m, R/5°).
double ReportBadness(const ReportQuery& q);

// Writes `path` (JPEG): reference | query scaled to `o.thumb_width` in all, the correspondences (x_ref, y_ref, x_q,
// y_q in original pixels) drawn with their inlier flags and instance ids (−1 = global; `inlier` and `source` may be
// empty), and below them the two depth maps colour-mapped (turbo, near = blue), when given.
void WriteQueryVisual(const std::string& path, const Image& ref, const Image& query,
                      const std::vector<Eigen::Vector4d>& matches, const std::vector<char>& inlier,
                      const std::vector<int>& source, const DepthMap& depth_ref, const DepthMap& depth_query,
                      const ReportOptions& o);

// Writes `dir`/index.html (+ eval's metrics.json, errors.csv and cdf_*.svg when `eval` is given). `queries` in
// scene order; their `visual` files must already be in `dir`.
void WriteRunReport(const std::string& dir, const std::string& title, const std::vector<ReportQuery>& queries,
                    const EvalRun* eval);

}  // namespace freeloc::eval
