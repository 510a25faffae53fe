// Instance knowledge (the paper's Eq. 1–3, docs/architecture.md §1): for each pair of instance masks (reference,
// query), the pointmap model runs again on the masked pair and matches are taken within the masks (Map_o); the final
// set takes Map_o for correspondences whose reference pixel lies inside instance o's reference mask and the global
// matches Map_g elsewhere — global matches inside a used instance mask are replaced, not added.
//   * kMask: pixels outside the mask are set to zero before the network (I ⊙ Mask, as in the paper).
//   * kCrop: each image is cropped to its mask's bounding box (plus a margin) first, so the object gets more
//     network pixels; pixels outside the mask inside the box are zeroed too.
// The model is a callback (the pipeline wires DUSt3R in), so this module needs no tensors.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "freeloc/core/enum_table.h"
#include "freeloc/core/image.h"
#include "freeloc/matching/correspondences.h"
#include "freeloc/matching/fast_nn.h"
#include "freeloc/matching/instance_mode.h"
#include "freeloc/matching/reciprocal.h"
#include "freeloc/vision/dust3r_preprocess.h"

namespace freeloc::matching {

struct Correspondence {
  Eigen::Vector2d ref, query;  // original pixels
  float conf = 0;              // min of the two confidences
  int source = -1;             // −1 = global (Map_g), otherwise the instance id (Map_o)
};

// A pair of instance masks at the original resolution of each image (non-zero = inside).
struct InstanceMasks {
  int id = 0;
  std::vector<uint8_t> ref, query;
};

// Pointmaps of a preprocessed pair: view 1's points and view 2's points in view 1's frame, with confidences; from a
// MASt3R model also the dense descriptors and their confidence (empty otherwise).
struct PairPointmaps {
  std::vector<float> pts1, conf1, pts2, conf2;              // H×W×3 and H×W each
  std::vector<float> desc1, desc_conf1, desc2, desc_conf2;  // H×W×D and H×W each (MASt3R)
  int h1 = 0, w1 = 0, h2 = 0, w2 = 0, desc_dim = 0;
};
using PointmapFn = std::function<PairPointmaps(const vision::Dust3rInput& ref, const vision::Dust3rInput& query)>;

struct InstanceOptions {
  InstanceMode mode = InstanceMode::kMask;
  double crop_margin = 0.1;   // kCrop: fraction of the box size added on every side
  int min_mask_pixels = 400;  // smaller masks (in either image) are skipped
  int min_matches = 16;       // instances with fewer matches are skipped
  ReciprocalOptions match;    // confidence threshold, subsampling (3D matching)
  // MASt3R: match by descriptors (fast reciprocal NN, then the border / desc_conf filter) instead of in 3D.
  bool descriptors = false;
  FastNnOptions fast_nn;
  DescriptorMatchFilter descriptor_filter;
  vision::Dust3rPreprocessOptions preprocess;
  void Validate() const;
};

struct InstanceResult {
  int id = 0;
  bool used = false;
  std::string reason;  // why skipped: "mask too small (N px)", "too few matches (M)"
  std::vector<Correspondence> matches;
};

// Correspondences of the global pair as `Correspondence`s (source −1) in original pixels.
std::vector<Correspondence> GlobalCorrespondences(const PairPointmaps& pm, const vision::Dust3rInput& ref,
                                                  const vision::Dust3rInput& query, const ReciprocalOptions& options);
// The same with the matching `options` choose: 3D reciprocal (options.match) or, with options.descriptors, MASt3R's
// fast reciprocal NN on the descriptors and its filter.
std::vector<Correspondence> GlobalCorrespondences(const PairPointmaps& pm, const vision::Dust3rInput& ref,
                                                  const vision::Dust3rInput& query, const InstanceOptions& options);

// Network-pixel matches of a pair, restricted to the masks when given (network resolution, H×W each; a descriptor
// match is kept when both pixels are inside). Throws when descriptors are asked for and the pair has none.
std::vector<PixelMatch> MatchPair(const PairPointmaps& pm, const uint8_t* mask1, const uint8_t* mask2,
                                  const InstanceOptions& options);

// Map_o for one instance. Throws freeloc::Error when a mask's size differs from its image's.
InstanceResult MatchInstance(const Image& ref, const Image& query, const InstanceMasks& masks, const PointmapFn& model,
                             const InstanceOptions& options);

// The network input MatchInstance builds for the reference side of an instance (the masked image, or its box in
// kCrop mode, preprocessed): it depends on the reference alone, so a cache can encode it once per scene.
vision::Dust3rInput InstanceReferenceInput(const Image& ref, const std::vector<uint8_t>& ref_mask,
                                           const InstanceOptions& options);

// Eq. 3: instance matches replace the global ones inside the reference masks of the instances that were used.
std::vector<Correspondence> MergeMatches(const std::vector<Correspondence>& global,
                                         const std::vector<InstanceResult>& instances,
                                         const std::vector<InstanceMasks>& masks, int ref_width, int ref_height);

// Label image (0 = background, k > 0 = instance k) → one mask per label, sorted by label.
std::vector<std::pair<int, std::vector<uint8_t>>> SplitLabels(const std::vector<uint16_t>& labels);

}  // namespace freeloc::matching
