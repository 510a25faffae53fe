// The Map-free Multi Frame track (docs/pipeline.md "Multi Frame"): an evaluated query frame with the 8 frames before
// it and the phone's tracking poses of those frames, fused into one pose. This file wires it: each frame of the
// window through the Relocalizer against the reference, the relations that tie the frames to the evaluated frame
// (the evaluated frame as a local reference), then the fusion — pose/window_fusion.h, where the rules live.
#pragma once

#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/image.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/query_result.h"
#include "freeloc/pipeline/stages.h"
#include "freeloc/pose/window_fusion.h"

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

// Relocalizes `frames` (oldest first, the evaluated frame last; 1–9 of them) against `reloc`'s reference and fuses
// them. One frame: exactly the single-frame answer. A frame that fails (a bad file) only loses its vote; the
// evaluated frame's error is the result when no other frame answers. `matches` (optional) receives the evaluated
// frame's correspondences against the reference.
QueryResult RelocalizeWindow(Relocalizer& reloc, std::vector<WindowFrame> frames,
                             matching::Correspondences* matches = nullptr);

}  // namespace freeloc::pipeline
