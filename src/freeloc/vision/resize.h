// Pillow-compatible image resampling (Pillow 9.x `Image.resize`, libImaging/Resample.c semantics): separable,
// horizontal pass first, fixed-point coefficients with 22 fractional bits, a uint8 intermediate. Bit-exact with
// Pillow for BICUBIC and LANCZOS (naver/dust3r), and BILINEAR.
#pragma once

#include "freeloc/core/image.h"

namespace freeloc::vision {

enum class ResampleFilter { kBilinear, kBicubic, kLanczos };

// Resizes an RGB8 image to (out_width, out_height) exactly as PIL.Image.resize(size, filter) does.
Image PillowResize(const Image& in, int out_width, int out_height, ResampleFilter filter);

// Same for a single-channel uint8 plane (masks), row-major.
std::vector<uint8_t> PillowResizePlane(const std::vector<uint8_t>& in, int width, int height, int out_width,
                                       int out_height, ResampleFilter filter);

// Pillow's NEAREST resize (Image.resize(size, NEAREST)): the source index comes from an accumulating double,
// pos = 0.5·in/out, idx = (int)pos, pos += in/out — which differs from floor((o + 0.5)·in/out) where that value is an
// integer. `channels` interleaved uint8 channels.
std::vector<uint8_t> PillowResizeNearest(const uint8_t* in, int width, int height, int channels, int out_width,
                                         int out_height);

// torch's legacy `nearest` (F.interpolate(mode='nearest')): src = min(floor(dst · (float)in/out), in − 1), float32
// arithmetic as LibTorch's CPU kernel. Works on any element type through the index maps.
std::vector<int> TorchNearestIndices(int in_size, int out_size);

}  // namespace freeloc::vision
