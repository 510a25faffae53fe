// The run controller on synthetic map-free scenes: outputs and provenance, per-query isolation of any exception
// (a LibTorch one included), per-scene isolation of a damaged scene, resume after a journal, the bundled demo data.
#include "freeloc/pipeline/run_controller.h"

#include <c10/util/Exception.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/core/version.h"
#include "freeloc/io/submission.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/run_comm.h"
#include "testing/mapfree_writer.h"
#include "testing/testing.h"

namespace freeloc::pipeline {
namespace {

namespace fs = std::filesystem;

struct Split {
  testing::TempDir tmp;
  std::string root() const { return tmp.File("data"); }
  std::string out() const { return tmp.File("sub.zip"); }
  Split() {
    for (uint32_t s : {3u, 4u})
      testing::WriteSyntheticMapfreeScene(tmp.File("data/val/s0000" + std::to_string(s)), 90 + s);
  }
};

PipelineOptions Options() {
  PipelineOptions o = ResolvePreset("precomputed:SIFT-essential");
  o.depth = DepthSpec::FromString("provided:gt");
  return o;
}

RunSpec Spec(const Split& split) {
  RunSpec spec;
  spec.data = split.root();
  spec.out = split.out();
  spec.log = split.tmp.File("run.jsonl");
  spec.progress_bar = false;
  return spec;
}

TEST(RunController, WritesSubmissionLogAndProvenance) {
  Split split;
  const RunResult r = ExecuteRun(Spec(split), Options());
  ASSERT_EQ(r.scenes, (std::vector<std::string>{"s00003", "s00004"}));
  EXPECT_EQ(r.queries, 8u);
  for (const auto& name : r.scenes) {
    const auto& res = r.results.at(name);
    EXPECT_EQ(res[0].status, QueryStatus::kTooFewMatches);
    int ok = 0;
    for (size_t i = 1; i < res.size(); ++i) {
      ok += res[i].metric();
      if (!res[i].metric()) continue;
      const Rigid3d& gt = r.loaded.at(name).gt.at(res[i].frame);
      EXPECT_LT(RotationAngleDeg(res[i].query_from_ref.rotation, gt.rotation), 5.0)
          << res[i].frame;  // 160×120 px, 30 % outliers
    }
    EXPECT_GE(ok, 2) << name;
  }
  // Submission: the answered queries; log: header then one record per query; sidecar: header + summary.
  const auto zip = io::ZipContents::Read(split.out()).files;
  EXPECT_EQ(zip.size(), 2u);
  const std::string log = testing::ReadText(split.tmp.File("run.jsonl"));
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1 + 8);
  const std::string header = log.substr(0, log.find('\n'));
  EXPECT_NE(header.find(std::string("\"freeloc_version\":\"") + Version() + "\""), std::string::npos) << header;
  std::string why;
  EXPECT_TRUE(SameResultOptions(header, Options(), &why)) << why;
  for (const OptionField& f : OptionFields())
    EXPECT_NE(header.find(std::string("\"") + f.name + "\":"), std::string::npos) << f.name;
  const std::string sidecar = testing::ReadText(split.out() + ".json");
  EXPECT_EQ(sidecar.rfind(header.substr(0, header.size() - 1), 0), 0u) << sidecar;
  EXPECT_NE(sidecar.find("\"summary\":{\"scenes\":2,\"queries\":8,\"solved\":" + std::to_string(r.solved)),
            std::string::npos)
      << sidecar;
  EXPECT_FALSE(fs::exists(split.out() + ".progress.jsonl"));
  // Deterministic: the same run gives the same bytes. The log is written as the run goes: after the k-th query it
  // holds the header and k records (it can be followed, and a stopped run keeps them).
  RunSpec again = Spec(split);
  again.out = split.tmp.File("again.zip");
  again.log = split.tmp.File("again.jsonl");
  std::vector<std::pair<int64_t, long>> seen;
  again.on_progress = [&](int64_t done, int64_t) {
    const std::string text = testing::ReadText(again.log);
    seen.emplace_back(done, static_cast<long>(std::count(text.begin(), text.end(), '\n')));
  };
  ExecuteRun(again, Options());
  EXPECT_EQ(testing::ReadText(again.out), testing::ReadText(split.out()));
  ASSERT_EQ(seen.size(), 8u);
  for (const auto& [done, lines] : seen) EXPECT_EQ(lines, 1 + done);
  const std::string final_log = testing::ReadText(again.log);  // rewritten at the end (timings differ per run)
  EXPECT_EQ(std::count(final_log.begin(), final_log.end(), '\n'), 1 + 8);
}

// The precomputed matcher, failing one query with a LibTorch error (what a network stage throws).
class ThrowingMatcher : public Matcher {
 public:
  explicit ThrowingMatcher(int fail_at) : fail_at_(fail_at) {}
  void SetReference(const Image&, const Camera&, const std::vector<uint16_t>*) override {}
  matching::Correspondences Match(const Image&, const Camera&, const FrameInputs& in, QueryResult*) override {
    TORCH_CHECK(calls_++ != fail_at_, "simulated: DefaultCPUAllocator: not enough memory");
    return matching::Correspondences::FromRows(*in.correspondences);
  }

