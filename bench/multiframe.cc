// bench/multiframe — the Map-free Multi Frame track: freeloc's window fusion (pipeline/multi_frame.h) against the
// single-frame answer on the same evaluated frames (`--frames 1`), per depth kind and device-pose variant, through
// the run controller (`freeloc run --track multi-frame`) and the evaluator (`freeloc eval --track multi-frame`).
// Data: synthetic hand-held query sequences (testing/sequence_scene.h: photo-textured rooms, 9-frame paths ending at
// each evaluated frame, frame numbers with gaps, device poses from a drifting tracker in the documented convention,
// in another convention and as garbage), generated here from --seed (tune on one seed, report on others).
//
//   multiframe [--scenes N] [--windows W] [--seed S] [--depth exact,degraded8,mono] [--hard] [--keep DIR]
//              [--per-query] [--variants 0,1,...]   (indices into the table's variants; default all)
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "bench_util.h"
#include "freeloc/core/logging.h"
#include "freeloc/eval/report.h"
#include "freeloc/io/image_io.h"
#include "freeloc/pipeline/run_controller.h"
#include "testing/sequence_scene.h"

using namespace freeloc;
using freeloc::bench::Fmt;

namespace {

struct Variant {
  const char* name;
  int frames;
  const char* device;  // device_poses option
  const char* file;    // which poses_device.<file>.txt is installed as poses_device.txt ("" = none)
};

struct Errors {
  std::vector<double> t, r;
  int pose_ok = 0, n = 0, answered = 0;
  double Median(std::vector<double> v) const { return bench::Median(v); }
};

}  // namespace

