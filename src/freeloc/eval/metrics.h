// Map-free metrics exactly as the official evaluator computes them (docs/formats.md "Evaluation",
// nianticlabs/map-free-reloc benchmark/{mapfree,utils,metrics,reprojection}.py): translation error between camera
// centres, rotation error 2·asin‖vec(q_gt ⊗ q_est⁻¹)‖, VCRE on the 7×4×7 virtual grid with float32 intrinsics and
// clipping, precision and AUC with failures in the denominators, average of per-scene medians — with every quirk
// (frame keys by number, every 5th key of poses.txt, a missing scene file counting all its GT frames).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "freeloc/io/mapfree.h"
#include "freeloc/io/submission.h"

namespace freeloc::eval {

// Per-frame errors of one estimate against the ground truth (both already in the official camera-to-world form).
struct FrameErrors {
  double trans_err = 0, rot_err = 0, vcre = 0;
};
// K as the official loader keeps it (float32 values), W and H of the image.
FrameErrors ComputeFrameErrors(const io::OfficialPose& gt, const io::OfficialPose& est,
                               const std::array<float, 4>& fxfycxcy, double width, double height);

struct FrameRecord {
  std::string scene;
  int64_t frame = 0;  // the 5-digit key
  // "submitted" (the submission has a pose for it: solved, or freeloc's prior with confidence 0), "missing" (no
  // usable line), "scene-missing" (no pose file). Never "ok": the evaluator cannot tell a solved query.
  std::string status;
  FrameErrors err;
  double confidence = 0;
};

struct SceneRecord {
  std::string name;
  bool file_present = false;
  int64_t failures = 0;
  std::vector<FrameRecord> frames;   // evaluated frames with their status (scene-missing: every GT key)
  std::vector<std::string> dropped;  // lines of the pose file the parser dropped (the first 1000)
  size_t dropped_count = 0;          // all of them
  size_t estimates() const;
};

struct Metrics {
  double avg_median_trans = 0, avg_median_rot = 0, avg_median_vcre = 0;
  double precision_pose = 0, auc_pose = 0, precision_vcre = 0, auc_vcre = 0;
  double estimates_ratio = 0;
  int64_t estimates = 0, failures = 0;
  int scenes_with_estimates = 0;
};

// What counts as an accurate pose (precision and AUC): the benchmark's 25 cm / 5° and 90 px VCRE.
struct Thresholds {
  double translation_m = 0.25;
  double rotation_deg = 5.0;
  double vcre_px = 90.0;
};

// Aggregates scenes as aggregate_results() does. Throws when no scene has an estimate (the official evaluator
// prints no metrics then).
Metrics Aggregate(const std::vector<SceneRecord>& scenes, const Thresholds& th = {});

// The official AUC (precision_recall): confidences sorted descending, ties grouped, recall in float32.
double PrecisionRecallAuc(const std::vector<double>& confidence, const std::vector<bool>& accepted, int64_t failures);

struct EvalInput {
  std::string split_dir;            // folder holding the scene folders
  std::vector<std::string> scenes;  // scene names to evaluate
  std::string submission_path;      // for messages
  const io::ZipContents* submission = nullptr;
  // single-frame: every 5th key of poses.txt (the official evaluator); multi-frame: the seq1 frames at linear
  // positions 9, 19, … of the frames sorted by number (docs/pipeline.md "Multi Frame"), a missing scene counting
  // those frames only.
  io::Track track = io::Track::kSingleFrame;
};

// The keys a track scores, from the ground truth of one scene.
std::vector<int64_t> EvaluatedKeys(const io::OfficialPoses& gt, io::Track track);

// Evaluates one submission. Throws freeloc::Error (clear message) where the official evaluator prints nothing:
// missing GT files, unreadable intrinsics, non-UTF-8 pose files, negative confidence on an evaluated frame.
std::vector<SceneRecord> EvaluateScenes(const EvalInput& in);

// The official JSON key names, in the official order.
extern const char* const kMetricNames[8];
std::array<double, 8> MetricValues(const Metrics& m);

}  // namespace freeloc::eval
