// bench/relocalize --phone: phone photos against the VGA pair, as a user runs them. The bundled TUM pair (s00003,
// 640×480, sensor depth) is upscaled (bilinear) to 12 MP (4032×3024) and 48 MP (8064×6048) JPEGs with its intrinsics
// scaled; each row runs `freeloc relocalize` as a child process and reports its wall time, its peak resident memory
// (wait4's ru_maxrss) and its pose against the VGA answer and the ground truth. Tables: the working resolution's
// accuracy/time curve on the 12 MP pair, the phone rows (12 and 48 MP, a 256×192 depth map, full resolution), and the
// network presets on freeloc's tiny models (their peak memory at 12 MP against VGA).
#pragma once

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "bench_util.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"

namespace phone {

struct Run {
  double wall_s = 0, rss_mb = 0;
  std::string status;
  freeloc::Rigid3d pose;
  nlohmann::json record;
};

// `freeloc ARGS --json` as a child: wall time, peak RSS, the record.
inline Run RunFreeloc(const std::string& binary, const std::vector<std::string>& args) {
  const std::string out = std::filesystem::temp_directory_path() / ("freeloc_phone_" + std::to_string(getpid()));
  std::fflush(stdout);
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv = {const_cast<char*>(binary.c_str())};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    static const char* json = "--json";
    argv.push_back(const_cast<char*>(json));
    argv.push_back(nullptr);
    if (!freopen(out.c_str(), "w", stdout)) _exit(127);  // (the parent flushed its own output before the fork)
    if (!freopen("/dev/null", "w", stderr)) _exit(127);
    execv(binary.c_str(), argv.data());
    _exit(127);
  }
  int status = 0;
  rusage ru{};
  wait4(pid, &status, 0, &ru);
  Run r;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.rss_mb = ru.ru_maxrss / 1024.0;
  const std::vector<uint8_t> b = freeloc::io::ReadFileBytes(out);
  std::filesystem::remove(out);
  r.record = nlohmann::json::parse(std::string(b.begin(), b.end()), nullptr, false);
  if (!r.record.is_object()) {
    r.status = "failed (exit " + std::to_string(WEXITSTATUS(status)) + ")";
    return r;
  }
  r.status = r.record.value("status", std::string("?"));
  const auto& q = r.record["qvec"];
  const auto& t = r.record["tvec"];
  r.pose = freeloc::Rigid3d(Eigen::Quaterniond(q[0], q[1], q[2], q[3]), Eigen::Vector3d(t[0], t[1], t[2]));
  return r;
}

// `im` upscaled to w × h, bilinear with pixel centres mapped as everywhere in freeloc.
inline freeloc::Image Upscale(const freeloc::Image& im, int w, int h) {
  freeloc::Image out(w, h);
  const double sx = static_cast<double>(im.width) / w, sy = static_cast<double>(im.height) / h;
  for (int y = 0; y < h; ++y) {
    const double v = std::clamp((y + 0.5) * sy - 0.5, 0.0, im.height - 1.0);
    const int y0 = static_cast<int>(v), y1 = std::min(y0 + 1, im.height - 1);
    const double fy = v - y0;
    for (int x = 0; x < w; ++x) {
      const double u = std::clamp((x + 0.5) * sx - 0.5, 0.0, im.width - 1.0);
      const int x0 = static_cast<int>(u), x1 = std::min(x0 + 1, im.width - 1);
      const double fx = u - x0;
      for (int c = 0; c < 3; ++c) {
        const double a = im.at(x0, y0, c) * (1 - fx) + im.at(x1, y0, c) * fx;
        const double b = im.at(x0, y1, c) * (1 - fx) + im.at(x1, y1, c) * fx;
        out.pixel(x, y)[c] = static_cast<uint8_t>(std::lround(a * (1 - fy) + b * fy));
      }
    }
  }
  return out;
}

inline std::string K(double s) {  // s00003's intrinsics for the photo scaled by s
  char buf[128];
  std::snprintf(buf, sizeof(buf), "%.4f,%.4f,%.4f,%.4f", 535.4 * s, 539.2 * s, (320.1 + 0.5) * s - 0.5,
                (247.6 + 0.5) * s - 0.5);
  return buf;
}

