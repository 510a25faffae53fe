#include "freeloc/vision/seggpt_preprocess.h"

#include <algorithm>

#include "freeloc/core/error.h"
#include "freeloc/vision/resize.h"

namespace freeloc::vision {

namespace {
constexpr double kMean[3] = {0.485, 0.456, 0.406};
constexpr double kStd[3] = {0.229, 0.224, 0.225};

// Writes an S×S RGB8 image into rows [row0, row0 + S) of a [3, 2S, S] float plane, normalised.
void Put(const Image& im, int row0, int S, float* out) {
  const size_t plane = static_cast<size_t>(2 * S) * S;
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x)
      for (int c = 0; c < 3; ++c) {
        const double v = im.at(x, y, c) / 255.0;
        out[c * plane + static_cast<size_t>(row0 + y) * S + x] = static_cast<float>((v - kMean[c]) / kStd[c]);
      }
}
}  // namespace

SegGptInputs PrepareSegGptInputs(const std::vector<Image>& prompt_images, const std::vector<Image>& prompt_masks,
                                 const Image& target, int S) {
  FREELOC_CHECK(!prompt_images.empty(), "SegGPT: at least one prompt (image + mask) is needed");
  FREELOC_CHECK(prompt_images.size() == prompt_masks.size(),
                "SegGPT: " << prompt_images.size() << " prompt images but " << prompt_masks.size() << " prompt masks");
  FREELOC_CHECK(S > 0, "SegGPT: bad half size");
  SegGptInputs in;
  in.k = static_cast<int>(prompt_images.size());
  in.half = S;
  auto bicubic = [S](const Image& im) {
    return (im.width == S && im.height == S) ? im : PillowResize(im, S, S, ResampleFilter::kBicubic);
  };
  in.target_resized = bicubic(target);
  const size_t item = static_cast<size_t>(3) * 2 * S * S;
  in.imgs.assign(item * in.k, 0.f);
  in.tgts.assign(item * in.k, 0.f);
  for (int k = 0; k < in.k; ++k) {
    FREELOC_CHECK(!prompt_images[k].empty() && !prompt_masks[k].empty(), "SegGPT: empty prompt " << k);
    const Image pi = bicubic(prompt_images[k]);
    Image pm(S, S);
    pm.data = PillowResizeNearest(prompt_masks[k].data.data(), prompt_masks[k].width, prompt_masks[k].height, 3, S, S);
    Put(pi, 0, S, &in.imgs[item * k]);
    Put(in.target_resized, S, S, &in.imgs[item * k]);
    Put(pm, 0, S, &in.tgts[item * k]);
    Put(pm, S, S, &in.tgts[item * k]);
    in.prompt_images_resized.push_back(pi);
    in.prompt_masks_resized.push_back(pm);
  }
  return in;
}

SegGptMask PostprocessSegGpt(const float* pred0, int S, int tw, int th) {
  SegGptMask m;
  m.painted.resize(static_cast<size_t>(S) * S * 3);
  const size_t plane = static_cast<size_t>(2 * S) * S;
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x)
      for (int c = 0; c < 3; ++c) {
        const double v =
            (static_cast<double>(pred0[c * plane + static_cast<size_t>(S + y) * S + x]) * kStd[c] + kMean[c]) * 255.0;
        m.painted[(static_cast<size_t>(y) * S + x) * 3 + c] = static_cast<float>(std::clamp(v, 0.0, 255.0));
      }
  const std::vector<int> xs = TorchNearestIndices(S, tw), ys = TorchNearestIndices(S, th);
  m.painted_full.resize(static_cast<size_t>(tw) * th * 3);
  m.mask.resize(static_cast<size_t>(tw) * th);
  double fg = 0;
  size_t n_fg = 0;
  for (int y = 0; y < th; ++y)
    for (int x = 0; x < tw; ++x) {
      const float* p = &m.painted[(static_cast<size_t>(ys[y]) * S + xs[x]) * 3];
      float* q = &m.painted_full[(static_cast<size_t>(y) * tw + x) * 3];
      q[0] = p[0];
      q[1] = p[1];
      q[2] = p[2];
      const double mean = (static_cast<double>(p[0]) + p[1] + p[2]) / 3.0;
      const bool on = mean > 128.0;
      m.mask[static_cast<size_t>(y) * tw + x] = on;
      if (on) {
        fg += mean / 255.0;
        ++n_fg;
      }
    }
  m.foreground_score = n_fg ? fg / static_cast<double>(n_fg) : 0.0;
  return m;
}

}  // namespace freeloc::vision