 private:
  int fail_at_, calls_ = 0;
};

TEST(RunController, ALibTorchExceptionFailsOnlyItsQuery) {
  Split split;
  const RunResult clean = ExecuteRun(Spec(split), Options());
  RunSpec spec = Spec(split);
  spec.out = split.tmp.File("t.zip");
  const RelocalizerFactory factory = [](const PipelineOptions& o) {
    return std::make_unique<Relocalizer>(o, std::make_unique<ThrowingMatcher>(2), MakeDepthEstimator(o),
                                         MakePoseSolver(o));
  };
  const RunResult r = ExecuteRun(spec, Options(), factory);
  const auto& s3 = r.results.at("s00003");
  // Query 0 has too few correspondences but is matched (call 0); call 2 is seq1/frame_00002.
  ASSERT_EQ(s3[2].status, QueryStatus::kError);
  EXPECT_NE(s3[2].message.find("s00003/seq1/frame_00002.png: "), std::string::npos) << s3[2].message;
  EXPECT_NE(s3[2].message.find("not enough memory"), std::string::npos) << s3[2].message;
  EXPECT_EQ(s3[2].message.find('\n'), std::string::npos) << s3[2].message;  // one line, no backtrace
  for (const auto& name : r.scenes)
    for (size_t i = 0; i < r.results.at(name).size(); ++i) {
      if (name == "s00003" && i == 2) continue;
      const QueryResult &a = r.results.at(name)[i], &b = clean.results.at(name)[i];
      EXPECT_EQ(a.status, b.status) << name << " " << i;
      EXPECT_EQ(a.query_from_ref.translation, b.query_from_ref.translation) << name << " " << i;
    }
  EXPECT_TRUE(fs::exists(spec.out));
}

TEST(RunController, ADamagedSceneFailsItsQueriesAndTheRunGoesOn) {
  Split split;
  testing::WriteText(split.root() + "/val/s00003/correspondences_SIFT.npz", "not a zip");
  const RunResult r = ExecuteRun(Spec(split), Options());
  for (const auto& q : r.results.at("s00003")) {
    EXPECT_EQ(q.status, QueryStatus::kError);
    EXPECT_EQ(q.message.rfind("reference: ", 0), 0u) << q.message;
    EXPECT_NE(q.message.find("correspondences_SIFT.npz"), std::string::npos) << q.message;
  }
  int ok = 0;
  for (const auto& q : r.results.at("s00004")) ok += q.ok();
  EXPECT_GE(ok, 2);
}

TEST(RunController, RefusesBadSpecsBeforeAnyWork) {
  Split split;
  RunSpec spec = Spec(split);
  spec.out.clear();
  EXPECT_THROW(ExecuteRun(spec, Options()), Error);
  spec = Spec(split);
  spec.scenes = {"s09999"};
  EXPECT_THROW(ExecuteRun(spec, Options()), Error);
  PipelineOptions o = Options();
  o.depth.suffix = "nope";
  try {
    ExecuteRun(Spec(split), o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("depth provided:nope: no scene has this depth", 0), 0u) << e.what();
  }
  EXPECT_FALSE(fs::exists(split.out()));
  EXPECT_FALSE(fs::exists(split.out() + ".progress.jsonl"));
  EXPECT_EQ(Shard::FromString("2/3").Select({"a", "b", "c", "d", "e"}), (std::vector<std::string>{"b", "e"}));
  EXPECT_THROW(Shard::FromString("0/2"), Error);
  EXPECT_THROW(Shard::FromString("3/2"), Error);
  EXPECT_THROW(Shard::FromString("1/2x"), Error);
}

// A run refused because another process holds the journal names that process.
TEST(RunController, ARefusedRunNamesTheProcessHoldingTheJournal) {
  Split split;
  const std::string journal = split.out() + ".progress.jsonl";
  testing::WriteText(journal, "");
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  if (child == 0) {  // holds the journal like a running freeloc, until killed
    const int fd = ::open(journal.c_str(), O_RDWR);
    struct flock record {};
    record.l_type = F_WRLCK;
    record.l_whence = SEEK_SET;
    if (fd < 0 || ::flock(fd, LOCK_EX) != 0 || ::fcntl(fd, F_SETLK, &record) != 0) ::_exit(1);
    if (::write(ready[1], "x", 1) != 1) ::_exit(1);
    ::pause();
    ::_exit(0);
  }
  char c = 0;
  ASSERT_EQ(::read(ready[0], &c, 1), 1);
  const std::string e = testing::ErrorOf([&] { ExecuteRun(Spec(split), Options()); });
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
  EXPECT_NE(e.find("(process " + std::to_string(child) + ") is writing this submission"), std::string::npos) << e;
}

// Crash safety of the journal: a second run on the same --out is refused while the first holds it; a torn last
// line (a crash or a full disk mid-write) is cut on resume, and the resumed run writes the clean run's bytes.
TEST(RunController, TheJournalIsLockedAndATornTailIsCut) {
  Split split;
  const RunResult clean = ExecuteRun(Spec(split), Options());
  const std::string clean_bytes = testing::ReadText(split.out());
  RunSpec spec = Spec(split);
  spec.out = split.tmp.File("j.zip");
  std::string second;
  spec.on_progress = [&](int64_t done, int64_t) {
    if (done != 1) return;
    RunSpec other = Spec(split);
    other.out = split.tmp.File("j.zip");
    second = testing::ErrorOf([&] { ExecuteRun(other, Options()); });
    throw std::runtime_error("stop");  // the first run dies here, mid-scene, leaving its journal
  };
  EXPECT_THROW(ExecuteRun(spec, Options()), std::runtime_error);
  EXPECT_NE(second.find("another freeloc run is writing this submission"), std::string::npos) << second;
  const std::string journal = split.tmp.File("j.zip.progress.jsonl");
  const std::string header = testing::ReadText(journal);
  ASSERT_EQ(std::count(header.begin(), header.end(), '\n'), 1) << header;
  testing::WriteText(journal, header + "{\"scene\":\"s0000");  // torn mid-record
  spec.on_progress = [&](int64_t done, int64_t) {
    if (done == 5) throw std::runtime_error("stop again");  // after the first scene (4 queries) was journaled
  };
  spec.resume = true;
  EXPECT_THROW(ExecuteRun(spec, Options()), std::runtime_error);
  const std::string after = testing::ReadText(journal);
  EXPECT_EQ(after.find("{\"scene\":\"s0000{"), std::string::npos) << "the fragment must be cut";
  EXPECT_EQ(std::count(after.begin(), after.end(), '\n'), 2) << after;  // header + one whole scene
  spec.on_progress = nullptr;
  const RunResult r = ExecuteRun(spec, Options());
  EXPECT_EQ(r.resumed_scenes, 1u);
  EXPECT_EQ(testing::ReadText(spec.out), clean_bytes);  // resumed ok poses come back digit for digit
  EXPECT_EQ(clean.queries, r.queries);
}

// The bundled TUM scenes (data/demo, present in every checkout): sift-essential with the sensor depth.
TEST(RunController, BundledDemoScenes) {
  testing::TempDir tmp;
  RunSpec spec;
  spec.data = testing::DemoPath();
  spec.out = tmp.File("demo.zip");
  spec.progress_bar = false;
  const RunResult r = ExecuteRun(spec, ResolvePreset("sift-essential"));
  EXPECT_EQ(r.queries, 7u);
  EXPECT_EQ(r.solved, 2u);  // s00001 has no depth maps
  for (const auto& q : r.results.at("s00001")) EXPECT_EQ(q.status, QueryStatus::kNoDepth);
}

// Which launcher environment means "one of N MPI processes" (the run then splits the scenes or, without MPI, refuses).
TEST(RunComm, LaunchedWorldSizeReadsTheLaunchersEnvironment) {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_PROCID", "SLURM_NTASKS"}) unsetenv(v);
  EXPECT_EQ(LaunchedWorldSize(), 1);
  setenv("OMPI_COMM_WORLD_SIZE", "3", 1);
  EXPECT_EQ(LaunchedWorldSize(), 3);
  unsetenv("OMPI_COMM_WORLD_SIZE");
  setenv("PMI_SIZE", "4", 1);
  EXPECT_EQ(LaunchedWorldSize(), 4);
  unsetenv("PMI_SIZE");
  setenv("SLURM_NTASKS", "8", 1);
  EXPECT_EQ(LaunchedWorldSize(), 1);  // an allocation, not a task launched by srun
  setenv("SLURM_PROCID", "0", 1);
  EXPECT_EQ(LaunchedWorldSize(), 8);
  unsetenv("SLURM_PROCID");
  unsetenv("SLURM_NTASKS");
  EXPECT_EQ(MpiCommFromEnvironment(), nullptr);  // not launched: no MPI, the run is the ordinary one
}

}  // namespace
}  // namespace freeloc::pipeline
