// `freeloc run`, `freeloc relocalize` and `freeloc demo`: the relocalization pipeline from the command line.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/progress.h"
#include "freeloc/eval/report.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/io/submission.h"
#include "freeloc/pipeline/relocalizer.h"

#ifndef FREELOC_DEMO_DIR
#define FREELOC_DEMO_DIR "data/demo"
#endif

namespace freeloc::cli {

namespace {

struct Overrides {
  std::string preset = "sift-essential", matcher, depth, solver, scale, instance_mode;
  std::string models, dust3r_model, seggpt_model, metric3d_model;
  double threshold = -1;
  int dust3r_size = 0;
  const GlobalOptions* global = nullptr;  // --device, --threads
};

void AddOverrides(CLI::App* sub, Overrides* o) {
  sub->add_option("--preset", o->preset,
                  "sift-essential (default), sift-pnp, sift-procrustes, precomputed:<name>-<solver>, seed, "
                  "seed-no-instance, seed-provided-depth, dust3r");
  sub->add_option("--matcher", o->matcher, "override: sift | dust3r | dust3r+instances | precomputed:<name>");
  sub->add_option("--depth", o->depth, "override: provided:<suffix> | metric3d | none");
  sub->add_option("--solver", o->solver, "override: essential | pnp | procrustes");
  sub->add_option("--scale", o->scale, "override: robust | official");
  sub->add_option("--threshold", o->threshold, "override: inlier threshold in pixels");
  sub->add_option("--instance-mode", o->instance_mode, "override: mask (default) | crop");
  sub->add_option("--models", o->models,
                  "folder holding the published weights files (then $FREELOC_MODELS; see docs/models.md)");
  sub->add_option("--dust3r,--dust3r-model", o->dust3r_model, "DUSt3R weights (.pth, or model.safetensors)");
  sub->add_option("--seggpt", o->seggpt_model, "SegGPT weights (seggpt_vit_large.pth, or model.safetensors)");
  sub->add_option("--metric3d", o->metric3d_model, "Metric3D v2 weights (metric_depth_vit_*_800k.pth, …)");
  sub->add_option("--dust3r-size", o->dust3r_size, "DUSt3R input size (default 512)");
}

pipeline::PipelineOptions Resolve(const Overrides& ov) {
  pipeline::PipelineOptions o = pipeline::ResolvePreset(ov.preset);
  if (!ov.matcher.empty()) o.matcher = ov.matcher;
  if (!ov.depth.empty()) o.depth = ov.depth;
  if (!ov.solver.empty()) o.solver = ov.solver;
  if (!ov.scale.empty()) o.scale = ov.scale;
  if (ov.threshold > 0) o.threshold_px = ov.threshold;
  if (!ov.instance_mode.empty()) o.instance_mode = ov.instance_mode;
  o.models_dir = ov.models;
  if (!ov.dust3r_model.empty()) o.dust3r_model = ov.dust3r_model;
  if (!ov.seggpt_model.empty()) o.seggpt_model = ov.seggpt_model;
  if (!ov.metric3d_model.empty()) o.metric3d_model = ov.metric3d_model;
  if (ov.dust3r_size > 0) o.dust3r_size = ov.dust3r_size;
  if (ov.global) {
    o.device = ov.global->device;
    o.threads = ov.global->threads;
  }
  pipeline::FindModels(&o);
  o.Validate();
  return o;
}

struct RunOptions {
  Overrides ov;
  std::string data, split = "val", scenes, out, log, shard;
  bool resume = false;
};

// "i/n" (1 ≤ i ≤ n) → {i, n}; {0, 0} when it is not of that form.
std::pair<int, int> ParseShard(const std::string& text) {
  int i = 0, n = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%d/%d%c", &i, &n, &tail) != 2 || n < 1 || i < 1 || i > n) return {0, 0};
  return {i, n};
}

// Shard i of n takes every n-th scene of the sorted list, starting at the i-th.
std::vector<std::string> ShardScenes(const std::vector<std::string>& scenes, const std::string& shard) {
  if (shard.empty()) return scenes;
  const auto [i, n] = ParseShard(shard);
  std::vector<std::string> mine;
  for (size_t k = static_cast<size_t>(i - 1); k < scenes.size(); k += static_cast<size_t>(n)) mine.push_back(scenes[k]);
  return mine;
}

nlohmann::ordered_json QueryToJson(const std::string& scene, const pipeline::QueryResult& q) {
  const auto qv = q.query_from_ref.QuaternionWxyz();
  const auto& t = q.query_from_ref.translation;
  return {{"scene", scene},
          {"frame", q.frame},
          {"status", q.status},
          {"confidence", q.confidence},
          {"matches", q.matches},
          {"inliers", q.inliers},
          {"global_matches", q.global_matches},
          {"instances", q.instances},
          {"instances_used", q.instances_used},
          {"scale_inliers", q.scale_inliers},
          {"depth_ms", q.depth_ms},
          {"match_ms", q.match_ms},
          {"instance_ms", q.instance_ms},
          {"solve_ms", q.solve_ms},
          {"ok", q.ok},
          {"qvec", {qv[0], qv[1], qv[2], qv[3]}},
          {"tvec", {t.x(), t.y(), t.z()}}};
}

pipeline::QueryResult QueryFromJson(const nlohmann::json& j) {
  pipeline::QueryResult q;
  q.frame = j.at("frame").get<std::string>();
  q.status = j.at("status").get<std::string>();
  q.ok = j.at("ok").get<bool>();
  q.confidence = j.at("confidence").get<double>();
  q.matches = j.at("matches").get<int>();
  q.inliers = j.at("inliers").get<int>();
  q.global_matches = j.value("global_matches", int(0));
  q.instances = j.value("instances", int(0));
  q.instances_used = j.value("instances_used", int(0));
  q.scale_inliers = j.value("scale_inliers", int(0));
  q.depth_ms = j.value("depth_ms", double(0));
  q.match_ms = j.at("match_ms").get<double>();
  q.instance_ms = j.value("instance_ms", double(0));
  q.solve_ms = j.at("solve_ms").get<double>();
  const auto qv = j.at("qvec").get<std::array<double, 4>>();
  const auto t = j.at("tvec").get<std::array<double, 3>>();
  q.query_from_ref = Rigid3d::FromWxyz(qv, Eigen::Vector3d(t[0], t[1], t[2]));
  return q;
}

// Progress of a run: `<out>.progress.jsonl`, a header line with the options, then one line per finished scene
// (appended and synced as each scene ends). `--resume` reads it back and skips those scenes; a last line cut short
// by a crash is ignored. The file is removed once the submission is written.
class ProgressFile {
 public:
  ProgressFile(const std::string& out, const std::string& options)
      : path_(out + ".progress.jsonl"), options_(options) {}
  const std::string& path() const { return path_; }

