#include "freeloc/pipeline/report_recorder.h"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/eval/report.h"
#include "freeloc/eval/view3d.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/submission.h"

namespace freeloc::pipeline {

namespace fs = std::filesystem;

namespace {
io::OfficialPose Official(const Rigid3d& query_from_ref) {
  io::OfficialPose p;
  const Eigen::Quaterniond c2w = query_from_ref.rotation.conjugate();
  p.q_c2w = {c2w.w(), c2w.x(), c2w.y(), c2w.z()};
  p.t_c2w = query_from_ref.Center();
  return p;
}
}  // namespace

std::string VisualName(const std::string& scene, const std::string& frame) {
  std::string n = "q_" + scene + "_" + fs::path(frame).replace_extension("").string() + ".jpg";
  for (char& c : n)
    if (c == '/' || c == '\\') c = '_';
  return n;
}

namespace {

// The report's view of one query without ground truth.
eval::ReportQuery ReportQueryOf(const std::string& scene, const QueryResult& r) {
  eval::ReportQuery q;
  q.scene = scene;
  q.frame = r.frame;
  q.status = ToString(r.status);
  q.message = r.message;
  q.confidence = r.confidence;
  q.matches = r.matches;
  q.inliers = r.inliers;
  q.instances = r.instances;
  q.instances_used = r.instances_used;
  q.has_pose = r.ok() || r.weak();
  q.solved = r.solved();
  q.submitted = r.submitted();
  q.centre = r.query_from_ref.Center();
  if (!r.window.empty()) {
    const WindowSummary& w = r.window;
    char line[256];
    std::snprintf(line, sizeof(line),
                  "%d of %d frames used; distance from %s (depth maps %.3f m, rig %.3f m); device poses %s", w.used,
                  w.frames, w.scale.empty() ? "the evaluated frame" : w.scale.c_str(), w.depth_distance_m,
                  w.rig_distance_m, w.device.c_str());
    q.window = line;
    for (const WindowVote& v : w.votes) {
      char dev[32], dist[32];
      std::snprintf(dev, sizeof(dev), v.rotation_dev_deg < 0 ? "–" : "%.3f", v.rotation_dev_deg);
      std::snprintf(dist, sizeof(dist), v.distance_m > 0 ? "%.3f" : "–", v.distance_m);
      q.window_votes.push_back({v.frame, ToString(v.status), v.relation, v.used ? "yes" : "no", dev, dist});
    }
  }
  return q;
}

// Writes `dir`/`name` (the pair with its matches and depth maps) and `name`.3d.js (the 3D view's data: the
// reference's points, its camera, the predicted and — when given — the true query camera).
void RenderDetail(const std::string& dir, const std::string& name, const Image& ref, const Image& query,
                  const QueryResult& r, const matching::Correspondences& c, const Relocalizer& reloc,
                  const Camera& query_camera, const Rigid3d* truth, const eval::ReportOptions& o) {
  eval::WriteQueryVisual(dir + "/" + name, ref, query, c.Rows(), r.inlier_mask, c.source, reloc.reference_depth(),
                         reloc.last_query_depth(), o);
  std::vector<eval::View3dCamera> cams;
  Camera kr = reloc.reference_intrinsics().camera,
         kq = r.query_intrinsics.known() ? r.query_intrinsics.camera : query_camera;
  kr.width = ref.width;
  kr.height = ref.height;
  kq.width = query.width;
  kq.height = query.height;
  cams.push_back({Rigid3d(), kr, "#33dd66", "reference"});
  if (r.ok() || r.weak()) cams.push_back({r.query_from_ref, kq, "#ff9922", "predicted"});
  if (truth) cams.push_back({*truth, kq, "#3399ff", "true"});
  const std::string js = "window.freelocViews=window.freelocViews||{};freelocViews[" + nlohmann::json(name).dump() +
                         "]=" + eval::View3dJson(ref, reloc.reference_depth(), kr, cams, 6000) + ";\n";
  io::WriteFileAtomic(dir + "/" + name + ".3d.js", js.data(), js.size());
}

}  // namespace

eval::ReportQuery ToReportQuery(const io::MapfreeScene& scene, const QueryResult& r) {
  eval::ReportQuery q = ReportQueryOf(scene.name, r);
  const auto gt = scene.gt.find(r.frame);
  if (gt == scene.gt.end()) return q;
  q.gt_centre = gt->second.Center();
  q.has_gt = true;
  if (!q.has_pose) return q;
  for (const io::MapfreeFrame& f : scene.queries) {
    if (f.name != r.frame) continue;
    const std::array<float, 4> k = {static_cast<float>(f.camera.fx), static_cast<float>(f.camera.fy),
                                    static_cast<float>(f.camera.cx), static_cast<float>(f.camera.cy)};
    q.err =
        eval::ComputeFrameErrors(Official(gt->second), Official(r.query_from_ref), k, f.camera.width, f.camera.height);
    q.has_errors = true;
  }
  return q;
}

ReportRecorder::ReportRecorder(std::string dir, eval::ReportOptions options) : dir_(std::move(dir)), o_(options) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  FREELOC_CHECK(fs::is_directory(dir_), dir_ << ": cannot create the report folder (" << ec.message() << ")");
}

