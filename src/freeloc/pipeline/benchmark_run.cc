#include "freeloc/pipeline/benchmark_run.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/progress.h"
#include "freeloc/io/correspondence_file.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/submission.h"
#include "freeloc/pipeline/record.h"

namespace freeloc::pipeline {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------------------------
// Shards and scenes

Shard Shard::FromString(const std::string& text) {
  Shard s;
  char tail = 0;
  FREELOC_CHECK(std::sscanf(text.c_str(), "%d/%d%c", &s.index, &s.count, &tail) == 2 && s.count >= 1 &&
                    s.index >= 1 && s.index <= s.count,
                "shard: '" << text << "' is not i/n with 1 <= i <= n (e.g. 2/4)");
  return s;
}

std::string Shard::ToString() const {
  return whole() ? "" : std::to_string(index) + "/" + std::to_string(count);
}

std::vector<std::string> Shard::Select(const std::vector<std::string>& scenes) const {
  if (whole()) return scenes;
  std::vector<std::string> mine;
  for (size_t k = static_cast<size_t>(index - 1); k < scenes.size(); k += static_cast<size_t>(count))
    mine.push_back(scenes[k]);
  return mine;
}

void RunSpec::Validate() const {
  FREELOC_CHECK(!data.empty(), "data: give the dataset root or a split folder");
  FREELOC_CHECK(!out.empty(), "out: give the submission ZIP to write");
  FREELOC_CHECK(shard.whole() || (shard.index >= 1 && shard.index <= shard.count),
                "shard: " << shard.index << "/" << shard.count << " is not i/n with 1 <= i <= n");
}

std::vector<std::string> ResolveScenes(const std::string& data, const std::string& split,
                                       const std::vector<std::string>& only, std::string* split_dir) {
  *split_dir = ResolveSplitDir(data, split);
  std::vector<std::string> scenes = ListScenes(*split_dir, only);
  FREELOC_CHECK(!scenes.empty(), *split_dir << ": no scene folders to process");
  return scenes;
}

namespace {

// Every scene read before any work: a missing or malformed intrinsics.txt/poses.txt is one error now, not after
// hours, and a provided-depth suffix must exist for at least one reference (a typo is an error, not N failures).
std::map<std::string, MapfreeScene> LoadScenes(const std::string& split_dir, const std::vector<std::string>& scenes,
                                               const PipelineOptions& o) {
  bool any_depth = !o.UsesProvidedDepth();
  std::string example;
  std::map<std::string, MapfreeScene> loaded;
  for (const auto& name : scenes) {
    const MapfreeScene& scene = loaded[name] = MapfreeScene::Load(split_dir + "/" + name);
    if (!o.UsesProvidedDepth()) continue;
    const std::string p = scene.DepthPath(scene.reference, o.depth.suffix);
    if (example.empty()) example = p;
    std::error_code ec;
    any_depth = any_depth || fs::exists(p, ec);
  }
  FREELOC_CHECK(any_depth, "depth " << o.depth.ToString() << ": no scene has this depth (e.g. " << example
                                    << " is missing); check the suffix, or use metric3d or none");
  return loaded;
}

// ---------------------------------------------------------------------------------------------------------------
// The journal: `<out>.progress.jsonl`, the run header, then one line per finished scene (appended and synced as
// each scene ends). Resuming reads it back and skips those scenes; a last line cut short by a crash is ignored.
// Removed once the submission is written.

class Journal {
 public:
  Journal(const std::string& out, std::string header) : path_(out + ".progress.jsonl"), header_(std::move(header)) {}
  ~Journal() { Close(); }
  const std::string& path() const { return path_; }

  // Scenes already done; empty when there is no journal yet.
  std::map<std::string, std::vector<QueryResult>> Load(const PipelineOptions& o) const {
    std::map<std::string, std::vector<QueryResult>> done;
    std::ifstream in(path_);
    if (!in) return done;
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) lines.push_back(line);
    FREELOC_CHECK(!lines.empty(), path_ << ": empty progress file; delete it or run without --resume");
    std::string why;
    FREELOC_CHECK(SameResultOptions(lines[0], o, &why),
                  path_ << ": written with different options (" << why
                        << "); rerun with the same options, or without --resume");
    for (size_t i = 1; i < lines.size(); ++i) {
      if (!ParseScene(lines[i], i + 1, i + 1 == lines.size(), &done)) break;  // the interrupted last write
    }
    return done;
  }