  // Scenes already done, read when resuming; empty when there is no progress file yet.
  std::map<std::string, std::vector<pipeline::QueryResult>> Load() const {
    std::map<std::string, std::vector<pipeline::QueryResult>> done;
    std::ifstream in(path_);
    if (!in) return done;
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) lines.push_back(line);
    FREELOC_CHECK(!lines.empty(), path_ + ": empty progress file; delete it or run without --resume");
    nlohmann::json header = nlohmann::json::parse(lines[0], nullptr, /*allow_exceptions=*/false);
    FREELOC_CHECK(header.is_object() && header.contains("freeloc_progress") && header.contains("options") &&
                      header["options"].is_string(),
                  path_ + ": not a freeloc progress file; delete it or run without --resume");
    FREELOC_CHECK(header["options"] == options_, path_ + ": written with different options (" +
                                                     header["options"].get<std::string>() + " vs " + options_ +
                                                     "); rerun with the same options, or without --resume");
    for (size_t i = 1; i < lines.size(); ++i) {
      const nlohmann::json j = nlohmann::json::parse(lines[i], nullptr, /*allow_exceptions=*/false);
      if (j.is_discarded()) {
        FREELOC_CHECK(i + 1 == lines.size(), path_ + ": line " + std::to_string(i + 1) +
                                                 " is not JSON; delete the file or run without --resume");
        break;  // the interrupted last write
      }
      std::vector<pipeline::QueryResult> qs;
      try {
        for (const auto& q : j.at("queries")) qs.push_back(QueryFromJson(q));
        done[j.at("scene").get<std::string>()] = std::move(qs);
      } catch (const nlohmann::json::exception& e) {
        throw Error(path_ + ": line " + std::to_string(i + 1) + " is not a scene record (" + e.what() +
                    "); delete the file or run without --resume");
      }
    }
    return done;
  }

