#include "freeloc/pipeline/run_controller.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <set>

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
#include "freeloc/pipeline/run_comm.h"
#include "freeloc/pipeline/report_recorder.h"

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
  FREELOC_OPTION_CHECK("data", !data.empty(), ": give the dataset root or a split folder");
  FREELOC_OPTION_CHECK("out", !out.empty(), ": give the submission ZIP to write");
  FREELOC_OPTION_CHECK("shard", shard.whole() || (shard.index >= 1 && shard.index <= shard.count),
                       ": " << shard.index << "/" << shard.count << " is not i/n with 1 <= i <= n");
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
    AnsweredQueries(scene, o);  // multi-frame: every query must be orderable by its frame number
    if (!o.UsesProvidedDepth()) continue;
    const std::string p = scene.DepthPath(scene.reference, o.depth.suffix);
    if (example.empty()) example = p;
    std::error_code ec;
    any_depth = any_depth || fs::exists(p, ec);
  }
  FREELOC_OPTION_CHECK("depth", any_depth, " " << o.depth.ToString() << ": no scene has this depth (e.g. " << example
                                    << " is missing); check the suffix, or use metric3d or none");
  return loaded;
}

// One finished scene as a line: {"scene": name, "queries": [records]} (the journal's lines and the ranks' messages).
std::string SceneRecord(const std::string& scene, const std::vector<QueryResult>& res) {
  nlohmann::ordered_json j = {{"scene", scene}, {"queries", nlohmann::ordered_json::array()}};
  for (const auto& q : res) j["queries"].push_back(nlohmann::ordered_json::parse(QueryRecordJson(scene, q)));
  return j.dump();
}

