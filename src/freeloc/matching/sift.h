// The SIFT baseline exactly as the map-free benchmark computes it (lib/models/matching/feature_matching.py
// SIFTMatching): OpenCV SIFT with 2048 features on the grey image, RootSIFT (L1 normalisation + square root),
// FLANN kd-tree matching (5 trees, 50 checks, k = 2) and Lowe's ratio test at 0.8. Correspondences come out in
// original-image pixels (x = column, y = row), reference first.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "freeloc/core/image.h"
#include "freeloc/matching/correspondences.h"

namespace freeloc::matching {

struct SiftOptions {
  int num_features = 2048;
  double ratio = 0.8;
  int trees = 5;
  int checks = 50;
  bool root_sift = true;
  uint32_t seed = 0;  // FLANN's randomised kd-trees are seeded so runs are reproducible
  void Validate() const;
};

// Keypoints (x, y in pixels) and their (Root)SIFT descriptors, row-major [size × dim].
struct SiftFeatures {
  std::vector<Eigen::Vector2f> points;
  std::vector<float> descriptors;
  int dim = 128;
  size_t size() const { return points.size(); }
};

// Extraction alone, so that a reference's features can be computed once and matched against many queries.
SiftFeatures ExtractSift(const Image& image, const SiftOptions& options = {});
// FLANN kNN of the reference's descriptors in the query's index, ratio test. MatchSift(a, b) ==
// MatchSiftFeatures(ExtractSift(a), ExtractSift(b)).
Correspondences MatchSiftFeatures(const SiftFeatures& ref, const SiftFeatures& query, const SiftOptions& options = {});
Correspondences MatchSift(const Image& ref, const Image& query, const SiftOptions& options = {});

}  // namespace freeloc::matching
