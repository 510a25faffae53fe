#include "freeloc/pipeline/run_journal.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "freeloc/core/error.h"
#include "freeloc/pipeline/record.h"

namespace freeloc::pipeline {

namespace fs = std::filesystem;

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

namespace {

// The length of the file without a last line that lacks its newline.
off_t TornTailCut(int fd, off_t size) {
  off_t end = size;
  char c = 0;
  while (end > 0 && ::pread(fd, &c, 1, end - 1) == 1 && c != '\n') --end;
  return end;
}

}  // namespace

RunJournal::RunJournal(const std::string& out, std::string header)
    : path_(out + ".progress.jsonl"), header_(std::move(header)) {}

RunJournal::~RunJournal() { Close(); }

std::map<std::string, std::vector<QueryResult>> RunJournal::Load(const PipelineOptions& o) const {
  std::map<std::string, std::vector<QueryResult>> done;
  std::ifstream in(path_);
  if (!in) return done;
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(line);
  FREELOC_CHECK(!lines.empty(), path_ << ": empty progress file; delete it or run without resuming");
  std::string why;
  FREELOC_CHECK(SameResultOptions(lines[0], o, &why), path_ << ": written with different options (" << why
                                                            << "); rerun with the same options, or without resuming");
  for (size_t i = 1; i < lines.size(); ++i) {
    if (!ParseScene(lines[i], i + 1, i + 1 == lines.size(), &done)) break;  // the interrupted last write
  }
  return done;
}

void RunJournal::Open(bool keep) {
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

void RunJournal::AppendScene(const std::string& scene, const std::vector<QueryResult>& res) {
  Append(SceneRecord(scene, res));
}

void RunJournal::AppendRecord(const std::string& scene_record) { Append(scene_record); }

void RunJournal::Finish() {
  Close();
  std::error_code ec;
  fs::remove(path_, ec);
}

bool RunJournal::ParseScene(const std::string& line, size_t number, bool last,
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

void RunJournal::Append(const std::string& line) {
  const std::string text = line + "\n";
  FREELOC_CHECK(std::fwrite(text.data(), 1, text.size(), file_) == text.size() && std::fflush(file_) == 0,
                path_ << ": write failed; check free disk space");
  FREELOC_CHECK(fsync(fileno(file_)) == 0 || errno == EINVAL,
                path_ << ": write failed (" << std::strerror(errno) << "); check free disk space");
}

void RunJournal::Close() {
  if (file_) std::fclose(file_);
  file_ = nullptr;
}

}  // namespace freeloc::pipeline