// The inverse; false when `line` is not JSON; throws when it is JSON but not a scene record.
bool ParseSceneRecord(const std::string& line, std::string* scene, std::vector<QueryResult>* res) {
  const nlohmann::json j = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return false;
  try {
    res->clear();
    for (const auto& q : j.at("queries")) res->push_back(QueryResultFromJson(q.dump()));
    *scene = j.at("scene").get<std::string>();
  } catch (const std::exception& e) {
    FREELOC_THROW("not a scene record (" << e.what() << ")");
  }
  return true;
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
    FREELOC_CHECK(!lines.empty(), path_ << ": empty progress file; delete it or run without resuming");
    std::string why;
    FREELOC_CHECK(SameResultOptions(lines[0], o, &why),
                  path_ << ": written with different options (" << why
                        << "); rerun with the same options, or without resuming");
    for (size_t i = 1; i < lines.size(); ++i) {
      if (!ParseScene(lines[i], i + 1, i + 1 == lines.size(), &done)) break;  // the interrupted last write
    }
    return done;
  }

  // Starts a new journal (header only) unless resuming from an existing one.
  // Starts a new journal (header only) unless resuming from an existing one. The file is locked (flock) for the
  // run: a second run on the same --out is refused instead of interleaving its writes. Resuming cuts a torn last
  // line (a crash or a full disk mid-write) so the next record starts on a line of its own.
  void Open(bool keep) {
    const int fd = ::open(path_.c_str(), O_RDWR | O_CREAT, 0644);
    FREELOC_CHECK(fd >= 0, path_ << ": cannot write the progress file; check the folder of the submission");
    // flock excludes every other open (this process's too); a POSIX record lock beside it lets the refused run
    // name the process that holds the file (F_GETLK).
    struct flock record {};
    record.l_type = F_WRLCK;
    record.l_whence = SEEK_SET;
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      struct flock holder = record;
      const bool known = ::fcntl(fd, F_GETLK, &holder) == 0 && holder.l_type != F_UNLCK && holder.l_pid > 0;
      ::close(fd);
      FREELOC_THROW(path_ << ": another freeloc run"
                          << (known ? " (process " + std::to_string(holder.l_pid) + ")" : std::string())
                          << " is writing this submission (its progress file is locked); wait for it, or write "
                             "the submission elsewhere");
    }
    ::fcntl(fd, F_SETLK, &record);  // best effort: only used to name this process to a refused run
    struct stat st {};
    ::fstat(fd, &st);
    const bool resume = keep && st.st_size > 0;
    FREELOC_CHECK(::ftruncate(fd, resume ? TornTailCut(fd, st.st_size) : 0) == 0,
                  path_ << ": cannot truncate the progress file; check free disk space");
    ::lseek(fd, 0, SEEK_END);
    file_ = ::fdopen(fd, "a");
    FREELOC_CHECK(file_ != nullptr, path_ << ": cannot write the progress file");
    if (!resume) Append(header_);
  }
  void AppendScene(const std::string& scene, const std::vector<QueryResult>& res) { Append(SceneRecord(scene, res)); }
  void AppendRecord(const std::string& scene_record) { Append(scene_record); }  // a SceneRecord line as it came
  void Finish() {
    Close();
    std::error_code ec;
    fs::remove(path_, ec);
  }

 private:
  // The length of the file without a last line that lacks its newline.
  static off_t TornTailCut(int fd, off_t size) {
    off_t end = size;
    char c = 0;
    while (end > 0 && ::pread(fd, &c, 1, end - 1) == 1 && c != '\n') --end;
    return end;
  }
  // One scene line; false for a damaged last line (ignored), an error for a damaged line before it.
  bool ParseScene(const std::string& line, size_t number, bool last,
                  std::map<std::string, std::vector<QueryResult>>* done) const {
    std::string scene;
    std::vector<QueryResult> qs;
    bool json = false;
    try {
      json = ParseSceneRecord(line, &scene, &qs);
    } catch (const Error& e) {
      FREELOC_THROW(path_ << ": line " << number << " is " << e.what() << "; delete the file or run without resuming");
    }
    if (!json) {
      FREELOC_CHECK(last, path_ << ": line " << number << " is not JSON; delete the file or run without resuming");
      return false;
    }
    (*done)[scene] = std::move(qs);
    return true;
  }
  void Append(const std::string& line) {
    const std::string text = line + "\n";
    FREELOC_CHECK(std::fwrite(text.data(), 1, text.size(), file_) == text.size() && std::fflush(file_) == 0,
                  path_ << ": write failed; check free disk space");
    FREELOC_CHECK(fsync(fileno(file_)) == 0 || errno == EINVAL,
                  path_ << ": write failed (" << std::strerror(errno) << "); check free disk space");
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
  WriteCorrespondenceFile(p.string(), c.Rows());
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

// Scenes over ranks: longest first (by query count, then name) to the least loaded rank (ties: the lowest) —
// deterministic, so every rank computes the same assignment.
std::vector<std::vector<std::string>> AssignScenes(const std::vector<std::string>& scenes,
                                                   const std::map<std::string, MapfreeScene>& loaded, int ranks) {
  std::vector<std::string> order = scenes;
  auto queries = [&](const std::string& n) { return loaded.at(n).queries.size(); };
  std::stable_sort(order.begin(), order.end(), [&](const std::string& a, const std::string& b) {
    return queries(a) != queries(b) ? queries(a) > queries(b) : a < b;
  });
  std::vector<std::vector<std::string>> out(static_cast<size_t>(ranks));
  std::vector<size_t> load(static_cast<size_t>(ranks), 0);
  for (const auto& n : order) {
    const size_t r = static_cast<size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    out[r].push_back(n);
    load[r] += queries(n) + 1;  // + 1: an empty scene still costs its reference
  }
  for (auto& v : out) std::sort(v.begin(), v.end());
  return out;
}

enum Tag { kTickTag = 1, kSceneTag = 2 };

// Runs this process's scenes through one relocalizer. Single process or rank 0: one progress bar over every query
// of the run, the journal, and (rank 0) the scenes and ticks the other ranks send. Other ranks: their scenes, a
// tick per query and each finished scene to rank 0.
class SceneRunner {
 public:
  SceneRunner(const RunSpec& spec, Relocalizer& reloc, Journal* journal, RunComm* comm, ReportRecorder* report,
              RunResult* res)
      : spec_(spec), reloc_(reloc), journal_(journal), comm_(comm), report_(report), res_(res) {
    for (const auto& name : res->scenes)
      total_ += static_cast<int64_t>(AnsweredQueries(res->loaded.at(name), reloc.options()).size());
  }

  void Run(const std::vector<std::string>& mine) {
    const bool root = !comm_ || comm_->rank() == 0;
    // Under mpirun the ranks' stderr is a pipe to the launcher, which shows it on the user's terminal: rank 0 draws
    // its one bar whenever logging is at info (not -q); a single process draws it on a terminal only.
    const int draw = !(root && spec_.progress_bar) ? 0 : comm_ ? (LogEnabled(LogLevel::kInfo) ? 1 : 0) : -1;
    ProgressBar bar("queries", total_, draw);
    bar_ = root ? &bar : nullptr;
    for (const auto& [name, results] : res_->results) Advance(static_cast<int64_t>(results.size()));
    for (const auto& name : mine) {
      MatchesCallback save;
      if (!spec_.save_matches.empty() || report_)
        save = [&](const QueryResult& r, const matching::Correspondences& c) {
          if (!spec_.save_matches.empty()) SaveMatches(spec_.save_matches, name, r, c);
          if (report_) report_->Consider(res_->loaded.at(name), r, c, reloc_);
        };
      auto results = RelocalizeScene(res_->loaded.at(name), reloc_, [&](const QueryResult&) { Query(); }, save);
      const CacheStats& cs = reloc_.stats();
      FREELOC_LOG(DEBUG) << name << ": reference work " << cs.reference_ms << " ms, " << cs.reference_instances
                         << " reference instances, DUSt3R reference encodings " << cs.reference_encodings
                         << " (reused " << cs.reference_reuses << "), Metric3D passes " << cs.depth_estimates;
      Finished(name, std::move(results));
    }
    if (root && comm_) {
      while (res_->results.size() < res_->scenes.size()) Handle(true);
    }
    bar.Finish();
  }

 private:
  void Query() {
    if (!comm_ || comm_->rank() == 0) {
      Advance(1);
      while (comm_ && Handle(false)) {
      }
    } else {
      comm_->Send(kTickTag, "1");
    }
  }

  void Advance(int64_t n) {
    done_ += n;
    if (bar_) bar_->Increment(n);
    Relabel();
    if (spec_.on_progress) spec_.on_progress(done_, total_);
  }

  void Relabel() {
    if (bar_)
      bar_->SetLabel("scene " + std::to_string(res_->results.size()) + "/" + std::to_string(res_->scenes.size()) +
                     ", queries");
  }

  void Finished(const std::string& name, std::vector<QueryResult> results) {
    if (comm_ && comm_->rank() != 0) {
      comm_->Send(kSceneTag, SceneRecord(name, results));
      res_->results[name] = std::move(results);
      return;
    }
    journal_->AppendScene(name, results);
    res_->results[name] = std::move(results);
  }

  // Rank 0: one message from the other ranks (a tick or a finished scene); false when none was pending.
  bool Handle(bool wait) {
    int tag = 0, from = 0;
    std::string payload, scene;
    if (!comm_->Receive(wait, &tag, &payload, &from)) return false;
    if (tag == kTickTag) {
      Advance(1);
      return true;
    }
    std::vector<QueryResult> results;
    FREELOC_CHECK(ParseSceneRecord(payload, &scene, &results) && res_->loaded.count(scene),
                  "run: rank " << from << " sent a damaged scene record");
    journal_->AppendRecord(payload);
    res_->results[scene] = std::move(results);
    Relabel();
    return true;
  }

  const RunSpec& spec_;
  Relocalizer& reloc_;
  Journal* journal_;
  RunComm* comm_;
  ReportRecorder* report_;
  RunResult* res_;
  ProgressBar* bar_ = nullptr;
  int64_t total_ = 0, done_ = 0;
};

// The submission (solved queries, and the answered ones with confidence 0; an empty pose file for every scene attempted), the log (header + one record
// per query) and the sidecar (header + summary), each written atomically.
void WriteOutputs(const RunSpec& spec, const RunHeader& header, RunResult* res) {
  std::map<std::string, std::vector<SubmissionEntry>> sub;
  std::string log = RunHeaderJson(header) + "\n";
  for (const auto& name : res->scenes) {
    sub[name];
    for (const auto& q : res->results[name]) {
      ++res->queries;
      if (q.ok()) ++res->relocalized;
      ++res->statuses[ToString(q.status)];
      if (q.status == QueryStatus::kError) {
        ++res->input_errors;
        if (res->input_error_messages.size() < 5)
          res->input_error_messages.push_back(name + "/" + q.frame + ": " + q.message);
      }
      if (q.submitted()) sub[name].push_back({q.frame, q.query_from_ref, q.prior() ? 0.0 : std::max(0.0, q.confidence)});
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

RunResult ExecuteRun(const RunSpec& spec, const PipelineOptions& options, const RelocalizerFactory& factory,
                       RunComm* comm) {
  spec.Validate();
  options.Validate();
  if (comm && comm->size() <= 1) comm = nullptr;
  const bool root = !comm || comm->rank() == 0;
  // Every output path is checked before the first byte of any output (the journal included) is written: a run that
  // cannot write its log must fail now, not after hours, and a failed start leaves nothing behind.
  if (root) {
    CheckWritableFile(spec.out, "the submission");
    if (!spec.log.empty()) {
      FREELOC_OPTION_CHECK("log", fs::absolute(spec.log) != fs::absolute(spec.out),
                           ": " << spec.log << " is also the submission; give the log another path");
      CheckWritableFile(spec.log, "the run log");
    }
  }
  if (!spec.save_matches.empty()) CheckWritableFolder(spec.save_matches, "the saved matches");
  if (!spec.report.empty()) CheckWritableFolder(spec.report, "the HTML report");
  RunResult res;
  res.scenes = spec.shard.Select(ResolveScenes(spec.data, spec.split, spec.scenes, &res.split_dir));
  if (!spec.shard.whole() && root) FREELOC_LOG(INFO) << "shard " << spec.shard.ToString() << ": " << res.scenes.size() << " scenes";
  res.loaded = LoadScenes(res.split_dir, res.scenes, options);
  // The networks are loaded here, before the journal and the first scene: a bad weights file is one error.
  std::unique_ptr<Relocalizer> reloc =
      factory ? factory(options) : std::make_unique<Relocalizer>(options, Relocalizer::kOptionsValidated);
  const RunHeader header{options, spec.data, spec.split, spec.shard.ToString(), res.scenes};
  Journal journal(spec.out, RunHeaderJson(header));
  if (root && spec.resume) {
    Resume(journal, options, &res);
  } else if (root && fs::exists(journal.path())) {
    FREELOC_LOG(WARNING) << journal.path() << " exists from an earlier run; starting over (resume the run to continue it)";
  }
  if (root) journal.Open(spec.resume);
  std::vector<std::string> mine;
  for (const auto& n : res.scenes)
    if (!res.results.count(n)) mine.push_back(n);
  if (comm) {
    // Rank 0 read the journal: every rank learns the finished scenes, then takes its share of the rest.
    std::string done;
    for (const auto& [n, r] : res.results) done += n + "\n";
    std::istringstream in(comm->Broadcast(done));
    std::set<std::string> finished;
    for (std::string n; std::getline(in, n);) finished.insert(n);
    std::vector<std::string> todo;
    for (const auto& n : res.scenes)
      if (!finished.count(n)) todo.push_back(n);
    const auto share = AssignScenes(todo, res.loaded, comm->size());
    mine = share[static_cast<size_t>(comm->rank())];
    std::string list;
    for (const auto& n : mine) list += (list.empty() ? "" : ", ") + n;
    FREELOC_LOG(INFO) << "rank " << comm->rank() << " of " << comm->size() << ": " << mine.size() << " scenes"
                      << (list.empty() ? "" : " (" + list + ")");
    if (spec.on_assigned) spec.on_assigned(*comm);
  }
  std::unique_ptr<ReportRecorder> report;
  if (!spec.report.empty()) {
    eval::ReportOptions ro = spec.report_options;
    ro.track = options.track;
    report = std::make_unique<ReportRecorder>(spec.report, ro);
  }
  SceneRunner(spec, *reloc, root ? &journal : nullptr, comm, report.get(), &res).Run(mine);
  if (!root) return res;
  WriteOutputs(spec, header, &res);
  if (report) report->Write(res.split_dir, res.scenes, res.loaded, res.results, spec.out);
  journal.Finish();
  return res;
}

}  // namespace freeloc::pipeline
