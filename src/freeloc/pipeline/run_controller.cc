#include "freeloc/pipeline/run_controller.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/progress.h"
#include "freeloc/io/correspondence_file.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/submission.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/relocalize_scene.h"
#include "freeloc/pipeline/report_recorder.h"
#include "freeloc/pipeline/run_comm.h"
#include "freeloc/pipeline/run_journal.h"
#include "freeloc/pipeline/run_scenes.h"

namespace freeloc::pipeline {

Shard Shard::FromString(const std::string& text) {
  Shard s;
  char tail = 0;
  FREELOC_OPTION_CHECK("shard",
                       std::sscanf(text.c_str(), "%d/%d%c", &s.index, &s.count, &tail) == 2 && s.count >= 1 &&
                           s.index >= 1 && s.index <= s.count,
                       ": '" << text << "' is not i/n with 1 <= i <= n (e.g. 2/4)");
  return s;
}

std::string Shard::ToString() const { return whole() ? "" : std::to_string(index) + "/" + std::to_string(count); }

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
  *split_dir = io::ResolveSplitDir(data, split);
  std::vector<std::string> scenes = io::ListScenes(*split_dir, only);
  FREELOC_CHECK(!scenes.empty(), *split_dir << ": no scene folders to process");
  return scenes;
}

namespace fs = std::filesystem;

namespace {

// <dir>/<scene>/<frame without extension>.matches.txt
void SaveMatches(const std::string& dir, const std::string& scene, const QueryResult& r,
                 const matching::Correspondences& c) {
  fs::path p = fs::path(dir) / scene / r.frame;
  p.replace_extension(".matches.txt");
  fs::create_directories(p.parent_path());
  io::WriteCorrespondenceFile(p.string(), c.Rows());
}

// The scenes a resumed journal already holds, moved into `res`.
void Resume(const RunJournal& journal, const PipelineOptions& o, RunResult* res) {
  auto done = journal.Load(o);
  for (const auto& name : res->scenes)
    if (done.count(name)) {
      res->results[name] = std::move(done[name]);
      ++res->resumed_scenes;
    }
  FREELOC_LOG(INFO) << "resuming from " << journal.path() << ": " << res->resumed_scenes << " of " << res->scenes.size()
                    << " scenes already done";
}

enum Tag { kTickTag = 1, kSceneTag = 2 };

// The --log file while the run works (root only): the header, the resumed scenes, then each record as its query
// finishes (this process's) or its scene arrives (another rank's), flushed, so the log can be followed (tail -f) and
// keeps what was done when a run is stopped. At the end WriteOutputs replaces it atomically with the records in
// scene order.
class LiveLog {
 public:
  LiveLog(const std::string& path, const std::string& header) : path_(path) {
    if (path.empty()) return;
    file_ = std::fopen(path.c_str(), "wb");
    FREELOC_CHECK(file_ != nullptr, path << ": cannot write the run log (" << std::strerror(errno) << ")");
    Write(header + "\n");
  }
  ~LiveLog() {
    if (file_) std::fclose(file_);
  }
  LiveLog(const LiveLog&) = delete;
  LiveLog& operator=(const LiveLog&) = delete;
  void Record(const std::string& scene, const QueryResult& r) {
    if (file_) Write(QueryRecordJson(scene, r) + "\n");
  }

