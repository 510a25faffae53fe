// The run controller's journal (run_controller.h): `<out>.progress.jsonl`, the run header, then one line per finished
// scene — {"scene": name, "queries": [records]}, the same line the MPI ranks send rank 0 — appended and synced as each
// scene ends. Resuming reads it back and skips those scenes; a last line cut short by a crash is ignored. Removed
// once the submission is written. Internal to the run controller.
#pragma once

#include <sys/types.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/query_result.h"

namespace freeloc::pipeline {

// One finished scene as a line (the journal's lines and the ranks' messages).
std::string SceneRecord(const std::string& scene, const std::vector<QueryResult>& res);
// The inverse; false when `line` is not JSON; throws when it is JSON but not a scene record.
bool ParseSceneRecord(const std::string& line, std::string* scene, std::vector<QueryResult>* res);

class RunJournal {
 public:
  RunJournal(const std::string& out, std::string header);
  ~RunJournal();
  RunJournal(const RunJournal&) = delete;
  RunJournal& operator=(const RunJournal&) = delete;
  const std::string& path() const { return path_; }

  // Scenes already done; empty when there is no journal yet. Throws when it was written with other options.
  std::map<std::string, std::vector<QueryResult>> Load(const PipelineOptions& o) const;
  // Starts a new journal (header only) unless `keep` and one exists. The file is locked (flock) for the run: a
  // second run on the same --out is refused instead of interleaving its writes. Resuming cuts a torn last line (a
  // crash or a full disk mid-write) so the next record starts on a line of its own.
  void Open(bool keep);
  void AppendScene(const std::string& scene, const std::vector<QueryResult>& res);
  void AppendRecord(const std::string& scene_record);  // a SceneRecord line as it came
  void Finish();                                       // closes and removes the file

 private:
  bool ParseScene(const std::string& line, size_t number, bool last,
                  std::map<std::string, std::vector<QueryResult>>* done) const;
  void Append(const std::string& line);
  void Close();
  std::string path_, header_;
  FILE* file_ = nullptr;
};

}  // namespace freeloc::pipeline
