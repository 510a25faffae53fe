// DUSt3R's `load_images` policy (dust3r/utils/image.py, naver/dust3r): long side to `size` (or short side
// to ≈224 in 224 mode), Python round-half-even sizes, LANCZOS when shrinking else BICUBIC (Pillow-exact), centre
// crop to multiples of 16 (square images to 3/4 height unless square_ok; a centred square in 224 mode), and
// normalisation (u8/255 − 0.5)/0.5 in float32. Also records how to map network pixels back to the original image.
#pragma once

#include <vector>

#include "freeloc/core/image.h"

namespace freeloc::vision {

struct Dust3rPreprocessOptions {
  int size = 512;          // 224, or any value whose crop is a multiple of the patch size
  bool square_ok = false;  // keep square images square (load_images' square_ok)
  int patch_size = 16;
  void Validate() const;
};

struct Dust3rInput {
  Image image;  // the network's input (cropped), H×W RGB8
  int orig_width = 0, orig_height = 0;
  int resized_width = 0, resized_height = 0;
  int crop_x = 0, crop_y = 0;     // top-left of the crop, in resized pixels
  std::vector<float> normalized;  // 3×H×W (CHW), (u8/255 − 0.5)/0.5

  int width() const { return image.width; }
  int height() const { return image.height; }
  // Network pixel → original pixel (pixel-centre convention, docs/architecture.md §2).
  void ToOriginal(double x_net, double y_net, double* x_orig, double* y_orig) const;
  // Original pixel → network pixel (inverse of ToOriginal).
  void ToNetwork(double x_orig, double y_orig, double* x_net, double* y_net) const;
};

// The resized size load_images picks for an image of (width, height) ("_resize_pil_image").
void Dust3rResizedSize(int width, int height, const Dust3rPreprocessOptions& options, int* out_width, int* out_height,
                       bool* lanczos);

Dust3rInput PreprocessForDust3r(const Image& image, const Dust3rPreprocessOptions& options = {});

// (u8/255 − 0.5)/0.5 in float32, HWC → CHW.
std::vector<float> NormalizeToCHW(const Image& image);

}  // namespace freeloc::vision