int main(int argc, char** argv) {
  int n_scenes = 6, windows = 3;
  uint32_t seed = 9001;  // scene s has seed + 17·s
  std::string keep, depths = "exact,degraded8,mono", only;
  bool per_query = false, hard = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--scenes") && i + 1 < argc) n_scenes = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--windows") && i + 1 < argc) windows = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--keep") && i + 1 < argc) keep = argv[++i];
    if (!std::strcmp(argv[i], "--depth") && i + 1 < argc) depths = argv[++i];
    if (!std::strcmp(argv[i], "--per-query")) per_query = true;
    if (!std::strcmp(argv[i], "--variants") && i + 1 < argc) only = argv[++i];
    if (!std::strcmp(argv[i], "--hard")) hard = true;
    if (!std::strcmp(argv[i], "--seed") && i + 1 < argc) seed = static_cast<uint32_t>(std::atoll(argv[++i]));
  }
  SetLogLevel(LogLevel::kWarning);
  namespace fs = std::filesystem;
  const std::string tmp = (fs::temp_directory_path() / ("freeloc_multiframe_" + std::to_string(getpid()))).string();
  const std::string split = keep.empty() ? tmp + "/val" : keep;
  std::printf("## bench/multiframe — the Multi Frame track: window fusion vs the single-frame answer\n\n");
  std::printf("%s\n\n", bench::MachineLine().c_str());
  std::vector<Image> photos;
  for (const std::string& p : bench::DemoTexturePhotos())
    photos.push_back(io::ReadImage(std::string(FREELOC_SOURCE_DIR) + "/data/demo/val/" + p));
  freeloc::testing::SequenceOptions so;
  so.windows = windows;
  if (hard) so.difficulty = freeloc::testing::SceneDifficulty::Hard();
  const double t0 = bench::NowSeconds();
  std::vector<std::string> scenes;
  for (int s = 0; s < n_scenes; ++s) {
    char name[16];
    std::snprintf(name, sizeof(name), "s%05d", s);
    scenes.push_back(name);
    const std::string dir = split + "/" + name;
    if (!fs::exists(dir + "/poses.txt"))
      freeloc::testing::WriteSequenceScene(dir, seed + 17u * static_cast<uint32_t>(s), photos, so);
    if (!fs::exists(dir + "/poses_device.documented.txt"))
      fs::copy_file(dir + "/poses_device.txt", dir + "/poses_device.documented.txt");
  }
  std::printf(
      "Synthetic query sequences (seed %u + 17·s%s): %d scenes × %d evaluated frames (+ %d trailing frames), "
      "%d×%d, evaluated frames placed as single-frame queries (baseline %.1f–%.1f m, rotation ≤ %.1f°), each "
      "ending a 9-frame hand-held path (%.0f–%.0f cm and ≤ %.1f° per frame), frame numbers with gaps; device "
      "poses from a drifting tracker (±2 %% scale, 2 mm + 0.05° random walk per frame). Depth per frame as "
      "bench/baseline (`exact`, `degraded8`, `mono`; each frame's errors independent). Generated in %.1f s into "
      "%s. `sift-essential` (anchored scale), provided depth.\n\n",
      seed, hard ? ", --hard" : "", n_scenes, windows, so.trailing, so.width, so.height, so.difficulty.min_baseline_m,
      so.difficulty.max_baseline_m, so.difficulty.max_rotation_rad * 180 / 3.14159265358979, 100 * so.min_step_m,
      100 * so.max_step_m, so.max_turn_deg, bench::NowSeconds() - t0, split.c_str());

  const std::vector<std::string> wanted = bench::SplitList(only);
  const std::vector<Variant> variants = {
      {"single frame (--frames 1)", 1, "ignore", ""},
      {"window, images only (--device-poses ignore)", 9, "ignore", ""},
      {"window, device poses documented (auto)", 9, "auto", "documented"},
      {"window, device poses other convention (auto)", 9, "auto", "other"},
      {"window, device poses garbage (auto)", 9, "auto", "garbage"},
      {"window, device poses documented (use)", 9, "use", "documented"},
  };
  bench::MarkdownTable table({"depth", "variant", "median t err (m)", "× single", "p90 t err (m)", "median R err (°)",
                              "precision (25 cm, 5°)", "evaluated", "device used (windows)", "s / evaluated query"});
  for (const std::string& depth : bench::SplitList(depths)) {
    std::vector<eval::EvalRun> reports;
    double single_median = 0;
    for (const Variant& v : variants) {
      if (!only.empty() &&
          std::find(wanted.begin(), wanted.end(), std::to_string(&v - variants.data())) == wanted.end())
        continue;
      for (const auto& name : scenes) {
        const std::string dir = split + "/" + name;
        std::error_code ec;
        fs::remove(dir + "/poses_device.txt", ec);
        if (*v.file) fs::copy_file(dir + "/poses_device." + std::string(v.file) + ".txt", dir + "/poses_device.txt");
      }
      pipeline::PipelineOptions o = pipeline::ResolvePreset("sift-essential");
      o.depth = pipeline::DepthSpec::FromString("provided:" + depth);
      pipeline::SetOption(&o, "track", "multi-frame");
      pipeline::SetOption(&o, "frames", std::to_string(v.frames));
      pipeline::SetOption(&o, "device_poses", v.device);
      pipeline::RunSpec spec;
      spec.data = split;
      spec.scenes = scenes;  // a --keep folder may hold more scenes than this run's
      spec.out = tmp + "/" + depth + "_" + std::to_string(&v - variants.data()) + ".zip";
      spec.progress_bar = false;
      fs::create_directories(tmp);
      const double t1 = bench::NowSeconds();
      const pipeline::RunResult res = pipeline::ExecuteRun(spec, o);
      const double secs = bench::NowSeconds() - t1;
      Errors e;
      int device_used = 0;
      for (const auto& name : res.scenes) {
        const io::MapfreeScene& sc = res.loaded.at(name);
        for (const auto& q : res.results.at(name)) {
          ++e.n;
          if (q.window.device.rfind("used", 0) == 0) ++device_used;
          if (!q.submitted() || !sc.gt.count(q.frame)) continue;
          const Rigid3d& gt = sc.gt.at(q.frame);
          const double te = (q.query_from_ref.Center() - gt.Center()).norm();
          const double re = RotationAngleDeg(q.query_from_ref.rotation, gt.rotation);
          e.t.push_back(te);
          e.r.push_back(re);
          e.pose_ok += te < 0.25 && re < 5;
          if (per_query)
            std::printf("%s %s %s %s: t %.3f m R %.2f° |t_gt| %.2f scale %s depth %.3f rig %.3f used %d/%d device %s\n",
                        depth.c_str(), v.name, name.c_str(), q.frame.c_str(), te, re, gt.translation.norm(),
                        q.window.scale.c_str(), q.window.depth_distance_m, q.window.rig_distance_m, q.window.used,
                        q.window.frames, q.window.device.c_str());
        }
      }
      std::vector<double> st = e.t;
      std::sort(st.begin(), st.end());
      const double med = bench::Median(e.t);
      if (v.frames == 1) single_median = med;
      table.Row({depth, v.name, Fmt("%.4f", med), Fmt("%.2f", single_median > 0 ? med / single_median : 0.0),
                 Fmt("%.4f", st.empty() ? 0.0 : st[st.size() * 9 / 10]), Fmt("%.3f", bench::Median(e.r)),
                 Fmt("%.3f", e.n ? static_cast<double>(e.pose_ok) / e.n : 0.0), std::to_string(e.n),
                 std::to_string(device_used), Fmt("%.2f", secs / std::max(1, e.n))});
      reports.push_back(eval::RunEvaluation(split, scenes, spec.out, io::Track::kMultiFrame));
      reports.back().label = v.name;
    }
    std::printf("### depth `%s`: the 8 metrics on the evaluated frames (`eval --track multi-frame`)\n\n%s\n",
                depth.c_str(), eval::MarkdownCompare(reports).c_str());
  }
  std::printf("### every evaluated frame (camera-centre and rotation errors against the ground truth)\n\n");
  table.Print();
  std::error_code ec;
  if (keep.empty()) fs::remove_all(tmp, ec);
  return 0;
}
