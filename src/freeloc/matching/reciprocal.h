// Reciprocal nearest neighbours in 3D between two pointmaps (dust3r/utils/geometry.py find_reciprocal_matches,
// naver/dust3r): pixel a of view 1 and pixel b of view 2 match iff each is the other's exact nearest
// neighbour, distances in double from the float32 points. Matches come out in the reference utility's order
// (row-major over view 2's valid pixels) with their confidences. KD-trees (nanoflann), optional subsampling of
// view 2 on a grid, deterministic for the same input.
#pragma once

#include <cstdint>
#include <vector>

namespace freeloc::matching {

struct PointmapView {
  const float* pts = nullptr;     // H×W×3, row-major
  const float* conf = nullptr;    // H×W (may be null: all valid, confidence 0)
  const uint8_t* mask = nullptr;  // H×W (may be null): only pixels with mask ≠ 0 take part (instance matching)
  int height = 0, width = 0;
};

struct ReciprocalOptions {
  double conf_threshold = 0;  // a pixel is valid if conf ≥ threshold (visloc style); 0 and no conf = all valid
  int subsample = 1;          // keep view 2 pixels with x % k == 0 and y % k == 0 (MASt3R-style cap)
  int threads = 0;            // 0 = hardware concurrency
  void Validate() const;
};

struct PixelMatch {
  int x1, y1, x2, y2;  // network pixels (x = column)
  float conf1, conf2;
};

std::vector<PixelMatch> ReciprocalMatches(const PointmapView& view1, const PointmapView& view2,
                                          const ReciprocalOptions& options = {});

// The same by brute force (O(n1·n2)), for cross-checks and the benchmark's reference.
std::vector<PixelMatch> ReciprocalMatchesBruteForce(const PointmapView& view1, const PointmapView& view2,
                                                    const ReciprocalOptions& options = {});

}  // namespace freeloc::matching
