// Dense depth in float metres; 0 marks an invalid pixel (docs/architecture.md §2).
#pragma once

#include <cmath>
#include <vector>

namespace freeloc {

struct DepthMap {
  int width = 0;
  int height = 0;
  std::vector<float> data;  // height * width, row-major, metres; 0 = invalid

  DepthMap() = default;
  DepthMap(int w, int h) : width(w), height(h), data(static_cast<size_t>(w) * h, 0.f) {}

  bool empty() const { return width <= 0 || height <= 0; }
  float& at(int x, int y) { return data[static_cast<size_t>(y) * width + x]; }
  float at(int x, int y) const { return data[static_cast<size_t>(y) * width + x]; }
  bool valid(int x, int y) const {
    if (x < 0 || y < 0 || x >= width || y >= height) return false;
    const float d = at(x, y);
    return d > 0.f && std::isfinite(d);
  }
};

}  // namespace freeloc
