// bench/eval — reading + evaluating a val-sized synthetic case (65 scenes × 570 queries, every query in the
// submission, every 5th evaluated) with freeloc's evaluator. Goal: under 1 s on the 2-core dev machine.
//
//   eval [--scenes N] [--queries Q] [--reps R]
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>

#include "bench_util.h"
#include "freeloc/core/logging.h"
#include "freeloc/eval/report.h"
#include "freeloc/io/submission.h"

namespace fs = std::filesystem;
using freeloc::bench::Fmt;

int main(int argc, char** argv) {
  int scenes = 65, queries = 570, reps = 5;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--scenes") && i + 1 < argc)
      scenes = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--queries") && i + 1 < argc)
      queries = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: eval [--scenes N] [--queries Q] [--reps R]\n");
      return 2;
    }
  }
  freeloc::SetLogLevel(freeloc::LogLevel::kError);
  const fs::path root = fs::temp_directory_path() / ("freeloc_bench_eval_" + std::to_string(getpid()));
  const fs::path split = root / "val";
  std::mt19937 rng(42);
  std::normal_distribution<double> n(0, 1);
  std::map<std::string, std::vector<freeloc::io::SubmissionEntry>> sub;
  std::vector<std::string> names;
  const double t_gen0 = freeloc::bench::NowSeconds();
  for (int s = 0; s < scenes; ++s) {
    char sn[16];
    std::snprintf(sn, sizeof(sn), "s%05d", 460 + s);
    names.push_back(sn);
    fs::create_directories(split / sn);
    std::string intr = "seq0/frame_00000.jpg 590.1 591.2 269.8 360.3 540 720\n";
    std::string poses = "seq0/frame_00000.jpg 1 0 0 0 0 0 0\n";
    for (int q = 0; q < queries; ++q) {
      char fn[32];
      std::snprintf(fn, sizeof(fn), "seq1/frame_%05d.jpg", q);
      const freeloc::Rigid3d gt(Eigen::Quaterniond(1, 0.1 * n(rng), 0.1 * n(rng), 0.1 * n(rng)).normalized(),
                                Eigen::Vector3d(n(rng), n(rng), n(rng)));
      intr += std::string(fn) + " 590.1 591.2 269.8 360.3 540 720\n";
      const std::string line = freeloc::io::FormatPoseLine({fn, gt, 0});
      poses += line.substr(0, line.rfind(' ')) + "\n";
      freeloc::Rigid3d est = gt;
      est.translation += 0.3 * Eigen::Vector3d(n(rng), n(rng), n(rng));
      est.rotation = (est.rotation * Eigen::Quaterniond(1, 0.03 * n(rng), 0.03 * n(rng), 0.03 * n(rng))).normalized();
      sub[sn].push_back({fn, est, std::abs(100 * n(rng))});
    }
    std::FILE* f = std::fopen((split / sn / "intrinsics.txt").c_str(), "w");
    std::fputs(intr.c_str(), f);
    std::fclose(f);
    f = std::fopen((split / sn / "poses.txt").c_str(), "w");
    std::fputs(poses.c_str(), f);
    std::fclose(f);
  }
  const std::string zip = (root / "submission.zip").string();
  const double t_write0 = freeloc::bench::NowSeconds();
  freeloc::io::WriteSubmission(zip, sub);
  const double t_write = freeloc::bench::NowSeconds() - t_write0;
  (void)t_gen0;

  std::vector<double> times;
  freeloc::eval::EvalRun run;
  for (int r = 0; r < reps + 1; ++r) {  // first run warms the page cache
    const double t0 = freeloc::bench::NowSeconds();
    run = freeloc::eval::RunEvaluation(split.string(), names, zip);
    if (r > 0) times.push_back(freeloc::bench::NowSeconds() - t0);
  }
  std::printf("## bench/eval — %d scenes × %d queries (%lld evaluated frames), median of %d\n\n", scenes, queries,
              static_cast<long long>(run.overall.estimates + run.overall.failures), reps);
  freeloc::bench::MarkdownTable t({"step", "median s", "goal"});
  t.Row({"write submission ZIP (" + std::to_string(scenes * queries) + " poses)", Fmt("%.3f", t_write), "–"});
  t.Row({"read GT + submission, evaluate, aggregate", Fmt("%.3f", freeloc::bench::Median(times)), "< 1 s"});
  t.Print();
  std::printf("\nAUC @ VCRE < 90px = %.4f, Precision @ Pose = %.4f (sanity)\npeak RSS: %.0f MB\n", run.overall.auc_vcre,
              run.overall.precision_pose, freeloc::bench::PeakRssMB());
  fs::remove_all(root);
  return 0;
}
