// A map-free scene through a Relocalizer (relocalize_scene.h): the reference once, then each query (or each
// evaluated frame's window); errors isolated per query.
#include "freeloc/pipeline/relocalize_scene.h"

#include <filesystem>
#include <map>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/pipeline/multi_frame.h"

namespace freeloc::pipeline {

namespace {
// The first line of an exception's text (LibTorch's messages carry a backtrace after it), prefixed with `file`
// unless it already names it.
std::string ErrorMessage(const std::exception& e, const std::string& file) {
  std::string what = e.what();
  const size_t nl = what.find('\n');
  if (nl != std::string::npos) what.resize(nl);
  if (what.empty()) what = "unknown error";
  return what.find(file) == std::string::npos ? file + ": " + what : what;
}
}  // namespace

namespace {

std::vector<QueryResult> FailScene(const io::MapfreeScene& scene, const PipelineOptions& o, const std::string& message,
                                   const std::function<void(const QueryResult&)>& on_query) {
  FREELOC_LOG(WARNING) << scene.name << ": " << message;
  std::vector<QueryResult> out;
  for (size_t i : AnsweredQueries(scene, o)) {
    QueryResult r;
    r.frame = scene.queries[i].name;
    r.status = QueryStatus::kError;
    r.message = message;
    AnswerUnsolved(o, &r);
    out.push_back(r);
    if (on_query) on_query(r);
  }
  return out;
}

// The scene's provided depth of `f` when the depth stage reads it and the file exists; empty otherwise (naming the
// file it looked for).
DepthMap ProvidedDepthOf(const io::MapfreeScene& scene, const io::MapfreeFrame& f, const PipelineOptions& o) {
  if (!o.UsesProvidedDepth()) return {};
  const std::string path = scene.DepthPath(f, o.depth.suffix);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    DepthMap none;
    none.source = path;  // named in the query's no-depth message
    return none;
  }
  return scene.LoadDepth(f, o.depth.suffix);
}

// A query that failed on an exception (a damaged image or depth map, a network error): status error naming the
// file, logged, answered as an unsolved query is.
QueryResult FailedQuery(const io::MapfreeScene& scene, const io::MapfreeFrame& f, const std::exception& e,
                        const PipelineOptions& o) {
  QueryResult r;
  r.status = QueryStatus::kError;
  r.message = ErrorMessage(e, scene.FramePath(f));
  r.frame = f.name;
  FREELOC_LOG(WARNING) << scene.name << "/" << f.name << ": " << r.message;
  AnswerUnsolved(o, &r);
  return r;
}

// The scene's device poses for the Multi Frame track: empty when off, absent or unreadable (said once per scene).
std::map<std::string, Rigid3d> SceneDevicePoses(const io::MapfreeScene& scene, const PipelineOptions& o) {
  if (o.multi_frame.device_poses == DevicePoseUse::kIgnore) return {};
  const std::string path = scene.DevicePosesPath();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    FREELOC_LOG(INFO) << scene.name << ": no poses_device.txt; the windows are tied together by the images alone";
    return {};
  }
  try {
    return io::ReadDevicePoses(path);
  } catch (const std::exception& e) {
    FREELOC_LOG(WARNING) << scene.name << ": " << e.what() << "; the device poses are ignored for this scene";
    return {};
  }
}

// The Multi Frame track: one result per evaluated frame (linear positions 9, 19, …), each from its window. Only
// the window's frames are read for it.
std::vector<QueryResult> RelocalizeWindows(const io::MapfreeScene& scene, Relocalizer& reloc,
                                           const std::vector<std::vector<Eigen::Vector4d>>& pre,
                                           const std::function<void(const QueryResult&)>& on_query,
                                           const MatchesCallback& on_matches) {
  const PipelineOptions& o = reloc.options();
  const std::map<std::string, Rigid3d> device = SceneDevicePoses(scene, o);
  std::vector<QueryResult> out;
  for (const io::QueryWindow& win : io::MultiFrameWindows(scene, o.multi_frame.frames)) {
    const io::MapfreeFrame& q = scene.queries[win.evaluated];
    std::vector<WindowFrame> frames;
    for (size_t i : win.frames) {
      const io::MapfreeFrame& f = scene.queries[i];
      WindowFrame wf;
      wf.name = f.name;
      wf.camera = f.camera;
      wf.inputs.intrinsics_source = IntrinsicsSource::kFile;
      wf.inputs.correspondences = pre.empty() ? nullptr : &pre[i];
      auto it = device.find(f.name);
      if (it != device.end()) {
        wf.has_device = true;
        wf.device_from_query = it->second;
      }
      try {
        wf.image = scene.LoadImage(f, o.WorkingMaxSide());
        wf.inputs.depth = ProvidedDepthOf(scene, f, o);
      } catch (const std::exception& e) {
        // A damaged window frame loses its vote; a damaged evaluated frame is the query's error.
        if (i == win.evaluated) {
          frames.clear();
          out.push_back(FailedQuery(scene, q, e, o));
          break;
        }
        FREELOC_LOG(WARNING) << scene.name << "/" << f.name << ": " << ErrorMessage(e, scene.FramePath(f))
                             << " (left out of the window of " << q.name << ")";
        wf.image = Image();
      }
      frames.push_back(std::move(wf));
    }
    if (frames.empty()) {
      if (on_matches) on_matches(out.back(), {});
      if (on_query) on_query(out.back());
      continue;
    }
    QueryResult r;
    matching::Correspondences c;
    try {
      r = RelocalizeWindow(reloc, std::move(frames), on_matches ? &c : nullptr);
    } catch (const std::exception& e) {
      r = FailedQuery(scene, q, e, o);
    }
    r.frame = q.name;
    if (!r.window.empty() && r.window.device.rfind("ignored", 0) == 0)
      FREELOC_LOG(INFO) << scene.name << "/" << q.name << ": device poses " << r.window.device;
    if (on_matches) on_matches(r, c);
    out.push_back(r);
    if (on_query) on_query(r);
  }
  return out;
}

}  // namespace

