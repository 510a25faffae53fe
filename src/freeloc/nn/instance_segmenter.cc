#include "freeloc/nn/instance_segmenter.h"

#include <algorithm>

#include "freeloc/core/error.h"
#include "freeloc/vision/seggpt_preprocess.h"

namespace freeloc::nn {

InstanceSegmenter::InstanceSegmenter(std::shared_ptr<const SegGptModel> model, InstanceSegmenterOptions options)
    : model_(std::move(model)), options_(options) {
  FREELOC_CHECK(model_ != nullptr, "InstanceSegmenter: no SegGPT model");
  FREELOC_CHECK(options_.max_batch >= 1, "InstanceSegmenter: max_batch must be >= 1");
}

std::vector<PropagatedInstance> InstanceSegmenter::Propagate(
    const Image& ref, const std::vector<std::pair<int, std::vector<uint8_t>>>& ref_masks, const Image& query) const {
  std::vector<PropagatedInstance> out;
  const int S = model_->config().half;
  for (size_t start = 0; start < ref_masks.size(); start += static_cast<size_t>(options_.max_batch)) {
    const size_t end = std::min(ref_masks.size(), start + static_cast<size_t>(options_.max_batch));
    std::vector<Image> prompts, masks;
    for (size_t i = start; i < end; ++i) {
      const auto& m = ref_masks[i].second;
      FREELOC_CHECK(m.size() == ref.num_pixels(), "instance " << ref_masks[i].first << ": the reference mask has "
                                                              << m.size() << " pixels, the image " << ref.num_pixels());
      Image rgb(ref.width, ref.height);
      for (size_t p = 0; p < m.size(); ++p)
        if (m[p]) rgb.data[3 * p] = rgb.data[3 * p + 1] = rgb.data[3 * p + 2] = 255;
      prompts.push_back(ref);
      masks.push_back(rgb);
    }
    const vision::SegGptInputs in = vision::PrepareSegGptInputs(prompts, masks, query, S);
    // Independent passes: the ensemble stays off even though the batch has several items.
    const io::TensorView pred = model_->Forward(in.imgs, in.tgts, in.k, SegType::kInstance, false);
    const size_t item = static_cast<size_t>(3) * 2 * S * S;
    for (int k = 0; k < in.k; ++k) {
      const auto& [id, rm] = ref_masks[start + static_cast<size_t>(k)];
      const vision::SegGptMask sm =
          vision::PostprocessSegGpt(pred.as<float>() + item * k, S, query.width, query.height);
      PropagatedInstance pi;
      pi.id = id;
      pi.query_mask = sm.mask;
      pi.score = std::clamp((sm.foreground_score - 0.5) / 0.5, 0.0, 1.0);
      const double ref_area = static_cast<double>(std::count(rm.begin(), rm.end(), 1)) / rm.size();
      const double q_area = static_cast<double>(std::count(sm.mask.begin(), sm.mask.end(), 1)) / sm.mask.size();
      pi.area_ratio = ref_area > 0 ? q_area / ref_area : 0;
      if (q_area == 0) {
        pi.reason = "empty propagation";
      } else if (pi.score < options_.min_score) {
        pi.reason = "weak propagation (score " + std::to_string(pi.score) + ")";
      } else if (pi.area_ratio < options_.min_area_ratio || pi.area_ratio > options_.max_area_ratio) {
        pi.reason = "area changed too much (ratio " + std::to_string(pi.area_ratio) + ")";
      } else {
        pi.kept = true;
      }
      out.push_back(std::move(pi));
    }
  }
  return out;
}

}  // namespace freeloc::nn
