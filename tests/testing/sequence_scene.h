// Synthetic query sequences for the Multi Frame track (docs/pipeline.md "Multi Frame"): the photo-textured room of
// textured_scene.h, and a seq1 that is a hand-held video — each evaluated frame (linear positions 9, 19, …) ends a
// smooth path of 9 frames (2–7 cm and up to 0.6° per frame, a gentle arc), frame numbers with gaps, exact /
// degraded8 / mono depth per frame, ground truth for every frame, and the phone's tracking poses three ways:
//   poses_device.txt          the documented convention (frame_from_query), from a drifting tracker (±2 % scale,
//                             a 2 mm and 0.05° random walk per frame);
//   poses_device.other.txt    the convention the public sample appears to follow: P_q⁻¹ ∘ P_j with P the tracker's
//                             world-to-camera poses in its own gravity-aligned world (same drift);
//   poses_device.garbage.txt  random poses (the evaluated frame's line still the identity).
// Header-only.
#pragma once

#include <Eigen/Geometry>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "testing/mapfree_writer.h"
#include "testing/textured_scene.h"

namespace freeloc::testing {

struct SequenceOptions {
  int windows = 3;   // evaluated frames
  int trailing = 2;  // frames after the last evaluated one (unused by the track)
  int width = 360, height = 480;
  double min_step_m = 0.02, max_step_m = 0.07;  // camera motion per frame
  double max_turn_deg = 0.6;                    // rotation per frame
  SceneDifficulty difficulty;                   // the evaluated frames' placement, texture and noise
};

// A poses_device.txt line as the dataset writes them (16 decimals; poses.txt and intrinsics.txt use the writer's
// own lines, testing/mapfree_writer.h).
inline std::string DeviceLine(const std::string& name, const Rigid3d& p) {
  const auto q = p.QuaternionWxyz();
  char line[320];
  std::snprintf(line, sizeof(line), "%s %.16f %.16f %.16f %.16f %.16f %.16f %.16f\n", name.c_str(), q[0], q[1], q[2],
                q[3], p.translation.x(), p.translation.y(), p.translation.z());
  return line;
}

// The scene folder `dir`; returns the frame names of seq1 in order.
inline std::vector<std::string> WriteSequenceScene(const std::string& dir, uint32_t seed,
                                                   const std::vector<Image>& photos, const SequenceOptions& so = {}) {
  namespace fs = std::filesystem;
  fs::create_directories(dir + "/seq0");
  fs::create_directories(dir + "/seq1");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  std::normal_distribution<double> g(0, 1);
  auto unit = [&] { return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized(); };
  const SceneDifficulty& hard = so.difficulty;
  const SyntheticScene base = MakeRoomScene(seed, 0.5, so.width, so.height);
  std::string intrinsics, poses, dev_doc, dev_other, dev_garbage;
  Image ref_img = RenderTextured(base, base.ref, Rigid3d(), photos, hard.px_per_m);
  AddImageNoise(&ref_img, hard.noise_grey, seed ^ 0x5bd1e995u);
  io::WriteImagePng(dir + "/seq0/frame_00000.png", ref_img);
  WriteDepthMm(dir + "/seq0/frame_00000.exact.png", base.depth_ref);
  WriteDepthVariants(dir + "/seq0/frame_00000", base.depth_ref, seed, -1);
  intrinsics += internal::IntrinsicsLine("seq0/frame_00000.png", base.ref);
  poses += internal::PoseLine("seq0/frame_00000.png", Rigid3d());

  // The tracker's world: gravity-aligned, arbitrary heading and origin (for the other convention).
  const Rigid3d tracker_from_ref(
      Eigen::Quaterniond(Eigen::AngleAxisd(6.28 * u01(rng), Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(0.3 * (u01(rng) - 0.5), Eigen::Vector3d::UnitX())),
      Eigen::Vector3d(2 * g(rng), 0.5 * g(rng), 2 * g(rng)));
  std::vector<std::string> names;
  int number = 0;
  const int total = 10 * so.windows + so.trailing;
  std::vector<Rigid3d> cam_from_ref(static_cast<size_t>(total));
  for (int w = 0; w * 10 < total; ++w) {
    // The evaluated frame of this stretch (linear position 10w + 9), placed as a single-frame query would be.
    const double baseline = hard.min_baseline_m + (hard.max_baseline_m - hard.min_baseline_m) * u01(rng);
    const Eigen::Quaterniond rq(Eigen::AngleAxisd(2 * hard.max_rotation_rad * (u01(rng) - 0.5), unit()));
    const Eigen::Vector3d cq =
        Eigen::Vector3d(u01(rng) - 0.5, 0.3 * (u01(rng) - 0.5), 0.5 * (u01(rng) - 0.5)).normalized() * baseline;
    // The path that ends there: velocity, a gentle arc, a turn.
    const double step = so.min_step_m + (so.max_step_m - so.min_step_m) * u01(rng);
    const Eigen::Vector3d v = step * unit(), acc = 0.1 * step * unit();
    const Eigen::Vector3d turn_axis = unit();
    const double turn = so.max_turn_deg * u01(rng) * 3.14159265358979 / 180;
    for (int k = -9; k <= 0; ++k) {
      const int pos = 10 * w + 9 + k;
      if (pos >= total) break;
      const Eigen::Vector3d c = cq + v * k + 0.5 * acc * k * k;
      const Eigen::Quaterniond ref_from_cam =
          rq.conjugate() * Eigen::Quaterniond(Eigen::AngleAxisd(turn * k, turn_axis));
      cam_from_ref[static_cast<size_t>(pos)] = Rigid3d(ref_from_cam.conjugate(), -(ref_from_cam.conjugate() * c));
    }
  }
  for (int pos = 0; pos < total; ++pos) {
    number += 1 + (u01(rng) < 0.15 ? 1 + static_cast<int>(2 * u01(rng)) : 0);  // frame numbers skip now and then
    char name[64];
    std::snprintf(name, sizeof(name), "seq1/frame_%05d", number);
    const std::string file = std::string(name) + ".png";
    names.push_back(file);
    const Rigid3d& T = cam_from_ref[static_cast<size_t>(pos)];
    SyntheticScene sc = base;
    Image img = RenderTextured(sc, sc.query, T, photos, hard.px_per_m);
    AddImageNoise(&img, hard.noise_grey, seed * 31u + static_cast<uint32_t>(pos));
    io::WriteImagePng(dir + "/" + file, img);
    const DepthMap d = sc.Render(sc.query, T);
    WriteDepthMm(dir + "/" + name + ".exact.png", d);
    WriteDepthVariants(dir + "/" + name, d, seed, pos);
    intrinsics += internal::IntrinsicsLine(file, sc.query);
    poses += internal::PoseLine(file, T);
  }
  // Device poses of the window frames (linear positions 10w+1 … 10w+9), relative to each window's evaluated frame.
  for (int w = 0; w < so.windows; ++w) {
    const int qpos = 10 * w + 9;
    const Rigid3d& Tq = cam_from_ref[static_cast<size_t>(qpos)];
    const double scale = 1 + 0.02 * (2 * u01(rng) - 1);
    std::vector<Rigid3d> drift(10);  // per offset from the evaluated frame, a random walk away from it
    Eigen::Vector3d walk_t = Eigen::Vector3d::Zero(), walk_r = Eigen::Vector3d::Zero();
    for (int k = 1; k <= 8; ++k) {
      walk_t += 0.002 * Eigen::Vector3d(g(rng), g(rng), g(rng));
      walk_r += 0.05 * 3.14159265358979 / 180 * Eigen::Vector3d(g(rng), g(rng), g(rng));
      drift[static_cast<size_t>(k)] =
          Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(walk_r.norm(), walk_r.normalized())), walk_t);
    }
    for (int k = 8; k >= 0; --k) {
      const int pos = qpos - k;
      const std::string& name = names[static_cast<size_t>(pos)];
      if (k == 0) {  // the evaluated frame: the identity, with signed zeros as in the real files
        const std::string id = name +
                               " 1.0000000000000000 -0.0000000000000000 0.0000000000000000 -0.0000000000000000 "
                               "0.0000000000000000 -0.0000000000000000 0.0000000000000000\n";
        dev_doc += id;
        dev_other += id;
        dev_garbage += id;
        continue;
      }
      const Rigid3d& Tj = cam_from_ref[static_cast<size_t>(pos)];
      Rigid3d rel = Tj * Tq.Inverse();  // frame_from_query, the truth
      rel.translation *= scale;
      const Rigid3d noisy = drift[static_cast<size_t>(k)] * rel;
      dev_doc += DeviceLine(name, noisy);
      // P = cam_from_tracker; the lines as the public sample seems to write them: P_q⁻¹ ∘ P_j.
      const Rigid3d Pq = Tq * tracker_from_ref.Inverse();
      const Rigid3d Pj = drift[static_cast<size_t>(k)] * Tj * tracker_from_ref.Inverse();
      dev_other += DeviceLine(name, Pq.Inverse() * Pj);
      dev_garbage += DeviceLine(
          name, Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.35 * u01(rng), unit())), 0.5 * u01(rng) * unit()));
    }
  }
  auto write = [&](const std::string& file, std::string text, bool final_newline) {
    if (!final_newline && !text.empty()) text.pop_back();
    std::FILE* f = std::fopen((dir + "/" + file).c_str(), "w");
    std::fputs(text.c_str(), f);
    std::fclose(f);
  };
  write("intrinsics.txt", intrinsics, true);
  write("poses.txt", poses, true);
  write("poses_device.txt", dev_doc, false);  // the public sample's last line has no newline either
  write("poses_device.other.txt", dev_other, false);
  write("poses_device.garbage.txt", dev_garbage, false);
  return names;
}

}  // namespace freeloc::testing
