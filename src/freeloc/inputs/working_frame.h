// A frame at the working resolution (PipelineOptions inputs.max_side, docs/pipeline.md "Phone photos"): the stages see
// a photo at most max_side pixels on its long side — the photo itself, a reduced decode of it (io/image_io.h), or a
// reduction made here — with its camera, depth map, instance labels and handed-in correspondences brought into those
// pixels; what leaves the Relocalizer (correspondences, intrinsics) goes back to the photo's own pixels. Pixel centres
// map as in Camera::Scaled: x_photo = (x + 0.5)·sx − 0.5.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/correspondences.h"
#include "freeloc/core/image.h"

namespace freeloc::inputs {

// Photo pixels per working pixel, and the maps between the two frames.
struct PixelScale {
  double sx = 1, sy = 1;
  bool scaled() const { return sx != 1 || sy != 1; }
  Eigen::Vector2d ToPhoto(const Eigen::Vector2d& p) const {
    return {(p.x() + 0.5) * sx - 0.5, (p.y() + 0.5) * sy - 0.5};
  }
  Eigen::Vector2d ToWorking(const Eigen::Vector2d& p) const {
    return {(p.x() + 0.5) / sx - 0.5, (p.y() + 0.5) / sy - 0.5};
  }
};

class WorkingFrame {
 public:
  // `image` must outlive the frame (it is referred to, not copied, when no reduction is made here).
  WorkingFrame(const Image& image, int max_side);
  const Image& image() const { return reduced_.empty() ? *image_ : reduced_; }
  int photo_width() const { return photo_w_; }
  int photo_height() const { return photo_h_; }
  const PixelScale& scale() const { return scale_; }
  bool scaled() const { return scale_.scaled(); }

  Camera ToWorking(const Camera& photo) const;  // a zero camera (none given) stays zero
  Camera ToPhoto(const Camera& working) const;
  // Correspondences → photo pixels: the query side this frame's, the reference side `ref`'s.
  void ToPhoto(Correspondences* c, const PixelScale& ref) const;
  // Rows (x_ref, y_ref, x_query, y_query) in photo pixels → working pixels, the query side this frame's.
  std::vector<Eigen::Vector4d> ToWorking(const std::vector<Eigen::Vector4d>& rows, const PixelScale& ref) const;
  // A label image of the photo's size → the working size (nearest); other sizes are left as they are.
  std::vector<uint16_t> ToWorking(const std::vector<uint16_t>& labels) const;

 private:
  const Image* image_;
  Image reduced_;
  int photo_w_, photo_h_;
  PixelScale scale_;
};

}  // namespace freeloc::inputs
