// DUSt3R as a pipeline stage: the model as the matching module's pointmap function, and a per-process model cache
// so that a run loads the weights once. Light header: the LibTorch model stays behind a forward declaration.
#pragma once

#include <memory>
#include <string>

#include "freeloc/matching/instance.h"

namespace freeloc::nn {
class Dust3rModel;
struct RuntimeOptions;
}  // namespace freeloc::nn

namespace freeloc::pipeline {

// Runs `model` on a preprocessed pair and returns its pointmaps (view 2's points in view 1's frame) on the host.
matching::PointmapFn Dust3rPointmapFn(std::shared_ptr<nn::Dust3rModel> model);

// The model at `path` (official .pth or model.safetensors; `config` optional), loaded on first use and kept for the
// process, keyed by path, config and runtime. Throws freeloc::Error naming the file when it cannot be loaded.
std::shared_ptr<nn::Dust3rModel> CachedDust3r(const std::string& path, const std::string& config,
                                              const nn::RuntimeOptions& runtime);

}  // namespace freeloc::pipeline
