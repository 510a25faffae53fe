#include "freeloc/vision/resize.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "freeloc/core/error.h"

namespace freeloc::vision {

namespace {

constexpr int kPrecisionBits = 32 - 8 - 2;  // 22, as Pillow's Resample.c

double BilinearFilter(double x) {
  if (x < 0.0) x = -x;
  if (x < 1.0) return 1.0 - x;
  return 0.0;
}

double BicubicFilter(double x) {
  constexpr double a = -0.5;
  if (x < 0.0) x = -x;
  if (x < 1.0) return ((a + 2.0) * x - (a + 3.0)) * x * x + 1;
  if (x < 2.0) return (((x - 5) * x + 8) * x - 4) * a;
  return 0.0;
}

double Sinc(double x) {
  if (x == 0.0) return 1.0;
  x = x * M_PI;
  return std::sin(x) / x;
}

double LanczosFilter(double x) {
  if (-3.0 <= x && x < 3.0) return Sinc(x) * Sinc(x / 3);
  return 0.0;
}

struct Coeffs {
  int ksize = 0;
  std::vector<int> bounds;  // per output: xmin, count
  std::vector<int32_t> kk;  // per output: ksize fixed-point weights
};

// Pillow's precompute_coeffs + normalize_coeffs_8bpc for one axis (box = the full input).
Coeffs Precompute(int in_size, int out_size, ResampleFilter filter) {
  double (*fn)(double) = nullptr;
  double support_base = 0;
  switch (filter) {
    case ResampleFilter::kBilinear:
      fn = BilinearFilter;
      support_base = 1.0;
      break;
    case ResampleFilter::kBicubic:
      fn = BicubicFilter;
      support_base = 2.0;
      break;
    case ResampleFilter::kLanczos:
      fn = LanczosFilter;
      support_base = 3.0;
      break;
  }
  const double scale = static_cast<double>(in_size) / out_size;
  const double filterscale = std::max(scale, 1.0);
  const double support = support_base * filterscale;
  Coeffs c;
  c.ksize = static_cast<int>(std::ceil(support)) * 2 + 1;
  c.bounds.resize(static_cast<size_t>(out_size) * 2);
  c.kk.assign(static_cast<size_t>(out_size) * c.ksize, 0);
  std::vector<double> k(c.ksize);
  for (int xx = 0; xx < out_size; ++xx) {
    const double center = (xx + 0.5) * scale;
    const double ss = 1.0 / filterscale;
    int xmin = static_cast<int>(center - support + 0.5);  // C cast truncates toward zero
    if (xmin < 0) xmin = 0;
    int xmax = static_cast<int>(center + support + 0.5);
    if (xmax > in_size) xmax = in_size;
    xmax -= xmin;
    double ww = 0.0;
    for (int x = 0; x < xmax; ++x) {
      const double w = fn((x + xmin - center + 0.5) * ss);
      k[x] = w;
      ww += w;
    }
    for (int x = 0; x < xmax; ++x)
      if (ww != 0.0) k[x] /= ww;
    for (int x = 0; x < c.ksize; ++x) {
      const double w = x < xmax ? k[x] : 0.0;
      c.kk[static_cast<size_t>(xx) * c.ksize + x] = w < 0 ? static_cast<int32_t>(-0.5 + w * (1 << kPrecisionBits))
                                                          : static_cast<int32_t>(0.5 + w * (1 << kPrecisionBits));
    }
    c.bounds[xx * 2 + 0] = xmin;
    c.bounds[xx * 2 + 1] = xmax;
  }
  return c;
}

inline uint8_t Clip8(int64_t in) {
  const int64_t v = in >> kPrecisionBits;
  return static_cast<uint8_t>(v < 0 ? 0 : v > 255 ? 255 : v);
}

// One pass over interleaved uint8 data with `channels` channels.
void HorizontalPass(const uint8_t* in, int in_w, int h, int channels, uint8_t* out, int out_w, const Coeffs& c) {
  for (int y = 0; y < h; ++y) {
    const uint8_t* row = in + static_cast<size_t>(y) * in_w * channels;
    uint8_t* orow = out + static_cast<size_t>(y) * out_w * channels;
    for (int xx = 0; xx < out_w; ++xx) {
      const int xmin = c.bounds[xx * 2], xmax = c.bounds[xx * 2 + 1];
      const int32_t* k = &c.kk[static_cast<size_t>(xx) * c.ksize];
      for (int ch = 0; ch < channels; ++ch) {
        int64_t ss = 1 << (kPrecisionBits - 1);
        for (int x = 0; x < xmax; ++x) ss += static_cast<int64_t>(row[(x + xmin) * channels + ch]) * k[x];
        orow[xx * channels + ch] = Clip8(ss);
      }
    }
  }
}

void VerticalPass(const uint8_t* in, int w, int in_h, int channels, uint8_t* out, int out_h, const Coeffs& c) {
  const size_t stride = static_cast<size_t>(w) * channels;
  for (int yy = 0; yy < out_h; ++yy) {
    const int ymin = c.bounds[yy * 2], ymax = c.bounds[yy * 2 + 1];
    const int32_t* k = &c.kk[static_cast<size_t>(yy) * c.ksize];
    uint8_t* orow = out + static_cast<size_t>(yy) * stride;
    for (size_t xc = 0; xc < stride; ++xc) {
      int64_t ss = 1 << (kPrecisionBits - 1);
      for (int y = 0; y < ymax; ++y) ss += static_cast<int64_t>(in[(y + ymin) * stride + xc]) * k[y];
      orow[xc] = Clip8(ss);
    }
  }
  (void)in_h;
}

std::vector<uint8_t> Resample(const uint8_t* in, int w, int h, int channels, int out_w, int out_h, ResampleFilter f) {
  FREELOC_CHECK(w > 0 && h > 0 && out_w > 0 && out_h > 0,
                "resize: sizes must be positive (from " << w << "x" << h << " to " << out_w << "x" << out_h << ")");
  std::vector<uint8_t> cur(in, in + static_cast<size_t>(w) * h * channels);
  int cw = w;
  if (out_w != w) {
    const Coeffs c = Precompute(w, out_w, f);
    std::vector<uint8_t> tmp(static_cast<size_t>(out_w) * h * channels);
    HorizontalPass(cur.data(), w, h, channels, tmp.data(), out_w, c);
    cur.swap(tmp);
    cw = out_w;
  }
  if (out_h != h) {
    const Coeffs c = Precompute(h, out_h, f);
    std::vector<uint8_t> tmp(static_cast<size_t>(cw) * out_h * channels);
    VerticalPass(cur.data(), cw, h, channels, tmp.data(), out_h, c);
    cur.swap(tmp);
  }
  return cur;
}

}  // namespace

Image PillowResize(const Image& in, int out_width, int out_height, ResampleFilter filter) {
  Image out;
  out.width = out_width;
  out.height = out_height;
  out.data = Resample(in.data.data(), in.width, in.height, 3, out_width, out_height, filter);
  return out;
}

std::vector<uint8_t> PillowResizePlane(const std::vector<uint8_t>& in, int width, int height, int out_width,
                                       int out_height, ResampleFilter filter) {
  FREELOC_CHECK(in.size() == static_cast<size_t>(width) * height, "resize: plane size does not match its data");
  return Resample(in.data(), width, height, 1, out_width, out_height, filter);
}

std::vector<uint8_t> PillowResizeNearest(const uint8_t* in, int w, int h, int ch, int ow, int oh) {
  FREELOC_CHECK(w > 0 && h > 0 && ow > 0 && oh > 0, "nearest resize: sizes must be positive");
  auto indices = [](int n_in, int n_out) {
    std::vector<int> idx(static_cast<size_t>(n_out));
    const double scale = static_cast<double>(n_in) / n_out;
    double pos = 0.5 * scale;
    for (int o = 0; o < n_out; ++o) {
      idx[static_cast<size_t>(o)] = std::min(static_cast<int>(pos), n_in - 1);
      pos += scale;
    }
    return idx;
  };
  const std::vector<int> xs = indices(w, ow), ys = indices(h, oh);
  std::vector<uint8_t> out(static_cast<size_t>(ow) * oh * ch);
  for (int y = 0; y < oh; ++y)
    for (int x = 0; x < ow; ++x)
      for (int c = 0; c < ch; ++c)
        out[(static_cast<size_t>(y) * ow + x) * ch + c] = in[(static_cast<size_t>(ys[y]) * w + xs[x]) * ch + c];
  return out;
}

std::vector<int> TorchNearestIndices(int in_size, int out_size) {
  std::vector<int> idx(static_cast<size_t>(out_size));
  const float scale = static_cast<float>(in_size) / static_cast<float>(out_size);
  for (int o = 0; o < out_size; ++o)
    idx[static_cast<size_t>(o)] = std::min(static_cast<int>(std::floor(static_cast<float>(o) * scale)), in_size - 1);
  return idx;
}

}  // namespace freeloc::vision
