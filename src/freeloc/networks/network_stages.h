// The networks module's stages (pipeline/networks.h): what pipeline::MakeMatcher and MakeDepthEstimator return for
// the presets that run a network. A program linking freeloc::networks may call them directly.
#pragma once

#include <memory>

#include "freeloc/pipeline/stages.h"

namespace freeloc::nn {
class Dust3rModel;
class SegGptModel;
class Metric3dModel;
}  // namespace freeloc::nn

namespace freeloc::networks {

// dust3r | dust3r+instances | mast3r | mast3r+instances (throws for other matchers).
std::unique_ptr<pipeline::Matcher> MakeNetworkMatcher(const pipeline::PipelineOptions& options);
// metric3d (throws for other depth stages).
std::unique_ptr<pipeline::DepthEstimator> MakeNetworkDepthEstimator(const pipeline::PipelineOptions& options);

// The same stages on models already in memory (e.g. bench/relocalize's random full-size weights); the options'
// model paths are not read. `seggpt` may be null when the matcher runs no SegGPT.
std::unique_ptr<pipeline::Matcher> MakeNetworkMatcher(const pipeline::PipelineOptions& options,
                                                      std::shared_ptr<nn::Dust3rModel> model,
                                                      std::shared_ptr<nn::SegGptModel> seggpt);
std::unique_ptr<pipeline::DepthEstimator> MakeNetworkDepthEstimator(std::shared_ptr<nn::Metric3dModel> model);

}  // namespace freeloc::networks
