#include "freeloc/inputs/working_frame.h"

#include <algorithm>

#include "freeloc/core/logging.h"
#include "freeloc/io/image_io.h"

namespace freeloc::inputs {

WorkingFrame::WorkingFrame(const Image& image, int max_side)
    : image_(&image), photo_w_(image.PhotoWidth()), photo_h_(image.PhotoHeight()) {
  int w = image.width, h = image.height;
  if (image.photo_width <= 0 && !image.empty()) {  // not reduced yet: reduce here when it is larger
    io::WorkingSize(image.width, image.height, max_side, &w, &h);
    if (w != image.width || h != image.height) reduced_ = io::ShrinkImage(image, w, h);
  }
  if (w != photo_w_ || h != photo_h_)
    FREELOC_LOG(DEBUG) << "working at " << w << "x" << h << " for a " << photo_w_ << "x" << photo_h_ << " photo";
  if (w > 0 && h > 0) {
    scale_.sx = static_cast<double>(photo_w_) / w;
    scale_.sy = static_cast<double>(photo_h_) / h;
  }
}

Camera WorkingFrame::ToWorking(const Camera& k) const {
  if (!scaled() || (k.fx == 0 && k.fy == 0)) return k;
  Camera c = k;
  c.width = photo_w_;
  c.height = photo_h_;
  return c.Scaled(image().width, image().height);
}

Camera WorkingFrame::ToPhoto(const Camera& k) const {
  if (!scaled() || (k.fx == 0 && k.fy == 0)) return k;
  Camera c = k;
  c.width = image().width;
  c.height = image().height;
  return c.Scaled(photo_w_, photo_h_);
}

void WorkingFrame::ToPhoto(Correspondences* c, const PixelScale& ref) const {
  if (ref.scaled())
    for (auto& p : c->ref) p = ref.ToPhoto(p);
  if (scaled())
    for (auto& p : c->query) p = scale_.ToPhoto(p);
}

std::vector<Eigen::Vector4d> WorkingFrame::ToWorking(const std::vector<Eigen::Vector4d>& rows,
                                                     const PixelScale& ref) const {
  std::vector<Eigen::Vector4d> out = rows;
  for (auto& r : out) {
    r.head<2>() = ref.ToWorking(r.head<2>());
    r.tail<2>() = scale_.ToWorking(r.tail<2>());
  }
  return out;
}

std::vector<uint16_t> WorkingFrame::ToWorking(const std::vector<uint16_t>& labels) const {
  if (!scaled() || labels.size() != static_cast<size_t>(photo_w_) * photo_h_) return labels;
  const int w = image().width, h = image().height;
  std::vector<uint16_t> out(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    const int sy = std::min(photo_h_ - 1, static_cast<int>((y + 0.5) * scale_.sy));
    for (int x = 0; x < w; ++x)
      out[static_cast<size_t>(y) * w + x] =
          labels[static_cast<size_t>(sy) * photo_w_ + std::min(photo_w_ - 1, static_cast<int>((x + 0.5) * scale_.sx))];
  }
  return out;
}

}  // namespace freeloc::inputs