  // Starts a new file (header only) unless resuming from an existing one.
  void Open(bool keep) {
    const bool exists = std::filesystem::exists(path_);
    file_ = std::fopen(path_.c_str(), keep && exists ? "a" : "w");
    FREELOC_CHECK(file_ != nullptr, path_ + ": cannot write the progress file; check the folder of --out");
    if (!(keep && exists)) Append(nlohmann::ordered_json{{"freeloc_progress", 1}, {"options", options_}});
  }
  void AppendScene(const std::string& scene, const std::vector<pipeline::QueryResult>& res) {
    nlohmann::ordered_json j = {{"scene", scene}, {"queries", nlohmann::ordered_json::array()}};
    for (const auto& q : res) j["queries"].push_back(QueryToJson(scene, q));
    Append(j);
  }
  void Finish() {
    Close();
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
  ~ProgressFile() { Close(); }

 private:
  void Append(const nlohmann::ordered_json& j) {
    const std::string line = j.dump() + "\n";
    FREELOC_CHECK(std::fwrite(line.data(), 1, line.size(), file_) == line.size() && std::fflush(file_) == 0,
                  path_ + ": write failed; check free disk space");
    fsync(fileno(file_));
  }
  void Close() {
    if (file_) std::fclose(file_);
    file_ = nullptr;
  }
  std::string path_, options_;
  FILE* file_ = nullptr;
};

// Runs every scene (skipping those a resumed progress file already holds), writes the submission (successful
// queries only) and the JSON-lines log.
std::map<std::string, std::vector<pipeline::QueryResult>> RunAll(const RunOptions& r,
                                                                 const pipeline::PipelineOptions& o,
                                                                 const std::vector<std::string>& scenes,
                                                                 const std::map<std::string, MapfreeScene>& loaded) {
  ProgressFile progress(r.out, o.Summary());
  std::map<std::string, std::vector<pipeline::QueryResult>> results;
  if (r.resume) {
    auto done = progress.Load();
    size_t reused = 0;
    for (const auto& name : scenes)
      if (done.count(name)) {
        results[name] = std::move(done[name]);
        ++reused;
      }
    FREELOC_LOG(INFO) << "resuming from " << progress.path() << ": " << reused << " of " << scenes.size()
                      << " scenes already done";
  } else if (std::filesystem::exists(progress.path())) {
    FREELOC_LOG(WARNING) << progress.path()
                         << " exists from an earlier run; starting over (use --resume to continue it)";
  }
  progress.Open(r.resume);
  // One bar over the queries (rate and ETA in queries), its label counting scenes.
  int64_t total = 0;
  for (const auto& name : scenes) total += static_cast<int64_t>(loaded.at(name).queries.size());
  ProgressBar bar("queries", total);
  size_t scenes_done = 0;
  auto label = [&] { bar.SetLabel("scene " + std::to_string(scenes_done) + "/" + std::to_string(scenes.size()) +
                                  ", queries"); };
  label();
  for (const auto& name : scenes) {
    if (!results.count(name)) {
      pipeline::CacheStats cs;
      results[name] = pipeline::RelocalizeScene(loaded.at(name), o, &cs, [&](const pipeline::QueryResult&) { bar.Increment(); });
      if (o.UsesDust3r() || o.UsesMetric3d())
        FREELOC_LOG(DEBUG) << name << ": reference work " << cs.reference_ms << " ms, " << cs.reference_instances
                           << " reference instances, DUSt3R reference encodings " << cs.reference_encodings
                           << " (reused " << cs.reference_reuses << "), Metric3D passes " << cs.depth_estimates;
      progress.AppendScene(name, results[name]);
    } else {
      bar.Increment(static_cast<int64_t>(results[name].size()));
    }
    ++scenes_done;
    label();
  }
  bar.Finish();
  std::map<std::string, std::vector<SubmissionEntry>> sub;
  std::string log;
  for (const auto& name : scenes) {
    sub[name];  // an empty pose file: the scene was attempted
    for (const auto& q : results[name]) {
      if (q.ok) sub[name].push_back({q.frame, q.query_from_ref, std::max(0.0, q.confidence)});
      nlohmann::ordered_json j = QueryToJson(name, q);
      j.erase("ok");
      j.erase("qvec");
      j.erase("tvec");
      log += j.dump() + "\n";
    }
  }
  WriteSubmission(r.out, sub);
  if (!r.log.empty()) WriteFileAtomic(r.log, log.data(), log.size());
  progress.Finish();
  return results;
}

// Every scene read before any work: a missing or malformed intrinsics.txt/poses.txt is one error now, not after
// hours, and a provided-depth suffix must exist for at least one reference (a typo is an error, not N failures).
std::map<std::string, MapfreeScene> LoadScenes(const std::string& split_dir, const std::vector<std::string>& scenes,
                                               const pipeline::PipelineOptions& o) {
  bool any_depth = !o.UsesProvidedDepth();
  std::string example;
  std::map<std::string, MapfreeScene> loaded;
  for (const auto& name : scenes) {
    const MapfreeScene& scene = loaded[name] = MapfreeScene::Load(split_dir + "/" + name);
    if (!o.UsesProvidedDepth()) continue;
    const std::string p = scene.DepthPath(scene.reference, o.depth.substr(9));
    if (example.empty()) example = p;
    any_depth = any_depth || std::filesystem::exists(p);
  }
  FREELOC_CHECK(any_depth, "--depth " << o.depth << ": no scene has this depth (e.g. " << example
                                      << " is missing); check the suffix, or use --depth metric3d or none");
  return loaded;
}

int RunRun(const RunOptions& r) {
  const pipeline::PipelineOptions o = Resolve(r.ov);
  std::string split_dir;
  const std::vector<std::string> scenes = ShardScenes(ResolveScenes(r.data, r.split, r.scenes, &split_dir), r.shard);
  FREELOC_LOG(INFO) << o.Summary();
  const auto loaded = LoadScenes(split_dir, scenes, o);
  pipeline::LoadModels(o);  // before the progress file and the first scene
  if (!r.shard.empty()) FREELOC_LOG(INFO) << "shard " << r.shard << ": " << scenes.size() << " scenes";
  const auto results = RunAll(r, o, scenes, loaded);
  size_t ok = 0, total = 0;
  for (const auto& [s, v] : results)
    for (const auto& q : v) {
      ++total;
      ok += q.ok;
    }
  std::printf("%zu of %zu queries relocalized in %zu scenes; submission written to %s\n", ok, total, scenes.size(),
              r.out.c_str());
  return 0;
}

struct RelocOptions {
  Overrides ov;
  std::string ref, query, ref_k, query_k, intrinsics, ref_depth, query_depth, save_matches;
  bool json = false;
};

// The camera of `image` in an intrinsics file (map-free `intrinsics.txt` lines: path fx fy cx cy W H): the line
// whose path is the image's path, a suffix of it, or has its file name.
Camera CameraFromFile(const std::string& file, const std::string& image) {
  const std::vector<MapfreeFrame> frames = ReadIntrinsicsFile(file);
  const std::string base = std::filesystem::path(image).filename().string();
  const MapfreeFrame* by_name = nullptr;
  for (const auto& f : frames) {
    if (image == f.name || (image.size() > f.name.size() && image.compare(image.size() - f.name.size() - 1,
                                                                         f.name.size() + 1, "/" + f.name) == 0))
      return f.camera;
    if (!by_name && std::filesystem::path(f.name).filename().string() == base) by_name = &f;
  }
  FREELOC_CHECK(by_name != nullptr, file << ": no line for " << image
                                         << "; each line is 'path fx fy cx cy width height' with the image's path "
                                            "or file name");
  return by_name->camera;
}

int RunRelocalize(const RelocOptions& r) {
  pipeline::PipelineOptions o = Resolve(r.ov);
  if (r.ref_depth.empty() && r.query_depth.empty() && r.ov.depth.empty() && o.UsesProvidedDepth()) o.depth = "none";
  o.Validate();
  FREELOC_CHECK(r.intrinsics.empty() != (r.ref_k.empty() && r.query_k.empty()),
                "give --ref-intrinsics and --query-intrinsics (fx,fy,cx,cy), or --intrinsics FILE, not both");
  FREELOC_CHECK(!r.intrinsics.empty() || (!r.ref_k.empty() && !r.query_k.empty()),
                "give both --ref-intrinsics and --query-intrinsics (fx,fy,cx,cy), or --intrinsics FILE");
  const Camera kr = r.intrinsics.empty() ? Camera::FromString(r.ref_k, "--ref-intrinsics")
                                         : CameraFromFile(r.intrinsics, r.ref),
               kq = r.intrinsics.empty() ? Camera::FromString(r.query_k, "--query-intrinsics")
                                         : CameraFromFile(r.intrinsics, r.query);
  FREELOC_CHECK(o.matcher == "sift" || o.UsesDust3r(),
                "relocalize works on images: use the sift, dust3r or dust3r+instances matcher (precomputed needs a "
                "scene)");
  DepthMap dr, dq;
  if (!r.ref_depth.empty()) dr = ReadDepthPng(r.ref_depth);
  if (!r.query_depth.empty()) dq = ReadDepthPng(r.query_depth);
  matching::Correspondences matches;
  const auto q = pipeline::RelocalizePair(ReadImage(r.ref), ReadImage(r.query), kr, kq, dr, dq, o, nullptr,
                                          r.save_matches.empty() ? nullptr : &matches);
  if (!r.save_matches.empty()) WriteCorrespondences(r.save_matches, matches);
  const auto qv = q.query_from_ref.QuaternionWxyz();
  const auto& t = q.query_from_ref.translation;
  if (r.json) {
    nlohmann::ordered_json j = {{"status", q.status},
                                {"qvec", {qv[0], qv[1], qv[2], qv[3]}},
                                {"tvec", {t.x(), t.y(), t.z()}},
                                {"confidence", q.confidence},
                                {"num_matches", q.matches},
                                {"num_inliers", q.inliers},
                                {"num_global_matches", q.global_matches},
                                {"instances", q.instances},
                                {"instances_used", q.instances_used},
                                {"scale_inliers", q.scale_inliers},
                                {"depth_ms", q.depth_ms},
                                {"match_ms", q.match_ms},
                                {"instance_ms", q.instance_ms},
                                {"solve_ms", q.solve_ms},
                                {"options", o.Summary()}};
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf(
        "%s\nstatus:      %s\nqvec (wxyz): %.9f %.9f %.9f %.9f\ntvec:        %.6f %.6f %.6f %s\n"
        "confidence:  %.6g\nmatches:     %d (%d inliers)\ninstances:   %d of %d used\n"
        "times:       depth %.0f ms, match %.0f ms, instances %.0f ms, solve %.0f ms\n",
        o.Summary().c_str(), q.status.c_str(), qv[0], qv[1], qv[2], qv[3], t.x(), t.y(), t.z(),
        q.status == "ok-unit-translation" ? "(unit norm: no depth)" : "(metres)", q.confidence, q.matches, q.inliers,
        q.instances_used, q.instances, q.depth_ms, q.match_ms, q.instance_ms, q.solve_ms);
  }
  return q.ok ? 0 : 1;
}

int RunDemo(const std::string& data_dir, const std::string& models, const GlobalOptions& global) {
  RunOptions r;
  r.data = data_dir;
  const std::string tmp =
      (std::filesystem::temp_directory_path() / ("freeloc_demo_" + std::to_string(getpid()) + ".zip")).string();
  r.out = tmp;
  r.ov.global = &global;
  r.ov.models = models;
  // The best preset whose weights are installed: the full method when all three networks are found.
  pipeline::PipelineOptions seed = pipeline::ResolvePreset("seed");
  seed.models_dir = models;
  pipeline::FindModels(&seed);
  std::string missing;
  if (seed.dust3r_model.empty()) missing += " DUSt3R";
  if (seed.seggpt_model.empty()) missing += " SegGPT";
  if (seed.metric3d_model.empty()) missing += " Metric3D";
  r.ov.preset = missing.empty() ? "seed" : "sift-essential";
  const pipeline::PipelineOptions o = Resolve(r.ov);
  std::printf("freeloc demo — preset %s on the bundled TUM RGB-D scenes (%s)\n", o.preset.c_str(), data_dir.c_str());
  std::printf("(%s)\n", o.Summary().c_str());
  if (!missing.empty())
    std::printf("(the full method, preset seed, needs the DUSt3R, SegGPT and Metric3D weights; not found:%s. Put the\n"
                " published files in a folder and pass --models DIR or set FREELOC_MODELS; see docs/models.md)\n",
                missing.c_str());
  std::printf("\n");
  std::string split_dir;
  const std::vector<std::string> scenes = ResolveScenes(data_dir, "val", "", &split_dir);
  const auto loaded = LoadScenes(split_dir, scenes, o);
  const auto results = RunAll(r, o, scenes, loaded);
  std::printf("| scene | query | status | inliers | rot err (°) | centre err (cm) |\n|---|---|---|---|---|---|\n");
  for (const auto& name : scenes) {
    const MapfreeScene& scene = loaded.at(name);
    for (const auto& q : results.at(name)) {
      if (!q.ok || !scene.gt.count(q.frame)) {
        std::printf("| %s | %s | %s | %d | – | – |\n", name.c_str(), q.frame.c_str(), q.status.c_str(), q.inliers);
        continue;
      }
      const Rigid3d& gt = scene.gt.at(q.frame);
      std::printf("| %s | %s | %s | %d | %.3f | %.2f |\n", name.c_str(), q.frame.c_str(), q.status.c_str(), q.inliers,
                  RotationAngleDeg(q.query_from_ref.rotation, gt.rotation),
                  100 * (q.query_from_ref.Center() - gt.Center()).norm());
    }
  }
  std::printf("\n");
  const eval::EvalRun run = eval::RunEvaluation(split_dir, scenes, tmp);
  std::printf("%s", eval::MarkdownReport(run).c_str());
  std::error_code ec;
  std::filesystem::remove(tmp, ec);
  if (o.UsesProvidedDepth())
    std::printf("\n(s00001 has no depth maps, so its queries cannot get a metric pose: they count as failures.)\n");
  return 0;
}

}  // namespace

void RegisterRun(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto r = std::make_shared<RunOptions>();
  r->ov.global = &global;
  auto* sub = app.add_subcommand("run", "Relocalize every query of every scene into a map-free submission ZIP");
  sub->add_option("--data", r->data, "dataset root (holding val/ test/) or a split folder")->required();
  sub->add_option("--split", r->split, "split folder (default val)");
  sub->add_option("--scenes", r->scenes, "comma-separated scene names (default: all)");
  sub->add_option("--out", r->out, "submission ZIP (written atomically)")->required();
  sub->add_option("--log", r->log, "JSON-lines log, one record per query");
  sub->add_flag("--resume", r->resume,
                "continue an interrupted run from <out>.progress.jsonl (same options), skipping finished scenes");
  sub->add_option("--shard", r->shard,
                  "i/n: only every n-th scene starting at the i-th (1 ≤ i ≤ n); join the shards with freeloc merge")
      ->check(CLI::Validator(
          [](std::string& v) {
            return ParseShard(v).first ? std::string() : "expected i/n with 1 <= i <= n, e.g. 2/4";
          },
          "I/N"));
  AddOverrides(sub, &r->ov);
  sub->callback([r, run] { *run = [r] { return RunRun(*r); }; });

  auto q = std::make_shared<RelocOptions>();
  q->ov.global = &global;
  auto* rs = app.add_subcommand("relocalize", "Pose of one query image relative to one reference image");
  rs->add_option("--ref", q->ref, "reference image")->required();
  rs->add_option("--query", q->query, "query image")->required();
  rs->add_option("--ref-intrinsics", q->ref_k, "fx,fy,cx,cy");
  rs->add_option("--query-intrinsics", q->query_k, "fx,fy,cx,cy");
  rs->add_option("--intrinsics", q->intrinsics,
                 "instead of the two above: a file of 'path fx fy cx cy W H' lines (map-free intrinsics.txt)");
  rs->add_option("--save-matches", q->save_matches, "write the correspondences (x_ref y_ref x_query y_query per line)");
  rs->add_option("--ref-depth", q->ref_depth, "reference depth PNG (uint16 mm)");
  rs->add_option("--query-depth", q->query_depth, "query depth PNG (uint16 mm)");
  rs->add_flag("--json", q->json, "one JSON object");
  AddOverrides(rs, &q->ov);
  rs->callback([q, run] { *run = [q] { return RunRelocalize(*q); }; });
}

void RegisterDemo(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto data = std::make_shared<std::string>(FREELOC_DEMO_DIR);
  auto models = std::make_shared<std::string>();
  auto* sub = app.add_subcommand("demo", "Relocalize the bundled TUM sample scenes and print errors and metrics");
  sub->add_option("--data", *data, "demo data (default: the repository's data/demo)");
  sub->add_option("--models", *models, "folder with the published weights (then $FREELOC_MODELS): runs preset seed");
  sub->callback([data, models, run, &global] {
    *run = [data, models, &global] { return RunDemo(*data, *models, global); };
  });
}

}  // namespace freeloc::cli
