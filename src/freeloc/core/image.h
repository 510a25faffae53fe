// RGB8 image, row-major H×W×3 (docs/architecture.md §2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace freeloc {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> data;  // height * width * 3, row-major, RGB
  // A photo held at a working resolution (a reduced decode, io/image_io.h) keeps its own displayed size here: its
  // intrinsics, depth maps and correspondences refer to that size. 0: this image is the photo's own size.
  int photo_width = 0, photo_height = 0;
  int PhotoWidth() const { return photo_width > 0 ? photo_width : width; }
  int PhotoHeight() const { return photo_height > 0 ? photo_height : height; }

  Image() = default;
  Image(int w, int h) : width(w), height(h), data(static_cast<size_t>(w) * h * 3, 0) {}

  bool empty() const { return width <= 0 || height <= 0; }
  size_t num_pixels() const { return static_cast<size_t>(width) * height; }
  uint8_t* pixel(int x, int y) { return data.data() + (static_cast<size_t>(y) * width + x) * 3; }
  const uint8_t* pixel(int x, int y) const { return data.data() + (static_cast<size_t>(y) * width + x) * 3; }
  uint8_t at(int x, int y, int c) const { return pixel(x, y)[c]; }
  bool operator==(const Image& o) const { return width == o.width && height == o.height && data == o.data; }
};

}  // namespace freeloc