void ReportRecorder::Consider(const io::MapfreeScene& scene, const QueryResult& r, const matching::Correspondences& c,
                              const Relocalizer& reloc) {
  const eval::ReportQuery q = ToReportQuery(scene, r);
  const double bad = eval::ReportBadness(q);
  const std::string name = VisualName(scene.name, r.frame);
  bool keep = false;
  if (per_scene_[scene.name] < o_.per_scene) {
    ++per_scene_[scene.name];
    pinned_.insert(name);
    keep = true;
  } else if (!q.has_pose && failures_ < o_.failures) {
    ++failures_;
    pinned_.insert(name);
    keep = true;
  } else if (q.has_errors && (static_cast<int>(worst_.size()) < o_.worst || bad > worst_.begin()->first)) {
    keep = true;
  }
  if (!keep) return;
  if (q.has_errors && q.has_pose && !pinned_.count(name)) {
    worst_.emplace(bad, name);
    if (static_cast<int>(worst_.size()) > o_.worst) {
      std::error_code ec;
      fs::remove(dir_ + "/" + worst_.begin()->second, ec);  // no longer among the worst
      fs::remove(dir_ + "/" + worst_.begin()->second + ".3d.js", ec);
      worst_.erase(worst_.begin());
    }
  }
  try {
    const io::MapfreeFrame* f = nullptr;
    for (const auto& x : scene.queries)
      if (x.name == r.frame) f = &x;
    if (!f) return;
    if (ref_scene_ != scene.name) {
      ref_ = scene.LoadImage(scene.reference);
      ref_scene_ = scene.name;
    }
    const Image query = scene.LoadImage(*f);
    const auto gt = scene.gt.find(r.frame);
    RenderDetail(dir_, name, ref_, query, r, c, reloc, f->camera, gt != scene.gt.end() ? &gt->second : nullptr, o_);
  } catch (const std::exception& e) {
    FREELOC_LOG(WARNING) << "report: " << scene.name << "/" << r.frame << ": no detail image (" << e.what() << ")";
  }
}

void ReportRecorder::Write(const std::string& split_dir, const std::vector<std::string>& scenes,
                           const std::map<std::string, io::MapfreeScene>& loaded,
                           const std::map<std::string, std::vector<QueryResult>>& results,
                           const std::string& submission) const {
  std::vector<eval::ReportQuery> queries;
  for (const auto& name : scenes)
    for (const auto& r : results.at(name)) queries.push_back(ToReportQuery(loaded.at(name), r));
  // The final selection over every rank's candidates: the first per scene, the failures, the worst; the rest of the
  // rendered images are removed.
  std::vector<size_t> order(queries.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return eval::ReportBadness(queries[a]) > eval::ReportBadness(queries[b]);
  });
  std::set<size_t> chosen;
  std::map<std::string, int> per_scene;
  for (size_t i = 0; i < queries.size(); ++i)
    if (per_scene[queries[i].scene]++ < o_.per_scene) chosen.insert(i);
  int failures = 0, worst = 0;
  for (size_t i : order) {
    if (!queries[i].has_pose && failures < o_.failures) chosen.insert(i), ++failures;
    if (queries[i].has_errors && queries[i].has_pose && worst < o_.worst) chosen.insert(i), ++worst;
  }
  int shown = 0;
  for (size_t i = 0; i < queries.size(); ++i) {
    const std::string file = VisualName(queries[i].scene, queries[i].frame);
    const bool exists = fs::exists(dir_ + "/" + file);
    if (chosen.count(i) && exists && shown < o_.max_details) {
      queries[i].visual = file;
      ++shown;
    } else if (exists) {
      std::error_code ec;
      fs::remove(dir_ + "/" + file, ec);
      fs::remove(dir_ + "/" + file + ".3d.js", ec);
    }
  }
  bool any_gt = false;
  for (const auto& name : scenes) any_gt = any_gt || loaded.at(name).has_gt();
  std::unique_ptr<eval::EvalRun> run;
  if (any_gt) {
    try {
      run = std::make_unique<eval::EvalRun>(eval::RunEvaluation(split_dir, scenes, submission, o_.track));
    } catch (const Error& e) {
      FREELOC_LOG(WARNING) << "report: no metrics (" << e.what() << ")";
    }
  }
  eval::WriteRunReport(dir_, "freeloc run — " + fs::path(submission).filename().string(), queries, run.get());
}

void WritePairReport(const std::string& dir, const std::string& title, const std::string& query_name, const Image& ref,
                     const Image& query, const QueryResult& r, const matching::Correspondences& c,
                     const Relocalizer& reloc) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  FREELOC_CHECK(fs::is_directory(dir), dir << ": cannot create the report folder (" << ec.message() << ")");
  eval::ReportQuery q = ReportQueryOf("pair", r);
  q.frame = query_name;
  q.visual = VisualName("pair", "query");
  RenderDetail(dir, q.visual, ref, query, r, c, reloc, r.query_intrinsics.camera, nullptr, eval::ReportOptions());
  eval::WriteRunReport(dir, title, {q}, nullptr);
}

}  // namespace freeloc::pipeline
