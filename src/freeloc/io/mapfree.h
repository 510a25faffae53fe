// The Map-free Relocalization dataset layout (docs/formats.md "Map-free dataset"):
//   <root>/<split>/sNNNNN/{intrinsics.txt, poses.txt, seq0/frame_00000.jpg, seq1/frame_XXXXX.jpg, …}
// plus provided depth maps `frame_XXXXX.<suffix>.png` (uint16 mm, 0 invalid) and precomputed correspondences
// `correspondences_<name>.npz`. This is the reader the pipeline uses; the evaluator parses the GT files with the
// official evaluator's own rules (eval/).
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/enum_table.h"
#include "freeloc/core/image.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/io/track.h"

namespace freeloc::io {

struct MapfreeFrame {
  std::string name;  // as written in intrinsics.txt, e.g. "seq1/frame_00012.jpg"
  Camera camera;     // this frame's own K and image size
};

// The frames of an intrinsics file (`path fx fy cx cy width height` per line, `#` lines skipped), in file order.
// Throws freeloc::Error naming the file and line.
// `scene_frames`: the file is a scene's intrinsics.txt, whose frame names must be paths inside the scene
// (seq<N>/<file>; refused with the line number otherwise).
std::vector<MapfreeFrame> ReadIntrinsicsFile(const std::string& path, bool scene_frames = false);

struct MapfreeScene {
  std::string name;  // "s00460"
  std::string dir;
  MapfreeFrame reference;
  std::vector<MapfreeFrame> queries;  // poses.txt order (intrinsics.txt order when poses.txt is absent)
  // Ground truth query_from_ref per frame name; empty for test scenes (all-zero poses) or without poses.txt.
  std::map<std::string, Rigid3d> gt;

  bool has_gt() const { return !gt.empty(); }
  std::string FramePath(const MapfreeFrame& f) const { return dir + "/" + f.name; }
  // `frame_XXXXX.<suffix>.png` next to the frame's image.
  std::string DepthPath(const MapfreeFrame& f, const std::string& suffix) const;
  // `max_side` > 0: at that working resolution (image_io.h).
  Image LoadImage(const MapfreeFrame& f, int max_side = 0) const;
  // Provided depth as stored (integers read as mm / 1000, DepthStorage::kInteger), 0 = invalid. Throws naming the file
  // when absent or damaged; its unit and size are the pipeline's rule (inputs/input_checks.h).
  DepthMap LoadDepth(const MapfreeFrame& f, const std::string& suffix) const;
  // Precomputed correspondences (x_ref, y_ref, x_query, y_query) per query, rows in `queries` order, NaN padding
  // dropped. `name` is SIFT, SG, LoFTR or any other suffix of correspondences_<name>.npz.
  std::vector<std::vector<Eigen::Vector4d>> LoadCorrespondences(const std::string& name) const;
  // The Multi Frame track's device tracking poses (docs/pipeline.md "Multi Frame").
  std::string DevicePosesPath() const { return dir + "/poses_device.txt"; }

  // Reads intrinsics.txt and poses.txt of one scene folder. Throws freeloc::Error naming the file and line.
  static MapfreeScene Load(const std::string& dir);
};

// The folder holding the scenes: `<root>/<split>` or `root` itself when it is already the split folder.
std::string ResolveSplitDir(const std::string& root, const std::string& split);
// Scene folder names (sNNNNN…) in sorted order; `only` restricts to the listed names (error if one is absent).
std::vector<std::string> ListScenes(const std::string& split_dir, const std::vector<std::string>& only = {});

// The Multi Frame track (docs/pipeline.md "Multi Frame"): the frame number of "seq1/frame_00011.jpg" (11); -1 when
// the file name is not frame_<digits>.<ext>.
int64_t FrameNumber(const std::string& name);

// One evaluated frame of the Multi Frame track and the frames it may use: indices into MapfreeScene::queries.
struct QueryWindow {
  size_t evaluated = 0;
  std::vector<size_t> frames;  // oldest first, the evaluated frame last
};
// The scene's seq1 frames sorted by frame number; the evaluated frames at linear positions 9, 19, 29, …, each with
// the `frames` (1–9) frames ending at it. Frame numbers may skip: the position decides, not the number.
std::vector<QueryWindow> MultiFrameWindows(const MapfreeScene& scene, int frames = 9);

// poses_device.txt: one `seq1/frame_XXXXX.jpg qw qx qy qz tx ty tz` line per window frame, read in the documented
// convention as frame_from_query (x_frame = R·x_query + t). Tolerates a missing final newline, blank lines and
// signed zeros; throws freeloc::Error naming the file and line for anything else (a bad number, a non-unit
// quaternion, a frame named twice).
std::map<std::string, Rigid3d> ReadDevicePoses(const std::string& path);

// Provided-depth PNG I/O in the map-free convention (uint16 millimetres, 0 invalid); read maps are
// DepthStorage::kInteger with `source` set, so that the pipeline can apply another unit (`depth_unit`).
DepthMap ReadDepthPng(const std::string& path);
// The same from the PNG's bytes (an upload); `what` names it in errors.
DepthMap DecodeDepthPng(const std::vector<uint8_t>& bytes, const std::string& what);
void WriteDepthPng(const std::string& path, const DepthMap& depth);

}  // namespace freeloc::io
