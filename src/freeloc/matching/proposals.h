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

#include "freeloc/matching/proposal_options.h"
#include "freeloc/vision/dust3r_preprocess.h"

namespace freeloc::matching {

// Label image (0 = none, 1…n) on the pointmap's grid.
std::vector<uint16_t> ProposeInstances(const float* pts, const float* conf, int height, int width,
                                       const ProposalOptions& options = {});

// Labels on the network grid → labels at the original image's resolution (via the preprocessing's mapping).
std::vector<uint16_t> ProposalsToImage(const std::vector<uint16_t>& labels, const vision::Dust3rInput& in);

}  // namespace freeloc::matching
