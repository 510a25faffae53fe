// Reference-instance proposals from the reference's own DUSt3R pointmap (the paper does not say where reference
// masks come from; docs/matching.md). Deterministic:
//  1. valid pixels: confidence ≥ the `conf_quantile` quantile of the image's confidences (and finite points);
//  2. surface breaks: between 4-neighbours whose depth (z) differs by more than `depth_jump` relative, or whose
//     normals (cross products of the neighbouring 3D differences) differ by more than `normal_angle_deg`;
//  3. connected components (4-connectivity) of valid pixels not separated by a break;
//  4. components touching fewer than `min_area` of the pixels are dropped; the rest are ranked by
//     area × mean confidence and the first `max_instances` kept; one pixel of dilation closes the break lines;
//  5. labels 1…n in rank order, mapped to any resolution by nearest sampling (ProposalsToImage).
#pragma once

#include <cstdint>
#include <vector>

#include "freeloc/vision/dust3r_preprocess.h"

namespace freeloc::matching {

struct ProposalOptions {
  double conf_quantile = 0.3;    // drop the least confident 30 % of pixels
  double depth_jump = 0.05;      // relative depth step that breaks a surface
  double normal_angle_deg = 35;  // normal change that breaks a surface
  double min_area = 0.01;        // fraction of the image
  int max_instances = 5;
  void Validate() const;
};

// Label image (0 = none, 1…n) on the pointmap's grid.
std::vector<uint16_t> ProposeInstances(const float* pts, const float* conf, int height, int width,
                                       const ProposalOptions& options = {});

// Labels on the network grid → labels at the original image's resolution (via the preprocessing's mapping).
std::vector<uint16_t> ProposalsToImage(const std::vector<uint16_t>& labels, const Dust3rInput& in);

}  // namespace freeloc::matching
