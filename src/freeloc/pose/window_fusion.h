// The Map-free Multi Frame track's fusion (docs/pipeline.md "Multi Frame"; the track: an evaluated query frame with
// the 8 frames before it and the phone's tracking poses of those frames, fused into one pose).
//
// Each frame of the window was relocalized against the reference as a single query would be, and tied to the
// evaluated frame by a rigid relation — from the images (the evaluated frame as a local reference: matches and both
// depth maps make it metric) or from the device poses where they agree with the images — which turns every frame's
// answer into a vote for the evaluated frame's pose. FuseWindow runs four named steps:
//   evidence   which relation ties each frame (the device poses trusted, checked or refused) and its vote;
//   shape      the rotation: a robust average of the votes (medoid, then the mean of the votes near it);
//   scale      the distance: every length the window measures is a depth map's — good maps leave the evaluated
//              frame's own answer; maps that scatter are taken all at once (geometry/window_scale.h: each map's error
//              shared by what it anchors); a tracker's metric baseline is an independent second source, fused in log
//              space by the uncertainties;
//   decision   the direction (the reference camera's centre seen along the rays), the confidence from the agreement
//              that remains, and whether the fused pose replaces the evaluated frame's own: with good maps only where
//              it moves it beyond twice its predicted error (the window shows it wrong).
// Frames whose rotation or ray disagrees are left out. Pure geometry: tests drive it with synthetic evidence.
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/rigid3d.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/pose/device_pose_use.h"
#include "freeloc/pose/pose_estimate.h"

namespace freeloc::pose {

// What each frame of an evaluated frame's window contributed.
struct WindowVote {
  std::string frame;               // e.g. "seq1/frame_00011.jpg"
  Status status = Status::kError;  // its own relocalization against the reference
  std::string relation = "none";   // how it is tied to the evaluated frame: self | device | images | none
  bool used = false;               // its rotation and its ray entered the fused pose
  double rotation_dev_deg = -1;    // its rotation vote's distance from the fused rotation (-1: no vote)
  double distance_m = 0;           // its depth-based distance to the reference camera (0: none)
};
struct WindowSummary {
  int frames = 0, used = 0;
  // The device poses' fate in this window: used | ignored (<why>) | absent | off
  std::string device;
  std::string scale;  // where the metric distance came from: depth | tracker | images | depth+tracker | depth+images
  double depth_distance_m = 0, rig_distance_m = 0;  // the depth maps' and the rig's triangulated distance (0: none)
  std::vector<WindowVote> votes;                    // oldest first, the evaluated frame last
  bool empty() const { return frames == 0; }
};

// What the fusion gets per frame (the evaluated frame last).
struct FrameEvidence {
  std::string name;
  PoseEstimate to_ref;              // the frame against the reference
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

// The evaluated frame's estimate after its window voted (its own to_ref when nothing else is usable; window_fused
// when the fusion made it), with the window's account.
struct FusedWindow : PoseEstimate {
  WindowSummary window;
};

FusedWindow FuseWindow(const std::vector<FrameEvidence>& frames, DevicePoseUse use);

}  // namespace freeloc::pose