inline std::string Pct(double v) { return freeloc::bench::Fmt("%.1f", 100 * v) + " %"; }

inline int Main(const std::string& binary, const std::string& source_dir, const std::string& models_dir) {
  namespace fs = std::filesystem;
  const std::string s = source_dir + "/data/demo/val/s00003/";
  const fs::path dir = fs::temp_directory_path() / ("freeloc_phone_bench_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const freeloc::Image ref = freeloc::io::ReadImage(s + "seq0/frame_00000.png");
  const freeloc::Image query = freeloc::io::ReadImage(s + "seq1/frame_00000.png");
  const auto jpeg = [&](const freeloc::Image& im, int w, int h, const std::string& name) {
    const std::vector<uint8_t> b = freeloc::io::EncodeJpeg(Upscale(im, w, h), 92, name);
    freeloc::io::WriteFileAtomic((dir / name).string(), b.data(), b.size());
    return (dir / name).string();
  };
  const std::string r12 = jpeg(ref, 4032, 3024, "ref12.jpg"), q12 = jpeg(query, 4032, 3024, "q12.jpg");
  const std::string r48 = jpeg(ref, 8064, 6048, "ref48.jpg"), q48 = jpeg(query, 8064, 6048, "q48.jpg");
  // A phone's depth map: 256×192 (the sensor map sampled at the centres of 2.5×2.5-pixel cells).
  const auto small_depth = [&](const std::string& from, const std::string& name) {
    const freeloc::DepthMap d = freeloc::io::ReadDepthPng(from);
    freeloc::DepthMap out(256, 192);
    for (int y = 0; y < 192; ++y)
      for (int x = 0; x < 256; ++x)
        out.at(x, y) = d.at(std::lround((x + 0.5) * 2.5 - 0.5), std::lround((y + 0.5) * 2.5 - 0.5));
    freeloc::io::WriteDepthPng((dir / name).string(), out);
    return (dir / name).string();
  };
  const std::string dr = s + "seq0/frame_00000.sensor.png", dq = s + "seq1/frame_00000.sensor.png";
  const std::string dr_small = small_depth(dr, "ref_depth_256.png"), dq_small = small_depth(dq, "q_depth_256.png");
  const freeloc::io::MapfreeScene scene = freeloc::io::MapfreeScene::Load(s);
  const freeloc::Rigid3d truth = scene.gt.at(scene.queries.at(0).name);
  const auto pair = [&](const std::string& a, const std::string& b, const std::string& k, const std::string& da,
                        const std::string& db, std::vector<std::string> extra) {
    std::vector<std::string> args = {
        "relocalize", "--ref",         a, "--query", b, "--ref-intrinsics", k, "--query-intrinsics", k, "--ref-depth",
        da,           "--query-depth", db};
    args.insert(args.end(), extra.begin(), extra.end());
    return RunFreeloc(binary, args);
  };
  std::printf("%s\n\n", freeloc::bench::MachineLine().c_str());
  const Run vga = pair(s + "seq0/frame_00000.png", s + "seq1/frame_00000.png", K(1), dr, dq, {});
  const auto vs = [&](const Run& r, const freeloc::Rigid3d& to) {
    return std::make_pair((r.pose.translation - to.translation).norm() / to.translation.norm(),
                          freeloc::RotationAngleDeg(r.pose.rotation, to.rotation));
  };
  const auto timing_share = [](const Run& r) {
    double sum = 0;
    for (const char* k : {"decode_ms", "prepare_ms", "depth_ms", "match_ms", "instance_ms", "solve_ms"})
      sum += r.record.value(k, 0.0);
    return sum / 1000 / r.wall_s;
  };

  std::printf("### sift-essential: the working resolution on the 12 MP pair (accuracy/time curve)\n\n");
  freeloc::bench::MarkdownTable curve(
      {"max_side", "status", "wall", "peak RSS", "t vs VGA", "R vs VGA", "t vs truth", "R vs truth"});
  const auto add_curve = [&](const std::string& label, const Run& r) {
    const auto a = vs(r, vga.pose), b = vs(r, truth);
    curve.Row({label, r.status, freeloc::bench::Fmt("%.2f", r.wall_s) + " s",
               freeloc::bench::Fmt("%.0f", r.rss_mb) + " MB", Pct(a.first), freeloc::bench::Fmt("%.2f", a.second) + "°",
               Pct(b.first), freeloc::bench::Fmt("%.2f", b.second) + "°"});
  };
  add_curve("VGA pair (640)", vga);
  for (const char* m : {"640", "1024", "1600", "2048", "3000", "0"})
    add_curve(std::string(m) == "0" ? "0 (4032, full)" : m,
              pair(r12, q12, K(6.3), dr, dq, {"--set", std::string("max_side=") + m}));
  curve.Print();

  std::printf("\n### sift-essential: phone photos against the VGA pair (default working resolution)\n\n");
  freeloc::bench::MarkdownTable rows(
      {"input", "status", "wall", "× VGA", "peak RSS", "t vs VGA", "R vs VGA", "stage times / wall", "inputs"});
  const auto add = [&](const std::string& label, const Run& r) {
    const auto a = vs(r, vga.pose);
    std::string notes;
    if (r.record.is_object() && r.record.contains("inputs"))
      notes = std::to_string(r.record["inputs"].size()) + " noted";
    rows.Row({label, r.status, freeloc::bench::Fmt("%.2f", r.wall_s) + " s",
              freeloc::bench::Fmt("%.2f", r.wall_s / vga.wall_s), freeloc::bench::Fmt("%.0f", r.rss_mb) + " MB",
              Pct(a.first), freeloc::bench::Fmt("%.2f", a.second) + "°", Pct(timing_share(r)), notes});
  };
  add("640×480 PNG pair", vga);
  add("12 MP JPEG pair", pair(r12, q12, K(6.3), dr, dq, {}));
  add("48 MP JPEG pair", pair(r48, q48, K(12.6), dr, dq, {}));
  add("12 MP + 256×192 depth", pair(r12, q12, K(6.3), dr_small, dq_small, {}));
  add("12 MP, full resolution", pair(r12, q12, K(6.3), dr, dq, {"--set", "max_side=0"}));
  rows.Print();

  if (!models_dir.empty() && fs::exists(models_dir + "/dust3r_tiny.pth")) {
    std::printf("\n### network presets on freeloc's tiny models: peak RSS at 12 MP against VGA\n\n");
    freeloc::bench::MarkdownTable nets(
        {"preset", "VGA wall", "VGA peak RSS", "12 MP wall", "12 MP peak RSS", "RSS ratio"});
    const std::vector<std::string> weights = {
        "--dust3r", models_dir + "/dust3r_tiny.pth",          "--mast3r",   models_dir + "/mast3r_tiny.pth",
        "--seggpt", models_dir + "/seggpt/model.safetensors", "--metric3d", models_dir + "/metric3d/model.safetensors"};
    for (const char* preset : {"dust3r", "mast3r", "seed"}) {
      std::vector<std::string> extra = {"--preset", preset};
      extra.insert(extra.end(), weights.begin(), weights.end());
      const Run a = pair(s + "seq0/frame_00000.png", s + "seq1/frame_00000.png", K(1), dr, dq, extra);
      const Run b = pair(r12, q12, K(6.3), dr, dq, extra);
      nets.Row({std::string(preset) + (a.record.is_object() ? "" : " (" + a.status + ")"),
                freeloc::bench::Fmt("%.2f", a.wall_s) + " s", freeloc::bench::Fmt("%.0f", a.rss_mb) + " MB",
                freeloc::bench::Fmt("%.2f", b.wall_s) + " s", freeloc::bench::Fmt("%.0f", b.rss_mb) + " MB",
                freeloc::bench::Fmt("%.3f", b.rss_mb / a.rss_mb)});
    }
    nets.Print();
  }
  fs::remove_all(dir);
  return 0;
}

}  // namespace phone
