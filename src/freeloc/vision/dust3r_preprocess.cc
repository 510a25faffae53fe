#include "freeloc/vision/dust3r_preprocess.h"

#include <algorithm>
#include <cfenv>
#include <cmath>

#include "freeloc/core/error.h"
#include "freeloc/vision/resize.h"

namespace freeloc::vision {

namespace {
// Python's round() on a double: round half to even.
int PyRound(double v) {
  const double r = std::nearbyint(v);  // default rounding mode is to-nearest-even
  return static_cast<int>(r);
}
}  // namespace

void Dust3rPreprocessOptions::Validate() const {
  FREELOC_CHECK(patch_size > 0, "DUSt3R preprocessing: patch size must be positive");
  FREELOC_CHECK(size == 224 || (size >= patch_size && size % patch_size == 0),
                "DUSt3R preprocessing: size " << size << " is not supported; use 224 or a multiple of " << patch_size
                                              << " (512 for the released model)");
}

void Dust3rResizedSize(int w, int h, const Dust3rPreprocessOptions& o, int* out_w, int* out_h, bool* lanczos) {
  int long_edge = o.size;
  if (o.size == 224) {
    const double ratio = std::max(static_cast<double>(w) / h, static_cast<double>(h) / w);
    long_edge = PyRound(224 * ratio);
  }
  const int s = std::max(w, h);
  *lanczos = s > long_edge;
  *out_w = PyRound(static_cast<double>(w) * long_edge / s);
  *out_h = PyRound(static_cast<double>(h) * long_edge / s);
}

std::vector<float> NormalizeToCHW(const Image& image) {
  const size_t hw = image.num_pixels();
  std::vector<float> out(3 * hw);
  for (size_t p = 0; p < hw; ++p) {
    for (int c = 0; c < 3; ++c) {
      const float v = static_cast<float>(image.data[p * 3 + c]) / 255.0f;
      out[c * hw + p] = (v - 0.5f) / 0.5f;
    }
  }
  return out;
}

Dust3rInput PreprocessForDust3r(const Image& image, const Dust3rPreprocessOptions& o) {
  o.Validate();
  FREELOC_CHECK(!image.empty(), "DUSt3R preprocessing: empty image");
  Dust3rInput r;
  r.orig_width = image.width;
  r.orig_height = image.height;
  int rw, rh;
  bool lanczos;
  Dust3rResizedSize(image.width, image.height, o, &rw, &rh, &lanczos);
  FREELOC_CHECK(rw > 0 && rh > 0, "DUSt3R preprocessing: image " << image.width << "x" << image.height
                                                                 << " is too elongated for size " << o.size);
  const Image resized =
      (rw == image.width && rh == image.height)
          ? image
          : PillowResize(image, rw, rh, lanczos ? ResampleFilter::kLanczos : ResampleFilter::kBicubic);
  r.resized_width = rw;
  r.resized_height = rh;
  const int cx = rw / 2, cy = rh / 2;
  int left, top, right, bottom;
  if (o.size == 224) {
    const int half = std::min(cx, cy);
    left = cx - half;
    top = cy - half;
    right = cx + half;
    bottom = cy + half;
  } else {
    const int p = o.patch_size;
    const double halfw = static_cast<double>(((2 * cx) / p) * p) / 2;
    double halfh = static_cast<double>(((2 * cy) / p) * p) / 2;
    if (!o.square_ok && rw == rh) halfh = 3.0 * halfw / 4.0;
    left = PyRound(cx - halfw);
    top = PyRound(cy - halfh);
    right = PyRound(cx + halfw);
    bottom = PyRound(cy + halfh);
  }
  FREELOC_CHECK(right > left && bottom > top, "DUSt3R preprocessing: image "
                                                  << image.width << "x" << image.height
                                                  << " leaves nothing after the crop at size " << o.size
                                                  << "; use a larger image");
  FREELOC_CHECK(left >= 0 && top >= 0 && right <= rw && bottom <= rh, "DUSt3R preprocessing: crop outside the image");
  r.crop_x = left;
  r.crop_y = top;
  r.image = Image(right - left, bottom - top);
  for (int y = 0; y < r.image.height; ++y) {
    std::copy_n(resized.pixel(left, top + y), static_cast<size_t>(r.image.width) * 3, r.image.pixel(0, y));
  }
  r.normalized = NormalizeToCHW(r.image);
  return r;
}

void Dust3rInput::ToOriginal(double xn, double yn, double* xo, double* yo) const {
  *xo = (xn + crop_x + 0.5) * orig_width / resized_width - 0.5;
  *yo = (yn + crop_y + 0.5) * orig_height / resized_height - 0.5;
}

void Dust3rInput::ToNetwork(double xo, double yo, double* xn, double* yn) const {
  *xn = (xo + 0.5) * resized_width / orig_width - 0.5 - crop_x;
  *yn = (yo + 0.5) * resized_height / orig_height - 0.5 - crop_y;
}

}  // namespace freeloc::vision
