// Map-free submissions (docs/formats.md "Submissions"): a ZIP with one `pose_sNNNNN.txt` per scene at its root, lines
// `seq1/frame_XXXXX.jpg qw qx qy qz tx ty tz confidence` (query_from_ref, w-first unit quaternion, metres).
//   * Writer: exact official format, shortest round-trip numbers, deterministic bytes (sorted entries, fixed
//     timestamps and attributes), atomic (temporary file in the same folder, then rename).
//   * Reader: the official evaluator's parsing rules (benchmark/utils.py load_poses), which also read poses.txt.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "freeloc/core/rigid3d.h"

namespace freeloc::io {

struct SubmissionEntry {
  std::string frame;  // "seq1/frame_00012.jpg"
  Rigid3d query_from_ref;
  double confidence = 0;
};

// Shortest decimal text that reads back to the same double (Python repr style).
std::string FormatDouble(double v);
// One line (no newline): "seq1/frame_00012.jpg qw qx qy qz tx ty tz confidence".
std::string FormatPoseLine(const SubmissionEntry& e);
// A whole pose file, one line per entry in the given order, '\n' terminated.
std::string FormatPoseFile(const std::vector<SubmissionEntry>& entries);

// Writes `files` (entry name → content) as a deterministic ZIP, atomically.
void WriteZipAtomic(const std::string& path, const std::map<std::string, std::string>& files);
// Writes a submission: scene name → its entries. Entry names are `pose_<scene>.txt`.
void WriteSubmission(const std::string& path, const std::map<std::string, std::vector<SubmissionEntry>>& scenes);
// Joins submissions of disjoint scene sets (the shards of one run) into `out`, atomically; returns the number of
// scenes. Throws naming the input when an entry is not a pose_<scene>.txt or a scene repeats. The result is
// byte-identical to the submission of the whole run.
size_t MergeSubmissions(const std::vector<std::string>& inputs, const std::string& out);

// A ZIP read into memory (name → bytes), in archive order. Throws naming the file when it is not a ZIP.
struct ZipContents {
  std::vector<std::string> names;
  std::map<std::string, std::string> files;
  static ZipContents Read(const std::string& path);
};

// One pose as the official loader keeps it: the file's world-to-camera pose converted to camera-to-world with
// transforms3d 0.4 semantics (qinv = conj(q)/|q|, c = −rotate(t, qinv)).
struct OfficialPose {
  std::array<double, 4> q_c2w;  // w-first
  Eigen::Vector3d t_c2w;        // camera centre in the reference frame
  double confidence = 0;        // only with confidences
  std::string name;             // the line's first field
};

// load_poses(): an insertion-ordered dict keyed by int(name[-9:-4]); duplicate keys keep their first position and
// take the last line's value. Dropped lines are counted, with a reason each, not errors.
struct OfficialPoses {
  std::vector<int64_t> keys;  // first-insertion order
  std::map<int64_t, OfficialPose> poses;
  std::vector<std::string> dropped;  // "line N: reason" (the first 1000)
  size_t dropped_count = 0;          // all dropped lines
  size_t size() const { return keys.size(); }
};
OfficialPoses ParseOfficialPoses(const std::string& text, bool with_confidence);

}  // namespace freeloc::io
