// Instance propagation with SegGPT (the paper's instance knowledge, docs/architecture.md §1 stage 3): each reference
// instance mask is a prompt (reference image + white-on-black mask, instance type token) and the query is the target;
// all instances go through the network as one batch with the feature ensemble off, i.e. one independent pass per
// instance. Each propagated mask gets a score so weak propagations can be dropped.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "freeloc/core/image.h"
#include "freeloc/nn/instance_segmenter_options.h"
#include "freeloc/nn/seggpt.h"

namespace freeloc::nn {

struct PropagatedInstance {
  int id = 0;
  std::vector<uint8_t> query_mask;  // 0/1 at the query's resolution
  double score = 0;                 // (mean foreground intensity − 0.5)/0.5 of the painted mask, in [0, 1]
  double area_ratio = 0;
  bool kept = false;
  std::string reason;  // why dropped
};

class InstanceSegmenter {
 public:
  InstanceSegmenter(std::shared_ptr<const SegGptModel> model, InstanceSegmenterOptions options = {});
  // `ref_masks`: (id, 0/1 mask at the reference's resolution) pairs, e.g. matching::SplitLabels of a label image.
  std::vector<PropagatedInstance> Propagate(const Image& ref,
                                            const std::vector<std::pair<int, std::vector<uint8_t>>>& ref_masks,
                                            const Image& query) const;

 private:
  std::shared_ptr<const SegGptModel> model_;
  InstanceSegmenterOptions options_;
};

}  // namespace freeloc::nn