std::vector<size_t> AnsweredQueries(const io::MapfreeScene& scene, const PipelineOptions& o) {
  std::vector<size_t> out;
  if (o.track == io::Track::kMultiFrame) {
    for (const io::QueryWindow& w : io::MultiFrameWindows(scene, o.multi_frame.frames)) out.push_back(w.evaluated);
  } else {
    for (size_t i = 0; i < scene.queries.size(); ++i) out.push_back(i);
  }
  return out;
}

std::vector<QueryResult> RelocalizeScene(const io::MapfreeScene& scene, Relocalizer& reloc,
                                         const std::function<void(const QueryResult&)>& on_query,
                                         const MatchesCallback& on_matches) {
  const PipelineOptions& o = reloc.options();
  std::vector<std::vector<Eigen::Vector4d>> pre;
  try {
    FrameInputs ref;
    ref.intrinsics_source = IntrinsicsSource::kFile;
    ref.depth = ProvidedDepthOf(scene, scene.reference, o);
    if (o.UsesProvidedDepth() && ref.depth.empty())
      FREELOC_LOG(WARNING) << scene.name << ": no '" << o.depth.suffix << "' depth for the reference ("
                           << scene.DepthPath(scene.reference, o.depth.suffix) << "); no query gets a metric pose"
                           << (o.solve.always_answer ? " (each is submitted with the prior pose, confidence 0)" : "");
    reloc.SetReference(scene.LoadImage(scene.reference, o.WorkingMaxSide()), scene.reference.camera, std::move(ref));
    if (o.UsesPrecomputed()) pre = scene.LoadCorrespondences(o.matcher.correspondences);
  } catch (const std::exception& e) {
    // A missing or damaged reference (or correspondence file) fails the scene's queries; the run goes on.
    return FailScene(scene, o, "reference: " + ErrorMessage(e, scene.FramePath(scene.reference)), on_query);
  }
  if (o.track == io::Track::kMultiFrame) return RelocalizeWindows(scene, reloc, pre, on_query, on_matches);
  std::vector<QueryResult> out;
  for (size_t i = 0; i < scene.queries.size(); ++i) {
    const io::MapfreeFrame& q = scene.queries[i];
    QueryResult r;
    matching::Correspondences c;
    try {
      FrameInputs in;
      in.intrinsics_source = IntrinsicsSource::kFile;
      in.depth = ProvidedDepthOf(scene, q, o);
      in.correspondences = pre.empty() ? nullptr : &pre[i];
      r = reloc.Relocalize(scene.LoadImage(q, o.WorkingMaxSide()), q.camera, std::move(in), on_matches ? &c : nullptr);
    } catch (const std::exception& e) {
      r = FailedQuery(scene, q, e, o);  // a bad query fails alone; the run goes on
    }
    r.frame = q.name;
    if (on_matches) on_matches(r, c);
    out.push_back(r);
    if (on_query) on_query(r);
  }
  return out;
}

std::vector<QueryResult> RelocalizeScene(const io::MapfreeScene& scene, const PipelineOptions& o, CacheStats* stats,
                                         const std::function<void(const QueryResult&)>& on_query) {
  Relocalizer reloc(o);  // validates and loads the networks: a bad weights file stops here
  auto out = RelocalizeScene(scene, reloc, on_query);
  if (stats) *stats = reloc.stats();
  return out;
}

}  // namespace freeloc::pipeline
