// The networks module's stages (pipeline/networks.h): what pipeline::MakeMatcher and MakeDepthEstimator return for
// the presets that run a network. A program linking freeloc::networks may call them directly.
#pragma once

#include <memory>

#include "freeloc/pipeline/stages.h"

namespace freeloc::pipeline {

// dust3r | dust3r+instances | mast3r | mast3r+instances (throws for other matchers).
std::unique_ptr<Matcher> MakeNetworkMatcher(const PipelineOptions& options);
// metric3d (throws for other depth stages).
std::unique_ptr<DepthEstimator> MakeNetworkDepthEstimator(const PipelineOptions& options);

}  // namespace freeloc::pipeline