 private:
  void Write(const std::string& line) {
    if (std::fwrite(line.data(), 1, line.size(), file_) != line.size() || std::fflush(file_) != 0) {
      FREELOC_LOG(WARNING) << path_ << ": cannot write the run log as it goes (" << std::strerror(errno)
                           << "); it is written once at the end";
      std::fclose(file_);
      file_ = nullptr;
    }
  }
  std::string path_;
  FILE* file_ = nullptr;
};

// Runs this process's scenes through one relocalizer. Single process or rank 0: one progress bar over every query
// of the run, the journal, and (rank 0) the scenes and ticks the other ranks send. Other ranks: their scenes, a
// tick per query and each finished scene to rank 0.
class SceneRunner {
 public:
  SceneRunner(const RunSpec& spec, Relocalizer& reloc, RunJournal* journal, RunComm* comm, ReportRecorder* report,
              LiveLog* log, RunResult* res)
      : spec_(spec), reloc_(reloc), journal_(journal), comm_(comm), report_(report), log_(log), res_(res) {
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
    for (const auto& [name, results] : res_->results) {
      Advance(static_cast<int64_t>(results.size()));
      if (log_)
        for (const auto& r : results) log_->Record(name, r);
    }
    for (const auto& name : mine) {
      MatchesCallback save;
      if (!spec_.save_matches.empty() || report_)
        save = [&](const QueryResult& r, const matching::Correspondences& c) {
          if (!spec_.save_matches.empty()) SaveMatches(spec_.save_matches, name, r, c);
          if (report_) report_->Consider(res_->loaded.at(name), r, c, reloc_);
        };
      auto results = RelocalizeScene(
          res_->loaded.at(name), reloc_,
          [&](const QueryResult& r) {
            if (log_) log_->Record(name, r);
            Query();
          },
          save);
      const CacheStats& cs = reloc_.stats();
      FREELOC_LOG(DEBUG) << name << ": reference work " << cs.reference_ms << " ms, " << cs.reference_instances
                         << " reference instances, DUSt3R reference encodings " << cs.reference_encodings << " (reused "
                         << cs.reference_reuses << "), Metric3D passes " << cs.depth_estimates;
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
    if (log_)
      for (const auto& r : results) log_->Record(scene, r);
    res_->results[scene] = std::move(results);
    Relabel();
    return true;
  }

  const RunSpec& spec_;
  Relocalizer& reloc_;
  RunJournal* journal_;
  RunComm* comm_;
  ReportRecorder* report_;
  LiveLog* log_;
  RunResult* res_;
  ProgressBar* bar_ = nullptr;
  int64_t total_ = 0, done_ = 0;
};

// The submission (the submitted queries: solved, and unsolved under always_answer; an empty pose file for every scene
// attempted), the log (header + one record per query) and the sidecar (header + summary), each written atomically.
void WriteOutputs(const RunSpec& spec, const RunHeader& header, RunResult* res) {
  std::map<std::string, std::vector<io::SubmissionEntry>> sub;
  std::string log = RunHeaderJson(header) + "\n";
  for (const auto& name : res->scenes) {
    sub[name];
    for (const auto& q : res->results[name]) {
      ++res->queries;
      if (q.solved()) ++res->solved;
      if (q.submitted()) ++res->submitted;
      ++res->statuses[ToString(q.status)];
      if (q.status == QueryStatus::kError) {
        ++res->input_errors;
        if (res->input_error_messages.size() < 5)
          res->input_error_messages.push_back(name + "/" + q.frame + ": " + q.message);
      }
      if (q.submitted())
        sub[name].push_back({q.frame, q.query_from_ref, q.prior() ? 0.0 : std::max(0.0, q.confidence)});
      log += QueryRecordJson(name, q) + "\n";
    }
  }
  io::WriteSubmission(spec.out, sub);
  if (!spec.log.empty()) io::WriteFileAtomic(spec.log, log.data(), log.size());
  const std::string summary = "{\"summary\":{\"scenes\":" + std::to_string(res->scenes.size()) +
                              ",\"queries\":" + std::to_string(res->queries) +
                              ",\"solved\":" + std::to_string(res->solved) +
                              ",\"submitted\":" + std::to_string(res->submitted) + "}}";
  const std::string sidecar = RunHeaderJson(header, summary) + "\n";
  io::WriteFileAtomic(spec.out + ".json", sidecar.data(), sidecar.size());
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
    io::CheckWritableFile(spec.out, "the submission");
    if (!spec.log.empty()) {
      FREELOC_OPTION_CHECK("log", fs::absolute(spec.log) != fs::absolute(spec.out),
                           ": " << spec.log << " is also the submission; give the log another path");
      io::CheckWritableFile(spec.log, "the run log");
    }
  }
  if (!spec.save_matches.empty()) io::CheckWritableFolder(spec.save_matches, "the saved matches");
  if (!spec.report.empty()) io::CheckWritableFolder(spec.report, "the HTML report");
  RunResult res;
  res.scenes = spec.shard.Select(ResolveScenes(spec.data, spec.split, spec.scenes, &res.split_dir));
  if (!spec.shard.whole() && root)
    FREELOC_LOG(INFO) << "shard " << spec.shard.ToString() << ": " << res.scenes.size() << " scenes";
  res.loaded = LoadScenes(res.split_dir, res.scenes, options);
  if (options.track == io::Track::kMultiFrame && spec.shard.whole() && !res.loaded.empty()) {
    // A whole run with nothing to answer is a mistake to say now, not "0 of 0 queries" after loading the networks.
    size_t evaluated = 0;
    for (const auto& [name, scene] : res.loaded) evaluated += AnsweredQueries(scene, options).size();
    FREELOC_OPTION_CHECK("track", evaluated > 0,
                         ": multi-frame, but no scene of "
                             << spec.data
                             << " has the 10 or more query frames the "
                                "Multi Frame track evaluates (linear positions 9, 19, … of seq1); use single-frame for "
                                "these scenes");
  }
  // The networks are loaded here, before the journal and the first scene: a bad weights file is one error.
  std::unique_ptr<Relocalizer> reloc =
      factory ? factory(options) : std::make_unique<Relocalizer>(options, Relocalizer::kOptionsValidated);
  const RunHeader header{options, spec.data, spec.split, spec.shard.ToString(), res.scenes};
  RunJournal journal(spec.out, RunHeaderJson(header));
  if (root && spec.resume) {
    Resume(journal, options, &res);
  } else if (root && fs::exists(journal.path())) {
    // The command line has warned before any work, naming its flag; here for the library's other callers.
    FREELOC_LOG(INFO) << journal.path() << " exists from an earlier run; starting over (resume the run to continue it)";
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
  std::unique_ptr<LiveLog> live_log;
  if (root) live_log = std::make_unique<LiveLog>(spec.log, RunHeaderJson(header));
  SceneRunner(spec, *reloc, root ? &journal : nullptr, comm, report.get(), live_log.get(), &res).Run(mine);
  live_log.reset();  // closed before WriteOutputs replaces it
  if (!root) return res;
  WriteOutputs(spec, header, &res);
  if (report) report->Write(res.split_dir, res.scenes, res.loaded, res.results, spec.out);
  journal.Finish();
  return res;
}

}  // namespace freeloc::pipeline
