#include "freeloc/core/camera.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "freeloc/core/error.h"

namespace freeloc {

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

Camera Camera::Scaled(int new_width, int new_height) const {
  FREELOC_CHECK(width > 0 && height > 0, "Camera::Scaled: the camera has no image size; set width and height");
  const double sx = static_cast<double>(new_width) / width;
  const double sy = static_cast<double>(new_height) / height;
  Camera c;
  c.fx = fx * sx;
  c.fy = fy * sy;
  c.cx = (cx + 0.5) * sx - 0.5;
  c.cy = (cy + 0.5) * sy - 0.5;
  c.width = new_width;
  c.height = new_height;
  return c;
}

void Camera::Validate(const std::string& what) const {
  FREELOC_CHECK(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0,
                what << ": focal lengths must be positive and finite (got fx=" << fx << ", fy=" << fy
                     << "); check the intrinsics");
  FREELOC_CHECK(std::isfinite(cx) && std::isfinite(cy),
                what << ": principal point must be finite; check the intrinsics");
  FREELOC_CHECK(width >= 0 && height >= 0, what << ": image size must not be negative; check the intrinsics");
  if (width > 0 && height > 0) {
    // A generous box: the principal point within the image widened by its size on every side, the focal length
    // below 100 image widths (cx=1e6 for a 640-pixel image is a typo, not a lens).
    FREELOC_CHECK(cx >= -width && cx <= 2.0 * width && cy >= -height && cy <= 2.0 * height,
                  what << ": principal point (" << cx << ", " << cy << ") is far outside the " << width << "x" << height
                       << " image; check the intrinsics (cx, cy are pixels, not normalised)");
    const double size = std::max(width, height);
    FREELOC_CHECK(fx <= 100 * size && fy <= 100 * size,
                  what << ": focal length (" << fx << ", " << fy << ") exceeds 100 image widths; check the intrinsics");
  } else {
    // Without the image size: a principal point 100 focal lengths off-axis is a typo, not a camera.
    const double f = std::max(fx, fy);
    FREELOC_CHECK(std::abs(cx) <= 100 * f && std::abs(cy) <= 100 * f,
                  what << ": principal point (" << cx << ", " << cy << ") is more than 100 focal lengths from the "
                       << "image origin; check the intrinsics (fx, fy, cx, cy in pixels)");
  }
}

void Camera::ValidateForImage(int image_width, int image_height, const std::string& what) const {
  Camera sized = *this;
  if (sized.width <= 0 || sized.height <= 0) {
    sized.width = image_width;
    sized.height = image_height;
  }
  sized.Validate(what);
}

Camera Camera::FromString(const std::string& text, const std::string& what) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stod(item, &used));
      FREELOC_CHECK(used == item.size(), "");
    } catch (...) {
      FREELOC_THROW(what << ": '" << item << "' is not a number; give intrinsics as fx,fy,cx,cy");
    }
  }
  FREELOC_CHECK(v.size() == 4, what << ": expected 4 comma-separated values fx,fy,cx,cy, got " << v.size());
  Camera c;
  c.fx = v[0];
  c.fy = v[1];
  c.cx = v[2];
  c.cy = v[3];
  c.Validate(what);
  return c;
}

}  // namespace freeloc
