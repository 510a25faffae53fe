#include "freeloc/io/mapfree.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/npz.h"
#include "freeloc/io/pyparse.h"

namespace freeloc::io {

namespace fs = std::filesystem;

namespace {

std::string ReadText(const std::string& path) {
  std::error_code ec;
  FREELOC_CHECK(fs::is_regular_file(path, ec),
                path << ": not a readable file; check that the scene folder is complete");
  // A scene's text files hold a line per frame (tens of kB for the largest scenes): one of more than 16 MB is not one
  // of them, and is refused before it is read (128 MB of newlines became 2 GB of lines).
  constexpr uintmax_t kMaxSceneText = 16u << 20;
  const uintmax_t size = fs::file_size(path, ec);
  FREELOC_CHECK(!ec && size <= kMaxSceneText,
                path << ": " << (ec ? std::string("cannot tell its size") : std::to_string(size) + " bytes")
                     << ", more than a scene's text file holds (16 MB at most); check the file");
  std::ifstream f(path, std::ios::binary);
  FREELOC_CHECK(f.good(), path << ": cannot read; check that the scene folder is complete");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

double Number(const std::string& s, const std::string& where) {
  double v;
  FREELOC_CHECK(py::ParseFloat(s, &v) && std::isfinite(v), where << ": '" << s << "' is not a finite number");
  return v;
}

}  // namespace

std::string MapfreeScene::DepthPath(const MapfreeFrame& f, const std::string& suffix) const {
  fs::path p = fs::path(dir) / f.name;
  return (p.parent_path() / (p.stem().string() + "." + suffix + ".png")).string();
}

Image MapfreeScene::LoadImage(const MapfreeFrame& f, int max_side) const {
  return ReadImage(FramePath(f), nullptr, max_side);
}

DepthMap MapfreeScene::LoadDepth(const MapfreeFrame& f, const std::string& suffix) const {
  const std::string path = DepthPath(f, suffix);
  std::error_code ec;
  FREELOC_CHECK(fs::exists(path, ec), path << ": provided depth '" << suffix << "' not found for " << f.name
                                           << " in scene " << name << "; check the depth suffix");
  // Its size against the photo's is the pipeline's rule (inputs/input_checks.h): resampled or refused there.
  return ReadDepthPng(path);
}

std::vector<std::vector<Eigen::Vector4d>> MapfreeScene::LoadCorrespondences(const std::string& cname) const {
  const std::string path = dir + "/correspondences_" + cname + ".npz";
  std::error_code ec;
  FREELOC_CHECK(fs::exists(path, ec), path << ": precomputed correspondences '" << cname << "' not found in scene "
                                           << name << " (expected correspondences_{SIFT,SG,LoFTR}.npz)");
  const auto arrays = ReadNpz(path);
  auto it = arrays.find("correspondences");
  FREELOC_CHECK(it != arrays.end(), path << ": has no array named 'correspondences'");
  const NpyArray& a = it->second;
  FREELOC_CHECK(a.shape.size() == 3 && a.shape[2] == 4,
                path << ": 'correspondences' must be [N_queries, max_pts, 4], got " << a.shape.size() << " dims");
  FREELOC_CHECK(a.shape[0] == static_cast<int64_t>(queries.size()),
                path << ": holds " << a.shape[0] << " query rows but the scene has " << queries.size() << " queries");
  std::vector<std::vector<Eigen::Vector4d>> out(static_cast<size_t>(a.shape[0]));
  const int64_t m = a.shape[1];
  for (int64_t q = 0; q < a.shape[0]; ++q) {
    for (int64_t k = 0; k < m; ++k) {
      const double* r = &a.data[static_cast<size_t>((q * m + k) * 4)];
      if (std::isnan(r[0]) || std::isnan(r[1]) || std::isnan(r[2]) || std::isnan(r[3])) continue;
      out[q].emplace_back(r[0], r[1], r[2], r[3]);
    }
  }
  return out;
}

// A frame name must be a relative path inside its scene: seq<N>/<file>, no "..", ".", empty or absolute parts, no
// backslashes or control characters — a name like "../s00002/seq1/frame_00000.jpg" would read another scene's
// files and be written into the submission.
void CheckFrameName(const std::string& name, const std::string& where) {
  bool ok = name.size() > 5 && name.compare(0, 3, "seq") == 0 && name.find('\\') == std::string::npos;
  size_t k = 3;
  while (ok && k < name.size() && std::isdigit(static_cast<unsigned char>(name[k]))) ++k;
  ok = ok && k > 3 && k < name.size() && name[k] == '/';
  for (size_t start = k + 1; ok && start <= name.size();) {
    size_t end = name.find('/', start);
    if (end == std::string::npos) end = name.size();
    const std::string part = name.substr(start, end - start);
    ok = !part.empty() && part != "." && part != "..";
    start = end + 1;
  }
  for (char c : name) ok = ok && static_cast<unsigned char>(c) >= 0x20;
  FREELOC_CHECK(ok, where << ": frame name '" << SafeText(name, 200) << "' is not a path inside the scene; frame names "
                          << "are relative, like seq0/frame_00000.jpg (seq<N>/ then the file, no '..' or absolute "
                          << "paths)");
}

std::vector<MapfreeFrame> ReadIntrinsicsFile(const std::string& ipath, bool scene_frames) {
  std::vector<MapfreeFrame> out;
  std::map<std::string, size_t> seen;  // frame → its line
  const auto lines = py::SplitLines(ReadText(ipath));
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string where = ipath + " line " + std::to_string(i + 1);
    if (lines[i].find('#') != std::string::npos || py::Strip(lines[i]).empty()) continue;
    const auto parts = py::SplitSpace(py::Strip(lines[i]));
    FREELOC_CHECK(parts.size() == 7,
                  where << ": expected 7 fields 'path fx fy cx cy width height', got " << parts.size());
    MapfreeFrame f;
    f.name = parts[0];
    if (scene_frames) CheckFrameName(f.name, where);
    f.camera.fx = Number(parts[1], where);
    f.camera.fy = Number(parts[2], where);
    f.camera.cx = Number(parts[3], where);
    f.camera.cy = Number(parts[4], where);
    const double w = Number(parts[5], where), h = Number(parts[6], where);
    FREELOC_CHECK(w >= 1 && h >= 1 && w <= 1e6 && h <= 1e6 && w == std::floor(w) && h == std::floor(h),
                  where << ": width and height must be whole numbers of pixels in [1, 10^6], got " << parts[5] << " "
                        << parts[6]);
    f.camera.width = static_cast<int>(w);
    f.camera.height = static_cast<int>(h);
    f.camera.Validate(where);
    const auto [it, fresh] = seen.emplace(f.name, i + 1);
    FREELOC_CHECK(fresh, where << ": frame " << SafeText(f.name) << " is already listed on line " << it->second
                               << "; each frame needs exactly one intrinsics line");
    out.push_back(f);
  }
  return out;
}

MapfreeScene MapfreeScene::Load(const std::string& dir) {
  MapfreeScene s;
  s.dir = dir;
  s.name = fs::path(dir).filename().string();
  if (s.name.empty()) s.name = fs::path(dir).parent_path().filename().string();
  const std::string ipath = dir + "/intrinsics.txt";
  std::error_code ec;
  FREELOC_CHECK(fs::is_directory(dir, ec), dir << ": scene folder not found");
  FREELOC_CHECK(fs::exists(ipath, ec), ipath << ": missing; every scene needs intrinsics.txt (path fx fy cx cy W H)");
  std::map<std::string, MapfreeFrame> frames;
  std::vector<std::string> order;
  for (const MapfreeFrame& f : ReadIntrinsicsFile(ipath, /*scene_frames=*/true)) {
    if (!frames.count(f.name)) order.push_back(f.name);
    frames[f.name] = f;
  }
  bool have_ref = false;
  for (const auto& n : order) {
    if (n.rfind("seq0/", 0) == 0) {
      FREELOC_CHECK(!have_ref, ipath << ": more than one reference frame (seq0/…); a map-free scene has exactly one");
      s.reference = frames[n];
      have_ref = true;
    }
  }
  FREELOC_CHECK(have_ref, ipath << ": no reference frame (a line for seq0/frame_00000.*)");

  // Ground truth and query order from poses.txt when present.
  const std::string ppath = dir + "/poses.txt";
  std::vector<std::string> query_order;
  bool all_zero = true;
  std::map<std::string, Rigid3d> gt;
  if (fs::exists(ppath, ec)) {
    const auto plines = py::SplitLines(ReadText(ppath));
    for (size_t i = 0; i < plines.size(); ++i) {
      const std::string where = ppath + " line " + std::to_string(i + 1);
      const auto parts = py::SplitSpace(py::Strip(plines[i]));
      if (parts.empty() || parts[0].find('#') != std::string::npos || py::Strip(plines[i]).empty()) continue;
      FREELOC_CHECK(parts.size() == 8,
                    where << ": expected 8 fields 'path qw qx qy qz tx ty tz', got " << parts.size());
      double v[7];
      for (int k = 0; k < 7; ++k) {
        FREELOC_CHECK(py::ParseFloat(parts[k + 1], &v[k]) && std::isfinite(v[k]),
                      where << ": '" << parts[k + 1] << "' is not a finite number; fix or remove the line");
        if (v[k] != 0) all_zero = false;
      }
      const std::string& n = parts[0];
      CheckFrameName(n, where);
      FREELOC_CHECK(frames.count(n), where << ": frame " << SafeText(n, 200) << " is not listed in intrinsics.txt");
      if (n.rfind("seq1/", 0) == 0 && std::find(query_order.begin(), query_order.end(), n) == query_order.end())
        query_order.push_back(n);
      const double qn = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
      if (qn > 1e-8) gt[n] = Rigid3d::FromWxyz({v[0], v[1], v[2], v[3]}, Eigen::Vector3d(v[4], v[5], v[6]));
    }
  }
  if (!all_zero) s.gt = std::move(gt);
  if (query_order.empty()) {
    for (const auto& n : order)
      if (n.rfind("seq0/", 0) != 0) query_order.push_back(n);
  }
  for (const auto& n : query_order) s.queries.push_back(frames[n]);
  return s;
}

int64_t FrameNumber(const std::string& name) {
  const std::string file = fs::path(name).filename().string();
  if (file.compare(0, 6, "frame_") != 0) return -1;
  size_t k = 6;
  int64_t v = 0;
  while (k < file.size() && std::isdigit(static_cast<unsigned char>(file[k])) && k < 6 + 15)
    v = 10 * v + (file[k++] - '0');
  if (k == 6 || k >= file.size() || file[k] != '.') return -1;
  return v;
}

std::vector<QueryWindow> MultiFrameWindows(const MapfreeScene& scene, int frames) {
  FREELOC_CHECK(frames >= 1 && frames <= 9, "frames: " << frames << " is not in 1..9 (the window holds 9 frames)");
  std::vector<size_t> order;
  for (size_t i = 0; i < scene.queries.size(); ++i) {
    FREELOC_CHECK(FrameNumber(scene.queries[i].name) >= 0,
                  scene.dir << ": query '" << SafeText(scene.queries[i].name, 200)
                            << "' is not named frame_<number>.<ext>; the Multi Frame track orders frames by number");
    order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return FrameNumber(scene.queries[a].name) < FrameNumber(scene.queries[b].name);
  });
  std::vector<QueryWindow> out;
  for (size_t pos = 9; pos < order.size(); pos += 10) {
    QueryWindow w;
    w.evaluated = order[pos];
    for (size_t k = pos + 1 - static_cast<size_t>(frames); k <= pos; ++k) w.frames.push_back(order[k]);
    out.push_back(std::move(w));
  }
  return out;
}

