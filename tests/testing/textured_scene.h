// Photo-textured synthetic scenes in the map-free layout: the ray-cast room of synthetic_scene.h with every plane
// textured by a photo (mirrored tiling, ~`px_per_m` texels per metre), rendered with 2×2 supersampling, exact depth
// and monocular-style degraded depth, and ground-truth poses. For side-by-side benchmarks of whole pipelines
// (SIFT included) on data whose truth is exact. Header-only.
#pragma once

#include <Eigen/Geometry>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "freeloc/core/image.h"
#include "freeloc/io/image_io.h"
#include "testing/synthetic_scene.h"

namespace freeloc::testing {

// Bilinear, mirrored-repeat texture lookup; (s, t) in texels.
inline Eigen::Vector3d SampleTexture(const Image& tex, double s, double t) {
  auto wrap = [](double v, int n) {
    const double period = 2.0 * (n - 1);
    v = std::fmod(std::abs(v), period);
    return v > n - 1 ? period - v : v;
  };
  s = wrap(s, tex.width);
  t = wrap(t, tex.height);
  const int x0 = std::min(static_cast<int>(s), tex.width - 2), y0 = std::min(static_cast<int>(t), tex.height - 2);
  const double fx = s - x0, fy = t - y0;
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      const uint8_t* p = &tex.data[3 * (static_cast<size_t>(y0 + dy) * tex.width + (x0 + dx))];
      out += w * Eigen::Vector3d(p[0], p[1], p[2]);
    }
  return out;
}

// The colour image of `cam` at `cam_from_world`: plane k is textured with photo k % photos.size().
inline Image RenderTextured(const SyntheticScene& sc, const Camera& cam, const Rigid3d& cam_from_world,
                            const std::vector<Image>& photos, double px_per_m = 160) {
  Image img(cam.width, cam.height);
  const Eigen::Matrix3d Rt = cam_from_world.R().transpose();
  const Eigen::Vector3d c = cam_from_world.Center();
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      Eigen::Vector3d acc = Eigen::Vector3d::Zero();
      for (int sub = 0; sub < 4; ++sub) {
        const double u = x - 0.25 + 0.5 * (sub % 2), v = y - 0.25 + 0.5 * (sub / 2);
        const Eigen::Vector3d d = Rt * cam.Unproject(u, v);
        int plane = -1;
        const double best = sc.FirstHit(c, d, &plane);
        if (plane < 0) continue;
        const Plane& p = sc.planes[static_cast<size_t>(plane)];
        const Eigen::Vector3d X = c + best * d;
        // Two in-plane axes: the world axes that the normal does not dominate.
        const Eigen::Vector3d a = std::abs(p.n.x()) > 0.5 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
        const Eigen::Vector3d b = p.n.cross(a).normalized();
        const Eigen::Vector3d a2 = b.cross(p.n).normalized();
        const Image& tex = photos[static_cast<size_t>(plane) % photos.size()];
        acc += SampleTexture(tex, px_per_m * X.dot(a2) + 37.0 * plane, px_per_m * X.dot(b) + 53.0 * plane);
      }
      for (int ch = 0; ch < 3; ++ch)
        img.data[3 * (static_cast<size_t>(y) * cam.width + x) + ch] =
            static_cast<uint8_t>(std::clamp(acc[ch] / 4.0 + 0.5, 0.0, 255.0));
    }
  return img;
}

inline void WriteDepthMm(const std::string& path, const DepthMap& d) {
  std::vector<uint16_t> mm(d.data.size());
  for (size_t i = 0; i < mm.size(); ++i)
    mm[i] = static_cast<uint16_t>(std::clamp(std::round(d.data[i] * 1000.0), 0.0, 65535.0));
  io::WritePng16(path, d.width, d.height, mm);
}

// The depth variants of a textured scene from the exact map of frame `frame` (each seeded by the scene seed and the
// frame, independently of the others): "degraded8" — ±8 % global scale (uniform), a ±5 % smooth field, 5 % holes;
// "mono" — monocular-like (DegradeDepthMonocular's defaults).
inline void WriteDepthVariants(const std::string& stem, const DepthMap& exact, uint32_t seed, int frame) {
  std::mt19937 rng(seed * 2654435761u + 977u * static_cast<uint32_t>(frame) + 1u);
  std::uniform_real_distribution<double> u01(0, 1);
  DepthMap d8 = DegradeDepth(exact, rng(), 0.0, 0.05, 0.0, 0.05);
  const float global = static_cast<float>(0.92 + 0.16 * u01(rng));
  for (float& v : d8.data) v *= global;
  WriteDepthMm(stem + ".degraded8.png", d8);
  WriteDepthMm(stem + ".mono.png", DegradeDepthMonocular(exact, rng()));
}

