// Per-process model caches of the networks module: each network is loaded once per (path, config, runtime) and kept
// for the process, so a run loads each network once. Light header: the LibTorch models stay behind forward
// declarations.
#pragma once

#include <memory>
#include <string>

namespace freeloc::nn {
class Dust3rModel;
class SegGptModel;
class Metric3dModel;
struct RuntimeOptions;
}  // namespace freeloc::nn

namespace freeloc::networks {

// Loaded on first use and kept for the process (keyed by path, config and runtime), so a run loads each network
// once. `config`: an explicit config.json (optional). Throw freeloc::Error naming the file.
std::shared_ptr<nn::Dust3rModel> CachedDust3r(const std::string& path, const std::string& config,
                                              const nn::RuntimeOptions& runtime);
std::shared_ptr<nn::SegGptModel> CachedSegGpt(const std::string& path, const nn::RuntimeOptions& runtime);
std::shared_ptr<nn::Metric3dModel> CachedMetric3d(const std::string& path, const nn::RuntimeOptions& runtime);

}  // namespace freeloc::networks
