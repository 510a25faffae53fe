#include "freeloc/pipeline/record.h"

#include <cmath>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "freeloc/core/error.h"
#include "freeloc/core/version.h"

namespace freeloc::pipeline {

namespace {

using Json = nlohmann::ordered_json;

Json OptionsObject(const PipelineOptions& o) {
  Json j = Json::object();
  for (const OptionField& f : OptionFields()) {
    const std::string v = GetOption(o, f.name);
    switch (f.type) {
      case OptionType::kText: j[f.name] = v; break;
      case OptionType::kInt: j[f.name] = std::stoll(v); break;
      case OptionType::kReal:  // a number, or the word `default` (solve.threshold_px unset)
        if (std::isdigit(static_cast<unsigned char>(v.back())))
          j[f.name] = std::stod(v);
        else
          j[f.name] = v;
        break;
    }
  }
  return j;
}

// A JSON value as an option's text form: strings as they are, numbers exactly, lists comma-joined, null empty.
std::string ValueText(const std::string& name, const Json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "1" : "0";
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  if (v.is_number()) return NumberText(v.get<double>());
  if (v.is_null()) return "";
  if (v.is_array()) {  // a list of names (scenes): strings and numbers only, nothing nested
    std::string s;
    for (const auto& e : v) {
      FREELOC_CHECK(!e.is_array() && !e.is_object(), name << ": a list holds names, not lists or objects");
      s += (s.empty() ? "" : ",") + ValueText(name, e);
    }
    return s;
  }
  FREELOC_THROW(name << ": expected a string, a number or a list");
}

PipelineOptions OptionsFromObject(const Json& j) {
  FREELOC_CHECK(j.is_object(), "options: expected a JSON object");
  PipelineOptions o;
  for (const auto& [name, value] : j.items()) {
    FREELOC_CHECK(value.is_string() || value.is_number(), name << ": expected a string or a number in the options");
    SetOption(&o, name, ValueText(name, value));
  }
  return o;
}

Json Parse(const std::string& text, const char* what) {
  Json j = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  FREELOC_CHECK(!j.is_discarded() && j.is_object(), what << ": not a JSON object");
  return j;
}

// "ok", "error", …, and the 0.1 form "error: <message>".
void ParseStatus(const std::string& text, QueryResult* r) {
  if (TryParseEnum(text, &r->status)) return;
  const size_t colon = text.find(": ");
  FREELOC_CHECK(colon != std::string::npos && TryParseEnum(text.substr(0, colon), &r->status),
                "status: '" << text << "' is not one of " << EnumNames<QueryStatus>());
  r->message = text.substr(colon + 2);
}

}  // namespace

std::string OptionsJson(const PipelineOptions& o) { return OptionsObject(o).dump(); }

PipelineOptions OptionsFromJson(const std::string& json) { return OptionsFromObject(Parse(json, "options")); }

namespace {

// {"fx", "fy", "cx", "cy", "source"} (+ "orientation" when the photo had the tag, "pointmap_focal" when estimated).
Json IntrinsicsObject(const FrameIntrinsics& f) {
  Json j = {{"fx", f.camera.fx},
            {"fy", f.camera.fy},
            {"cx", f.camera.cx},
            {"cy", f.camera.cy},
            {"source", ToString(f.source)}};
  if (f.orientation > 0) j["orientation"] = f.orientation;
  if (f.pointmap_focal > 0) j["pointmap_focal"] = f.pointmap_focal;
  return j;
}

FrameIntrinsics IntrinsicsFromJson(const Json& j) {
  FrameIntrinsics f;
  f.camera.fx = j.at("fx").get<double>();
  f.camera.fy = j.at("fy").get<double>();
  f.camera.cx = j.at("cx").get<double>();
  f.camera.cy = j.at("cy").get<double>();
  f.source = ParseEnum<IntrinsicsSource>(j.at("source").get<std::string>());
  f.orientation = j.value("orientation", 0);
  f.pointmap_focal = j.value("pointmap_focal", 0.0);
  return f;
}

}  // namespace

std::string QueryRecordJson(const std::string& scene, const QueryResult& r, const PipelineOptions* options,
                            int indent) {
  const auto q = r.query_from_ref.QuaternionWxyz();
  const auto& t = r.query_from_ref.translation;
  Json j = Json::object();
  if (!scene.empty()) j["scene"] = scene;
  if (!r.frame.empty()) j["frame"] = r.frame;
  j["status"] = ToString(r.status);
  if (!r.message.empty()) j["message"] = r.message;
  j["solved"] = r.solved();
  j["submitted"] = r.submitted();  // solved, or unsolved under always_answer (weak-support pose, or the prior)
  j["metric"] = r.metric();
  if (const std::string route = r.RouteText(); !route.empty()) j["route"] = route;
  j["qvec"] = {q[0], q[1], q[2], q[3]};
  j["tvec"] = {t.x(), t.y(), t.z()};
  // The same pose as COLMAP and hloc users read it: the query camera's centre in the reference frame (metres, or a
  // unit direction) and both 4×4 matrices, row by row.
  const Rigid3d ref_from_query = r.query_from_ref.Inverse();
  const Eigen::Vector3d centre = ref_from_query.translation;
  j["centre"] = {centre.x(), centre.y(), centre.z()};
  const auto matrix = [](const Rigid3d& p) {
    const Eigen::Matrix3d R = p.R();
    Json m = Json::array();
    for (int i = 0; i < 3; ++i) m.push_back({R(i, 0), R(i, 1), R(i, 2), p.translation[i]});
    m.push_back({0.0, 0.0, 0.0, 1.0});
    return m;
  };
  j["query_from_ref"] = matrix(r.query_from_ref);
  j["ref_from_query"] = matrix(ref_from_query);
  j["confidence"] = r.confidence;
  j["matches"] = r.matches;
  j["inliers"] = r.inliers;
  j["global_matches"] = r.global_matches;
  j["instances"] = r.instances;
  j["instances_used"] = r.instances_used;
  j["scale_inliers"] = r.scale_inliers;
  j["predicted_translation_m"] = r.predicted_translation_m;
  j["predicted_rotation_deg"] = r.predicted_rotation_deg;
  j["decode_ms"] = r.timings.decode_ms;
  j["prepare_ms"] = r.timings.prepare_ms;
  j["depth_ms"] = r.timings.depth_ms;
  j["match_ms"] = r.timings.match_ms;
  j["instance_ms"] = r.timings.instance_ms;
  j["solve_ms"] = r.timings.solve_ms;
  j["pair_ms"] = r.timings.pair_ms;
  j["own_pass_ms"] = r.timings.own_pass_ms;
  j["segment_ms"] = r.timings.segment_ms;
  j["instance_pass_ms"] = r.timings.instance_pass_ms;
  j["instance_pairs"] = r.timings.instance_pairs;
  if (r.ref_intrinsics.known() || r.query_intrinsics.known())
    j["intrinsics"] = {{"ref", IntrinsicsObject(r.ref_intrinsics)}, {"query", IntrinsicsObject(r.query_intrinsics)}};
  if (!r.input_notes.empty()) j["inputs"] = r.input_notes;
  if (!r.window.empty()) {
    const WindowSummary& w = r.window;
    Json votes = Json::array();
    for (const WindowVote& v : w.votes)
      votes.push_back({{"frame", v.frame},
                       {"status", ToString(v.status)},
                       {"relation", v.relation},
                       {"used", v.used},
                       {"rotation_dev_deg", v.rotation_dev_deg},
                       {"distance_m", v.distance_m}});
    j["window"] = {{"frames", w.frames},
                   {"used", w.used},
                   {"device", w.device},
                   {"scale", w.scale},
                   {"depth_distance_m", w.depth_distance_m},
                   {"rig_distance_m", w.rig_distance_m},
                   {"votes", votes}};
  }
  if (options) j["options"] = OptionsObject(*options);
  return j.dump(indent);
}

QueryResult QueryResultFromJson(const std::string& json, std::string* scene) {
  const Json j = Parse(json, "query record");
  QueryResult r;
  try {
    if (scene) *scene = j.value("scene", std::string());
    r.frame = j.value("frame", std::string());
    ParseStatus(j.at("status").get<std::string>(), &r);
    if (j.contains("message")) r.message = j.at("message").get<std::string>();
    r.confidence = j.at("confidence").get<double>();
    r.matches = j.at("matches").get<int>();
    r.inliers = j.at("inliers").get<int>();
    r.global_matches = j.value("global_matches", 0);
    r.instances = j.value("instances", 0);
    r.instances_used = j.value("instances_used", 0);
    r.scale_inliers = j.value("scale_inliers", 0);
    // "answered": the name in logs written before "submitted" (0.x); both mean the same for an unsolved query.
    r.submitted_unsolved = !r.ok() && (j.value("submitted", false) || j.value("answered", false));
    FREELOC_CHECK(r.SetRouteText(j.value("route", std::string())),
                  "route: '" << j.value("route", std::string()) << "' is not a route freeloc writes");
    r.predicted_translation_m = j.value("predicted_translation_m", 0.0);
    r.predicted_rotation_deg = j.value("predicted_rotation_deg", 0.0);
    r.timings.decode_ms = j.value("decode_ms", 0.0);
    r.timings.prepare_ms = j.value("prepare_ms", 0.0);
    r.timings.depth_ms = j.value("depth_ms", 0.0);
    r.timings.match_ms = j.value("match_ms", 0.0);
    r.timings.instance_ms = j.value("instance_ms", 0.0);
    r.timings.solve_ms = j.value("solve_ms", 0.0);
    if (j.contains("intrinsics")) {
      r.ref_intrinsics = IntrinsicsFromJson(j.at("intrinsics").at("ref"));
      r.query_intrinsics = IntrinsicsFromJson(j.at("intrinsics").at("query"));
    }
    r.timings.pair_ms = j.value("pair_ms", 0.0);
    r.timings.own_pass_ms = j.value("own_pass_ms", 0.0);
    r.timings.segment_ms = j.value("segment_ms", 0.0);
    r.timings.instance_pass_ms = j.value("instance_pass_ms", 0.0);
    r.timings.instance_pairs = j.value("instance_pairs", 0);
    if (j.contains("inputs")) r.input_notes = j.at("inputs").get<std::vector<std::string>>();
    if (j.contains("window")) {
      const Json& w = j.at("window");
      r.window.frames = w.at("frames").get<int>();
      r.window.used = w.at("used").get<int>();
      r.window.device = w.at("device").get<std::string>();
      r.window.scale = w.at("scale").get<std::string>();
      r.window.depth_distance_m = w.at("depth_distance_m").get<double>();
      r.window.rig_distance_m = w.at("rig_distance_m").get<double>();
      for (const Json& v : w.at("votes")) {
        WindowVote vote;
        vote.frame = v.at("frame").get<std::string>();
        vote.status = ParseEnum<QueryStatus>(v.at("status").get<std::string>());
        vote.relation = v.at("relation").get<std::string>();
        vote.used = v.at("used").get<bool>();
        vote.rotation_dev_deg = v.at("rotation_dev_deg").get<double>();
        vote.distance_m = v.at("distance_m").get<double>();
        r.window.votes.push_back(vote);
      }
    }
    const auto q = j.at("qvec").get<std::array<double, 4>>();
    const auto t = j.at("tvec").get<std::array<double, 3>>();
    r.query_from_ref = Rigid3d::FromWxyz(q, Eigen::Vector3d(t[0], t[1], t[2]));  // validated, normalised
    // A quaternion the pipeline wrote is unit to rounding: keep its exact coefficients, so that a resumed run
    // writes the same digits as an uninterrupted one (normalising again moves the last bit).
    const double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    if (std::abs(n2 - 1.0) < 1e-12) r.query_from_ref.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  } catch (const nlohmann::json::exception& e) {
    FREELOC_THROW("query record: " << e.what());
  }
  return r;
}

std::string RunHeaderJson(const RunHeader& h, const std::string& extra) {
  Json j = Json::object();
  j["freeloc_run"] = 1;
  j["freeloc_version"] = std::string(Version());
  j["options"] = OptionsObject(h.options);
  j["data"] = h.data;
  j["split"] = h.split;
  j["shard"] = h.shard.empty() ? Json(nullptr) : Json(h.shard);
  j["scenes"] = h.scenes;
  if (!extra.empty()) {
    const Json more = Parse(extra, "run header extra");  // named: items() must not outlive it
    for (const auto& [k, v] : more.items()) j[k] = v;
  }
  return j.dump();
}

bool SameResultOptions(const std::string& header_json, const PipelineOptions& options, std::string* why) {
  const Json j = Json::parse(header_json, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("freeloc_run") || !j.contains("options") ||
      !j["options"].is_object()) {
    if (why) *why = "not a freeloc run header";
    return false;
  }
  Json mine = OptionsObject(options), theirs = j["options"];
  mine.erase("threads");
  theirs.erase("threads");
  for (const auto& [k, v] : mine.items())
    if (!theirs.contains(k) || theirs[k] != v) {
      if (why) *why = k + " " + (theirs.contains(k) ? theirs[k].dump() : "absent") + " vs " + v.dump();
      return false;
    }
  return true;
}

OptionsFile ReadOptionsFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  FREELOC_CHECK(in, path << ": cannot read the options file; give a run's <submission>.json, its log or a JSON object");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  FREELOC_CHECK(text.size() <= (16u << 20), path << ": more than 16 MB is not an options file");
  // A log: its first line is the run header.
  Json j = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) j = Json::parse(text.substr(0, text.find('\n')), nullptr, false);
  FREELOC_CHECK(!j.is_discarded() && j.is_object(),
                path << ": not a JSON object (nor a log whose first line is one); give a run's <submission>.json");
  OptionsFile f;
  const bool nested = j.contains("options") && j.at("options").is_object();
  try {
    for (const auto& [name, value] : (nested ? j.at("options") : j).items()) f.options[name] = ValueText(name, value);
    if (nested)
      for (const auto& [name, value] : j.items())
        if (name != "options" && !value.is_object()) f.run[name] = ValueText(name, value);
  } catch (const Error& e) {
    FREELOC_THROW(path << ": " << e.what());
  }
  return f;
}

}  // namespace freeloc::pipeline
