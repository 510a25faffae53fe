// Dense depth in float metres; 0 marks an invalid pixel (docs/architecture.md §2).
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace freeloc {

// How a provided map's values were stored: as float metres (arrays, the networks' estimates) or as integers (16-bit
// PNGs, uint16 arrays), which the readers turn into metres as millimetres — the map-free convention — until the
// pipeline applies the unit the options name (`depth_unit`, inputs/input_checks.h, docs/formats.md "Depth maps").
enum class DepthStorage : uint8_t { kMetres, kInteger };

struct DepthMap {
  int width = 0;
  int height = 0;
  std::vector<float> data;  // height * width, row-major, metres; 0 = invalid
  DepthStorage storage = DepthStorage::kMetres;
  std::string source;  // where it came from, for messages: a file's path, "depth_ref"; empty: unnamed

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
