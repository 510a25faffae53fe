// Synthetic map-free scene folders for pipeline and CLI tests: the layout of the benchmark (intrinsics.txt,
// poses.txt, seq0/frame_00000.png reference, seq1/frame_XXXXX.png queries, frame_XXXXX.<suffix>.png depth in
// uint16 mm, correspondences_<name>.npz float64 [queries, max_pts, 4] NaN-padded) from the ray-cast room of
// synthetic_scene.h. Images are blank (the precomputed matcher never looks at them). Header-only.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/io/submission.h"
#include "testing/synthetic_scene.h"
#include "testing/testing.h"

namespace freeloc::testing {

struct SyntheticMapfreeOptions {
  int queries = 4;
  int width = 160, height = 120;
  std::string depth_suffix = "gt";
  std::string correspondences = "SIFT";
  double noise_px = 0.7;
  double outliers = 0.3;
  bool degrade_depth = true;  // monocular-like depth (global scale, smooth field, blobs, holes) for variety
  // The queries' camera roll about the optical axis: 0 — small rotations (±6° about any axis); r > 0 — a roll of
  // r to r + 0.8 radians either way (a phone held sideways), where unit quaternions' last bits are at stake.
  double roll_rad = 0;
};

namespace internal {

inline std::string PoseLine(const std::string& name, const Rigid3d& p) {
  const auto q = p.QuaternionWxyz();
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", name.c_str(), q[0], q[1], q[2],
                q[3], p.translation.x(), p.translation.y(), p.translation.z());
  return buf;
}

inline std::string IntrinsicsLine(const std::string& name, const Camera& k) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s %.17g %.17g %.17g %.17g %d %d\n", name.c_str(), k.fx, k.fy, k.cx, k.cy, k.width,
                k.height);
  return buf;
}

// A .npz holding `correspondences` (float64, [rows.size(), max, 4], NaN padding).
inline void WriteCorrespondencesNpz(const std::string& path, const std::vector<std::vector<Eigen::Vector4d>>& rows) {
  size_t m = 1;
  for (const auto& r : rows) m = std::max(m, r.size());
  std::vector<double> v(rows.size() * m * 4, std::numeric_limits<double>::quiet_NaN());
  for (size_t q = 0; q < rows.size(); ++q)
    for (size_t k = 0; k < rows[q].size(); ++k)
      for (int c = 0; c < 4; ++c) v[(q * m + k) * 4 + c] = rows[q][k](c);
  std::string h = "{'descr': '<f8', 'fortran_order': False, 'shape': (" + std::to_string(rows.size()) + ", " +
                  std::to_string(m) + ", 4), }";
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::string npy = std::string("\x93NUMPY\x01\x00", 8) + static_cast<char>(h.size() & 0xff) +
                    static_cast<char>(h.size() >> 8) + h +
                    std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
  io::WriteZipAtomic(path, {{"correspondences.npy", npy}});
}

}  // namespace internal

// Writes scene `dir` (its name is the folder's); deterministic in `seed`. Query 0 gets only 4 correspondences
// (too few for any solver), so every scene holds a failure next to its answers.
inline void WriteSyntheticMapfreeScene(const std::string& dir, uint32_t seed, const SyntheticMapfreeOptions& o = {}) {
  namespace fs = std::filesystem;
  fs::create_directories(dir + "/seq0");
  fs::create_directories(dir + "/seq1");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  SyntheticScene base = MakeRoomScene(seed, 0.5, o.width, o.height);
  const std::string ref = "seq0/frame_00000.png";
  std::string intrinsics = internal::IntrinsicsLine(ref, base.ref), poses = internal::PoseLine(ref, Rigid3d());
  io::WriteImagePng(dir + "/" + ref, Image(o.width, o.height));
  DepthMap dref = base.depth_ref;
  if (o.degrade_depth) dref = DegradeDepth(dref, rng(), 0.05, 0.05, 0.05, 0.02);
  io::WriteDepthPng(dir + "/seq0/frame_00000." + o.depth_suffix + ".png", dref);
  std::vector<std::vector<Eigen::Vector4d>> rows;
  for (int k = 0; k < o.queries; ++k) {
    char name[64];
    std::snprintf(name, sizeof(name), "seq1/frame_%05d", k);
    // Another query pose in the same room.
    SyntheticScene s = base;
    const Eigen::Vector3d axis = Eigen::Vector3d(u01(rng) - 0.5, u01(rng) - 0.5, u01(rng) - 0.5).normalized();
    Eigen::Quaterniond q;
    if (o.roll_rad > 0) {  // (draws only then: the small-rotation scenes keep their seeds' numbers)
      const double sign = u01(rng) < 0.5 ? -1 : 1;
      q = Eigen::AngleAxisd(sign * (o.roll_rad + 0.8 * u01(rng)),
                            (0.15 * axis + Eigen::Vector3d::UnitZ()).normalized());
    } else {
      q = Eigen::AngleAxisd(0.2 * (u01(rng) - 0.5), axis);
    }
    const Eigen::Vector3d c =
        Eigen::Vector3d(u01(rng) - 0.5, 0.3 * (u01(rng) - 0.5), u01(rng) - 0.5).normalized() * (0.2 + 1.2 * u01(rng));
    s.query_from_ref = Rigid3d(q, -(q * c));
    s.depth_query = s.Render(s.query, s.query_from_ref);
    std::vector<Eigen::Vector2d> p1, p2;
    s.Correspondences(k == 0 ? 4 : 80 + static_cast<int>(300 * u01(rng)), o.noise_px, rng(), &p1, &p2);
    std::vector<Eigen::Vector4d> r;
    for (size_t i = 0; i < p1.size(); ++i) {
      if (u01(rng) < o.outliers) p2[i] = Eigen::Vector2d(u01(rng) * (o.width - 1), u01(rng) * (o.height - 1));
      r.emplace_back(p1[i].x(), p1[i].y(), p2[i].x(), p2[i].y());
    }
    rows.push_back(r);
    intrinsics += internal::IntrinsicsLine(std::string(name) + ".png", s.query);
    poses += internal::PoseLine(std::string(name) + ".png", s.query_from_ref);
    io::WriteImagePng(dir + "/" + name + ".png", Image(o.width, o.height));
    DepthMap dq = s.depth_query;
    if (o.degrade_depth) dq = DegradeDepth(dq, rng(), 0.05, 0.05, 0.05, 0.02);
    io::WriteDepthPng(dir + "/" + name + "." + o.depth_suffix + ".png", dq);
  }
  WriteText(dir + "/intrinsics.txt", intrinsics);
  WriteText(dir + "/poses.txt", poses);
  internal::WriteCorrespondencesNpz(dir + "/correspondences_" + o.correspondences + ".npz", rows);
}

}  // namespace freeloc::testing