// How hard a scene's queries are: the default is the benchmark-like set bench/baseline reports on; `Hard()` gives
// wider baselines and rotations (less overlap, more plane-dominated views of one wall), blurrier texture and image
// noise — fewer, noisier matches, where twin models and weak support occur.
struct SceneDifficulty {
  double min_baseline_m = 0.2, max_baseline_m = 1.2;
  double max_rotation_rad = 0.15;  // uniform in ±this about a random axis
  double px_per_m = 160;           // texture density (lower: blurrier, fewer SIFT features)
  double noise_grey = 0;           // image noise, standard deviation in grey levels
  static SceneDifficulty Hard() { return {0.3, 2.2, 0.45, 70, 6}; }
};

inline void AddImageNoise(Image* img, double sigma, uint32_t seed) {
  if (sigma <= 0) return;
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, sigma);
  for (uint8_t& v : img->data) v = static_cast<uint8_t>(std::clamp(v + g(rng) + 0.5, 0.0, 255.0));
}

// One map-free scene folder `dir` (reference seq0/frame_00000.png, queries seq1/frame_{00000,00005,…}.png so every
// query is an evaluated key), depth suffixes "exact", "degraded", "degraded8" and "mono", GT poses, intrinsics.
inline void WriteTexturedScene(const std::string& dir, uint32_t seed, int queries, const std::vector<Image>& photos,
                               int width = 540, int height = 720, const SceneDifficulty& hard = {}) {
  namespace fs = std::filesystem;
  fs::create_directories(dir + "/seq0");
  fs::create_directories(dir + "/seq1");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  std::string intrinsics, poses;
  char line[256];
  auto add = [&](const std::string& name, const Camera& k, const Rigid3d& q_from_r) {
    std::snprintf(line, sizeof(line), "%s %.6f %.6f %.6f %.6f %d %d\n", name.c_str(), k.fx, k.fy, k.cx, k.cy, k.width,
                  k.height);
    intrinsics += line;
    const Eigen::Quaterniond& q = q_from_r.rotation;
    const Eigen::Vector3d& t = q_from_r.translation;
    std::snprintf(line, sizeof(line), "%s %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", name.c_str(), q.w(), q.x(), q.y(),
                  q.z(), t.x(), t.y(), t.z());
    poses += line;
  };
  // The room (and its box) are fixed by `seed`; each query is a fresh camera placement in it.
  const SyntheticScene base = MakeRoomScene(seed, 0.5, width, height);
  Image ref_img = RenderTextured(base, base.ref, Rigid3d(), photos, hard.px_per_m);
  AddImageNoise(&ref_img, hard.noise_grey, seed ^ 0x5bd1e995u);
  io::WriteImagePng(dir + "/seq0/frame_00000.png", ref_img);
  WriteDepthMm(dir + "/seq0/frame_00000.exact.png", base.depth_ref);
  WriteDepthMm(dir + "/seq0/frame_00000.degraded.png", DegradeDepth(base.depth_ref, rng(), 0.05, 0.05, 0.10, 0.05));
  WriteDepthVariants(dir + "/seq0/frame_00000", base.depth_ref, seed, -1);
  add("seq0/frame_00000.png", base.ref, Rigid3d());
  for (int i = 0; i < queries; ++i) {
    SyntheticScene sc = base;
    const double baseline = hard.min_baseline_m + (hard.max_baseline_m - hard.min_baseline_m) * u01(rng);
    const Eigen::Vector3d axis = Eigen::Vector3d(u01(rng) - 0.5, u01(rng) - 0.5, u01(rng) - 0.5).normalized();
    const Eigen::Quaterniond q(Eigen::AngleAxisd(2 * hard.max_rotation_rad * (u01(rng) - 0.5), axis));
    const Eigen::Vector3d centre =
        Eigen::Vector3d(u01(rng) - 0.5, 0.3 * (u01(rng) - 0.5), 0.5 * (u01(rng) - 0.5)).normalized() * baseline;
    sc.query_from_ref = Rigid3d(q, -(q * centre));
    char name[64];
    std::snprintf(name, sizeof(name), "seq1/frame_%05d", 5 * i);
    Image qimg = RenderTextured(sc, sc.query, sc.query_from_ref, photos, hard.px_per_m);
    AddImageNoise(&qimg, hard.noise_grey, seed * 31u + static_cast<uint32_t>(i));
    io::WriteImagePng(dir + "/" + name + ".png", qimg);
    const DepthMap d = sc.Render(sc.query, sc.query_from_ref);
    WriteDepthMm(dir + "/" + name + ".exact.png", d);
    WriteDepthMm(dir + "/" + name + ".degraded.png", DegradeDepth(d, rng(), 0.05, 0.05, 0.10, 0.05));
    WriteDepthVariants(dir + "/" + name, d, seed, i);
    add(std::string(name) + ".png", sc.query, sc.query_from_ref);
  }
  std::FILE* f = std::fopen((dir + "/intrinsics.txt").c_str(), "w");
  std::fputs(intrinsics.c_str(), f);
  std::fclose(f);
  f = std::fopen((dir + "/poses.txt").c_str(), "w");
  std::fputs(poses.c_str(), f);
  std::fclose(f);
}

}  // namespace freeloc::testing