  // Starts a new journal (header only) unless resuming from an existing one.
  void Open(bool keep) {
    std::error_code ec;
    const bool exists = fs::exists(path_, ec);
    file_ = std::fopen(path_.c_str(), keep && exists ? "a" : "w");
    FREELOC_CHECK(file_ != nullptr, path_ << ": cannot write the progress file; check the folder of the submission");
    if (!(keep && exists)) Append(header_);
  }
  void AppendScene(const std::string& scene, const std::vector<QueryResult>& res) {
    nlohmann::ordered_json j = {{"scene", scene}, {"queries", nlohmann::ordered_json::array()}};
    for (const auto& q : res) j["queries"].push_back(nlohmann::ordered_json::parse(QueryRecordJson(scene, q)));
    Append(j.dump());
  }
  void Finish() {
    Close();
    std::error_code ec;
    fs::remove(path_, ec);
  }

 private:
  // One scene line; false for a damaged last line (ignored), an error for a damaged line before it.
  bool ParseScene(const std::string& line, size_t number, bool last,
                  std::map<std::string, std::vector<QueryResult>>* done) const {
    const nlohmann::json j = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded()) {
      FREELOC_CHECK(last, path_ << ": line " << number << " is not JSON; delete the file or run without --resume");
      return false;
    }
    try {
      std::vector<QueryResult> qs;
      for (const auto& q : j.at("queries")) qs.push_back(QueryResultFromJson(q.dump()));
      (*done)[j.at("scene").get<std::string>()] = std::move(qs);
    } catch (const std::exception& e) {
      FREELOC_THROW(path_ << ": line " << number << " is not a scene record (" << e.what()
                          << "); delete the file or run without --resume");
    }
    return true;
  }
  void Append(const std::string& line) {
    const std::string text = line + "\n";
    FREELOC_CHECK(std::fwrite(text.data(), 1, text.size(), file_) == text.size() && std::fflush(file_) == 0,
                  path_ << ": write failed; check free disk space");
    fsync(fileno(file_));
  }
  void Close() {
    if (file_) std::fclose(file_);
    file_ = nullptr;
  }
  std::string path_, header_;
  FILE* file_ = nullptr;
};

// <dir>/<scene>/<frame without extension>.matches.txt
void SaveMatches(const std::string& dir, const std::string& scene, const QueryResult& r,
                 const matching::Correspondences& c) {
  fs::path p = fs::path(dir) / scene / r.frame;
  p.replace_extension(".matches.txt");
  fs::create_directories(p.parent_path());
  std::vector<Eigen::Vector4d> rows;
  for (size_t i = 0; i < c.size(); ++i) rows.emplace_back(c.ref[i].x(), c.ref[i].y(), c.query[i].x(), c.query[i].y());
  WriteCorrespondenceFile(p.string(), rows);
}

// The scenes a resumed journal already holds, moved into `res`.
void Resume(const Journal& journal, const PipelineOptions& o, RunResult* res) {
  auto done = journal.Load(o);
  for (const auto& name : res->scenes)
    if (done.count(name)) {
      res->results[name] = std::move(done[name]);
      ++res->resumed_scenes;
    }
  FREELOC_LOG(INFO) << "resuming from " << journal.path() << ": " << res->resumed_scenes << " of "
                    << res->scenes.size() << " scenes already done";
}

