// Plausible inputs (docs/formats.md "Plausible inputs"): one rule, for every entry point (CLI, Python, the service,
// `run`), that a well-formed depth map or set of intrinsics means what freeloc takes it to mean. A file that means
// something else — depth in metres or centimetres where millimetres are read, a transposed depth map, normalised or
// reordered intrinsics — is refused with a message naming the input, what it looks like and the option that fixes
// it; a depth map of the photo's aspect ratio at another resolution (a phone's 256×192) is resampled. What an answer
// took on a loosened bound or a resampled map is noted with it and lowers its confidence (InputNotes).
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/correspondences.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/inputs/input_options.h"
#include "freeloc/pose/pose_estimate.h"

namespace freeloc::inputs {

// What the checks did to a frame's inputs, carried to the query's answer: one line each ("query depth: resampled
// from 256x192 to 640x480"), and the factor its confidence is multiplied by (1: nothing).
struct InputNotes {
  std::vector<std::string> notes;
  double confidence_factor = 1;
  void Add(const std::string& note, double factor) {
    notes.push_back(note);
    confidence_factor *= factor;
  }
  void Append(const InputNotes& other) {
    notes.insert(notes.end(), other.notes.begin(), other.notes.end());
    confidence_factor *= other.confidence_factor;
  }
};

// The confidence factors: a depth map resampled from another resolution, an input accepted only by a bound loosened
// from its default.
inline constexpr double kResampledDepthFactor = 0.8;
inline constexpr double kLoosenedBoundFactor = 0.5;

// Integer maps (DepthStorage::kInteger, read as millimetres) in `unit` → metres; float maps are left as they are.
void ApplyDepthUnit(DepthUnit unit, DepthMap* depth);

// The provided-depth rule for a frame whose photo is `photo_width` × `photo_height` (0 × 0: unknown — `freeloc pose`)
// and is worked on at `work_width` × `work_height` (working_frame.h; the photo's size when not reduced): the unit
// applied; a map of the photo's aspect ratio (within 1 %) resampled to the working size (bilinear where the four
// neighbours are valid and agree within 10 %, else the nearest pixel) — noted when its size is not the photo's;
// another aspect ratio refused; the valid depths' median within [depth_median_min_m, depth_median_max_m]. `frame`
// names it in messages ("query depth"), with the map's source. Throws freeloc::Error; an empty map is returned as is.
DepthMap CheckProvidedDepth(DepthMap depth, int photo_width, int photo_height, int work_width, int work_height,
                            const InputOptions& o, const std::string& frame, InputNotes* notes);

// Intrinsics handed in (flags, a file, Python, the service) against an image of `width` × `height` (0 × 0: unknown —
// only finiteness and sign): focal lengths within [focal_min, focal_max] image long sides, fx/fy within
// focal_aspect_max, the principal point inside the image (widened by principal_point_margin). A failure names the
// likely mistake (normalised, cx,cy,fx,fy or fx,cx,fy,cy order, another image size or orientation) with the values
// that fix it. Throws freeloc::Error naming `what`.
void CheckIntrinsics(const Camera& camera, int width, int height, const InputOptions& o, const std::string& what,
                     InputNotes* notes);

// Two provided depth maps must agree with each other through the answer: at its inliers the query map's depths
// against those the reference map and the pose predict. A median ratio beyond 1.5 (either way) — one map in another
// unit, or a map of another photo — turns an ok or weak answer into scale-no-consensus with a message naming both
// maps. Needs at least 10 inliers with depth in both; `r` carries the pose and inlier mask of `c`.
void CheckDepthAgreement(const Correspondences& c, const Camera& k_ref, const Camera& k_query, const DepthMap& d_ref,
                         const DepthMap& d_query, pose::PoseEstimate* r);
inline constexpr double kDepthAgreementRatio = 1.5;

}  // namespace freeloc::inputs
