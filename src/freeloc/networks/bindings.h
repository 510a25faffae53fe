// The networks one by one for the bindings (Python's Dust3r, Metric3D and SegGPT): load a network and run it on
// images, results as named host tensors — so that a binding reaches the networks through the networks module's table
// (pipeline/networks.h) and includes no nn/ or vision/ header.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "freeloc/pipeline/networks.h"

namespace freeloc::networks {

std::shared_ptr<void> LoadBoundNetwork(pipeline::BoundNetwork kind, const std::string& path, const std::string& config,
                                       const nn::RuntimeOptions& runtime);
std::string BoundNetworkFamily(const std::shared_ptr<void>& network);
pipeline::NamedTensors RunBoundPointmaps(const std::shared_ptr<void>& network, const Image& image_1,
                                         const Image& image_2, int size);
pipeline::NamedTensors RunBoundDepth(const std::shared_ptr<void>& network, const Image& image, const Camera& camera);
std::vector<uint8_t> RunBoundSegment(const std::shared_ptr<void>& network, const std::vector<Image>& prompt_images,
                                     const std::vector<Image>& prompt_masks, const Image& target,
                                     const std::string& type);

}  // namespace freeloc::networks