std::map<std::string, Rigid3d> ReadDevicePoses(const std::string& path) {
  std::map<std::string, Rigid3d> out;
  const auto lines = py::SplitLines(ReadText(path));
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string where = path + " line " + std::to_string(i + 1);
    const std::string text = py::Strip(lines[i]);
    if (text.empty()) continue;
    const auto parts = py::SplitSpace(text);
    FREELOC_CHECK(parts.size() == 8, where << ": expected 8 fields 'path qw qx qy qz tx ty tz', got " << parts.size());
    CheckFrameName(parts[0], where);
    double v[7];
    for (int k = 0; k < 7; ++k)
      FREELOC_CHECK(py::ParseFloat(parts[k + 1], &v[k]) && std::isfinite(v[k]),
                    where << ": '" << SafeText(parts[k + 1], 40) << "' is not a finite number");
    const double qn = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
    FREELOC_CHECK(std::abs(qn - 1) < 1e-3, where << ": the quaternion has norm " << qn << ", not 1");
    // A phone's tracker between frames of one window: centimetres to metres. A kilometre is garbage, not a motion.
    FREELOC_CHECK(std::abs(v[4]) <= 1000 && std::abs(v[5]) <= 1000 && std::abs(v[6]) <= 1000,
                  where << ": a translation of " << v[4] << ", " << v[5] << ", " << v[6]
                        << " m between two frames of a window; a tracking pose moves metres at most");
    FREELOC_CHECK(!out.count(parts[0]), where << ": frame " << SafeText(parts[0], 200) << " is listed twice");
    out[parts[0]] = Rigid3d::FromWxyz({v[0], v[1], v[2], v[3]}, Eigen::Vector3d(v[4], v[5], v[6]));
  }
  return out;
}

