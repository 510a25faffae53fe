// Metric3D v2 input preparation (YvanYin/Metric3D hubconf.py __main__): keep-aspect resize into the canonical
// input (H, W) with OpenCV INTER_LINEAR, centred padding with the mean colour (which OpenCV saturates to
// (124, 116, 104) on uint8), (x − mean)/std in float32. The intrinsics are scaled by the same factor; only fx·s
// matters (the network output is de-canonicalised by fx·s/1000).
#pragma once

#include <array>
#include <vector>

#include "freeloc/core/image.h"

namespace freeloc::vision {

struct Metric3dInput {
  int height = 0, width = 0;              // network input H, W
  double scale = 0;                       // s = min(H/h, W/w)
  int resized_h = 0, resized_w = 0;       // (int(h·s), int(w·s))
  std::array<int, 4> pad = {0, 0, 0, 0};  // top, bottom, left, right
  Image resized, padded;
  std::vector<float> input;  // [3, H, W]
};

Metric3dInput PrepareMetric3dInput(const Image& image, int input_h, int input_w);

}  // namespace freeloc::vision
