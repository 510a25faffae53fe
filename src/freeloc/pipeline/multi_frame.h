// The Map-free Multi Frame track (spec/mapfree-multiframe.md, docs/pipeline.md "Multi Frame"): an evaluated query
// frame with the 8 frames before it and the phone's tracking poses of those frames, fused into one pose.
//
// Each frame of the window is relocalized against the reference as a single query would be. The frames are tied to
// the evaluated frame by a rigid relation — from the images (the evaluated frame as a local reference: matches and
// both depth maps make it metric) or from the device poses where they agree with the images — which turns every
// frame's answer into a vote for the evaluated frame's pose:
//   rotation   a robust average of the votes (medoid, then the mean of the votes near it);
//   direction  the reference camera's centre seen along nine rays from nine known places;
//   distance   every length the window measures is a depth map's: good maps leave the evaluated frame's own answer;
//              maps that scatter are taken all at once (geometry/window_scale.h: each map's error shared by what it
//              anchors, so ten independent maps beat the one reference map every answer leans on); a tracker's
//              metric baseline is an independent second source, fused in log space by the uncertainties.
// With good maps the fused pose replaces the evaluated frame's own only where it moves it beyond twice its predicted
// error (the window shows it wrong).
// Frames whose rotation or ray disagrees are left out; the confidence comes from the agreement that remains.
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/image.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/query_result.h"
#include "freeloc/pipeline/stages.h"

namespace freeloc::pipeline {

class Relocalizer;

// One frame of a window, oldest first; the evaluated frame last.
struct WindowFrame {
  std::string name;  // e.g. "seq1/frame_00011.jpg"
  Image image;
  Camera camera;
  FrameInputs inputs;
  bool has_device = false;
  Rigid3d device_from_query;  // the tracker's frame_from_query (the documented convention of poses_device.txt)
};

// What the fusion gets per frame (the evaluated frame last).
struct FrameEvidence {
  std::string name;
  QueryResult to_ref;               // the frame against the reference
  bool has_image_relation = false;  // the frame against the evaluated frame, from the images
  bool image_relation_metric = false;
  Rigid3d image_relation;                                                        // frame_from_query
  double image_relation_rot_sigma_deg = 0, image_relation_position_sigma_m = 0;  // its predicted errors
  bool has_device = false;
  Rigid3d device;                  // frame_from_query by the tracker
  geometry::ScaleAnchors anchors;  // metric to_ref: its |t| as each depth map alone anchors it
  // The image relation's length as the evaluated frame's map ("ref") and this frame's map ("query") alone anchor it.
  geometry::ScaleAnchors relation_anchors;
};

// Fuses a window's evidence into the evaluated frame's result (its own to_ref when nothing else is usable). Pure
// geometry: tests drive it with synthetic evidence.
QueryResult FuseWindow(const std::vector<FrameEvidence>& frames, DevicePoseUse use);

// Relocalizes `frames` (oldest first, the evaluated frame last; 1–9 of them) against `reloc`'s reference and fuses
// them. One frame: exactly the single-frame answer. A frame that fails (a bad file) only loses its vote; the
// evaluated frame's error is the result when no other frame answers. `matches` (optional) receives the evaluated
// frame's correspondences against the reference.
QueryResult RelocalizeWindow(Relocalizer& reloc, std::vector<WindowFrame> frames,
                             matching::Correspondences* matches = nullptr);

}  // namespace freeloc::pipeline