std::string ResolveSplitDir(const std::string& root, const std::string& split) {
  std::error_code ec;
  FREELOC_CHECK(fs::is_directory(root, ec), root << ": dataset folder not found; give the map-free root "
                                                 << "(holding train/ val/ test/) or a split folder");
  const fs::path with_split = fs::path(root) / split;
  if (fs::is_directory(with_split, ec)) return with_split.string();
  // `root` may already be the split folder: it then holds scene folders directly.
  for (const auto& e : fs::directory_iterator(root, ec)) {
    if (e.is_directory() && fs::exists(e.path() / "intrinsics.txt")) return root;
  }
  FREELOC_THROW(root << ": has no '" << split << "' folder and no scene folders; give the dataset root or "
                     << "the split folder");
}

std::vector<std::string> ListScenes(const std::string& split_dir, const std::vector<std::string>& only) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(split_dir, ec))
    if (e.is_directory()) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  if (only.empty()) return names;
  for (const auto& n : only) {
    FREELOC_CHECK(std::binary_search(names.begin(), names.end(), n),
                  split_dir << ": scene '" << n << "' is not in this split");
  }
  std::vector<std::string> out = only;
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

DepthMap ReadDepthPng(const std::string& path) { return DecodeDepthPng(ReadFileBytes(path), path); }

DepthMap DecodeDepthPng(const std::vector<uint8_t>& bytes, const std::string& path) {
  int w, h, bits = 0;
  const std::vector<uint16_t> mm = DecodePng16(bytes, path, &w, &h, &bits);
  FREELOC_CHECK(bits == 16, path << ": an 8-bit PNG is not a depth map; depth maps are 16-bit PNGs in millimetres "
                                    "(the map-free convention)");
  DepthMap d(w, h);
  for (size_t i = 0; i < mm.size(); ++i) d.data[i] = mm[i] / 1000.0f;
  d.storage = DepthStorage::kInteger;
  d.source = path;
  return d;
}

void WriteDepthPng(const std::string& path, const DepthMap& depth) {
  std::vector<uint16_t> mm(depth.data.size());
  for (size_t i = 0; i < mm.size(); ++i) {
    const float v = depth.data[i];
    mm[i] = (v > 0 && std::isfinite(v)) ? static_cast<uint16_t>(std::min(65535.0f, std::round(v * 1000.0f))) : 0;
  }
  WritePng16(path, depth.width, depth.height, mm);
}

}  // namespace freeloc::io