// Every scene not yet done, through one relocalizer; one progress bar over the queries, its label counting scenes.
void RunScenes(const RunSpec& spec, Relocalizer& reloc, Journal& journal, RunResult* res) {
  int64_t total = 0;
  for (const auto& name : res->scenes) total += static_cast<int64_t>(res->loaded.at(name).queries.size());
  ProgressBar bar("queries", total, spec.progress_bar ? -1 : 0);
  size_t done = 0;
  auto label = [&] { bar.SetLabel("scene " + std::to_string(done) + "/" + std::to_string(res->scenes.size()) +
                                  ", queries"); };
  label();
  int64_t queries_done = 0;
  auto advance = [&](int64_t n) {
    bar.Increment(n);
    queries_done += n;
    if (spec.on_progress) spec.on_progress(queries_done, total);
  };
  for (const auto& name : res->scenes) {
    if (res->results.count(name)) {
      advance(static_cast<int64_t>(res->results[name].size()));
    } else {
      MatchesCallback save;
      if (!spec.save_matches.empty())
        save = [&](const QueryResult& r, const matching::Correspondences& c) { SaveMatches(spec.save_matches, name, r, c); };
      res->results[name] = RelocalizeScene(res->loaded.at(name), reloc, [&](const QueryResult&) { advance(1); }, save);
      const CacheStats& cs = reloc.stats();
      FREELOC_LOG(DEBUG) << name << ": reference work " << cs.reference_ms << " ms, " << cs.reference_instances
                         << " reference instances, DUSt3R reference encodings " << cs.reference_encodings
                         << " (reused " << cs.reference_reuses << "), Metric3D passes " << cs.depth_estimates;
      journal.AppendScene(name, res->results[name]);
    }
    ++done;
    label();
  }
  bar.Finish();
}

// The submission (successful queries; an empty pose file for every scene attempted), the log (header + one record
// per query) and the sidecar (header + summary), each written atomically.
void WriteOutputs(const RunSpec& spec, const RunHeader& header, RunResult* res) {
  std::map<std::string, std::vector<SubmissionEntry>> sub;
  std::string log = RunHeaderJson(header) + "\n";
  for (const auto& name : res->scenes) {
    sub[name];
    for (const auto& q : res->results[name]) {
      ++res->queries;
      if (q.ok()) {
        ++res->relocalized;
        sub[name].push_back({q.frame, q.query_from_ref, std::max(0.0, q.confidence)});
      }
      log += QueryRecordJson(name, q) + "\n";
    }
  }
  WriteSubmission(spec.out, sub);
  if (!spec.log.empty()) WriteFileAtomic(spec.log, log.data(), log.size());
  const std::string summary = "{\"summary\":{\"scenes\":" + std::to_string(res->scenes.size()) +
                              ",\"queries\":" + std::to_string(res->queries) +
                              ",\"relocalized\":" + std::to_string(res->relocalized) + "}}";
  const std::string sidecar = RunHeaderJson(header, summary) + "\n";
  WriteFileAtomic(spec.out + ".json", sidecar.data(), sidecar.size());
}

}  // namespace

RunResult RunBenchmark(const RunSpec& spec, const PipelineOptions& options, const RelocalizerFactory& factory) {
  spec.Validate();
  options.Validate();
  RunResult res;
  res.scenes = spec.shard.Select(ResolveScenes(spec.data, spec.split, spec.scenes, &res.split_dir));
  if (!spec.shard.whole()) FREELOC_LOG(INFO) << "shard " << spec.shard.ToString() << ": " << res.scenes.size() << " scenes";
  res.loaded = LoadScenes(res.split_dir, res.scenes, options);
  // The networks are loaded here, before the journal and the first scene: a bad weights file is one error.
  std::unique_ptr<Relocalizer> reloc = factory ? factory(options) : std::make_unique<Relocalizer>(options);
  const RunHeader header{options, spec.data, spec.split, spec.shard.ToString(), res.scenes};
  Journal journal(spec.out, RunHeaderJson(header));
  if (spec.resume) {
    Resume(journal, options, &res);
  } else if (fs::exists(journal.path())) {
    FREELOC_LOG(WARNING) << journal.path() << " exists from an earlier run; starting over (use --resume to continue it)";
  }
  journal.Open(spec.resume);
  RunScenes(spec, *reloc, journal, &res);
  WriteOutputs(spec, header, &res);
  journal.Finish();
  return res;
}

}  // namespace freeloc::pipeline
