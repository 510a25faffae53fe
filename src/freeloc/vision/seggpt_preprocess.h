// SegGPT's input preparation (Painter SegGPT_inference seggpt_engine.inference_image + run_one_image,
// baaivision/Painter SegGPT): every image resized to S×S ignoring aspect (Pillow BICUBIC), prompt masks with Pillow
// NEAREST; per prompt k, [prompt image ; target image] and [prompt mask ; prompt mask] stacked along the height;
// /255 and ImageNet normalisation (in double, cast to float32); and the post-processing back to a binary mask.
#pragma once

#include <cstdint>
#include <vector>

#include "freeloc/core/image.h"

namespace freeloc::vision {

struct SegGptInputs {
  int k = 0, half = 0;      // prompts, S (each half is S×S)
  std::vector<float> imgs;  // [K, 3, 2S, S]
  std::vector<float> tgts;  // [K, 3, 2S, S]
  std::vector<Image> prompt_images_resized, prompt_masks_resized;
  Image target_resized;
};

// `prompt_masks` are RGB (white object on black for instance prompts; any colours for semantic ones).
SegGptInputs PrepareSegGptInputs(const std::vector<Image>& prompt_images, const std::vector<Image>& prompt_masks,
                                 const Image& target, int half_size);

struct SegGptMask {
  std::vector<float> painted;       // [S, S, 3]: item 0, bottom half, (pred·std + mean)·255 clipped to [0, 255]
  std::vector<float> painted_full;  // [Ht, Wt, 3]: torch legacy nearest resize of `painted`
  std::vector<uint8_t> mask;        // [Ht, Wt]: 1 where mean over channels > 128 (strict)
  double foreground_score = 0;      // mean over the mask's pixels of mean(painted)/255 (0 when the mask is empty)
};

// `pred0`: item 0 of the network output, [3, 2S, S] in normalised space.
SegGptMask PostprocessSegGpt(const float* pred0, int half_size, int target_width, int target_height);

}  // namespace freeloc::vision
