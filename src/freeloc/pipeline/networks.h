// The networks module (libfreeloc_networks.so, src/freeloc/networks/): every stage and command that runs a network —
// the DUSt3R/MASt3R matchers with SegGPT instances, Metric3D depth, and the work of `freeloc pointmap / segment /
// depth`. It is the only part above nn/ that links LibTorch, and it is loaded on first use (core/module_loader.h):
// presets and commands that use no network never load LibTorch (`freeloc --version` and `pose` start in
// milliseconds). A program that links freeloc::networks has it loaded already; the table is the same. Light header.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/image.h"
#include "freeloc/io/tensor.h"
#include "freeloc/nn/runtime.h"
#include "freeloc/pipeline/stages.h"

namespace freeloc::pipeline {

// `freeloc pointmap`: DUSt3R/MASt3R pointmaps of an image pair (and matches) written as safetensors.
struct PointmapCommand {
  std::string model, config, out;
  int size1 = 512, size2 = 512;     // load_images size of each image
  std::vector<std::string> images;  // exactly two
  bool matches = false;
  double conf_thr = 0;
  int subsample = 0;  // 0: the model's default (DUSt3R 1, MASt3R 8)
  int border = 3;
  nn::RuntimeOptions runtime;
};

// `freeloc segment`: SegGPT segmentation of a target like the prompts.
struct SegmentCommand {
  std::string model, config, target, out, raw, type = "instance";
  std::vector<std::string> prompt_images, prompt_masks;
  nn::RuntimeOptions runtime;
};

// `freeloc depth`: Metric3D v2 depth of one image.
struct DepthCommand {
  std::string model, config, image, intrinsics, out, raw;
  nn::RuntimeOptions runtime;
};

// The networks one by one, for the bindings (Python's Dust3r, Metric3D, SegGPT): a handle from load_network, results
// as named host tensors (the names `freeloc pointmap` and `freeloc depth --raw` write).
enum class BoundNetwork { kDust3r, kMetric3d, kSegGpt };
using NamedTensors = std::vector<std::pair<std::string, io::TensorView>>;

struct NetworksApi {
  int abi;  // kNetworksAbi of the build that made the module
  // The matchers `dust3r`, `dust3r+instances`, `mast3r`, `mast3r+instances` (options validated).
  std::unique_ptr<Matcher> (*make_matcher)(const PipelineOptions& options);
  // The depth stage `metric3d`.
  std::unique_ptr<DepthEstimator> (*make_depth_estimator)(const PipelineOptions& options);
  // The commands' work; each prints its one-line summary and returns the exit code.
  int (*pointmap)(const PointmapCommand& command);
  int (*segment)(const SegmentCommand& command);
  int (*depth)(const DepthCommand& command);
  // The bindings' networks (networks/bindings.h). `type` of run_segment: "instance" | "semantic".
  std::shared_ptr<void> (*load_network)(BoundNetwork kind, const std::string& path, const std::string& config,
                                        const nn::RuntimeOptions& runtime);
  std::string (*network_family)(const std::shared_ptr<void>& network);  // "DUSt3R", "MASt3R", "Metric3D", "SegGPT"
  NamedTensors (*run_pointmaps)(const std::shared_ptr<void>& network, const Image& image_1, const Image& image_2,
                                int size);
  NamedTensors (*run_depth)(const std::shared_ptr<void>& network, const Image& image, const Camera& camera);
  std::vector<uint8_t> (*run_segment)(const std::shared_ptr<void>& network, const std::vector<Image>& prompt_images,
                                      const std::vector<Image>& prompt_masks, const Image& target,
                                      const std::string& type);
};
// Raised whenever the table or a type it passes changes layout (3: PipelineOptions in parts, sprt_min_matches).
constexpr int kNetworksAbi = 3;
constexpr const char* kNetworksLibrary = "libfreeloc_networks.so";
constexpr const char* kNetworksEntry = "freeloc_networks_v1";

// The module's table, loading it (and LibTorch) on first call. Throws freeloc::Error when it cannot be loaded.
const NetworksApi& Networks();
// Whether the networks module (hence LibTorch) is loaded in this process.
bool NetworksLoaded();

}  // namespace freeloc::pipeline
