#include "freeloc/networks/model_cache.h"

#include <map>
#include <mutex>

#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/metric3d.h"
#include "freeloc/nn/runtime.h"
#include "freeloc/nn/seggpt.h"

namespace freeloc::networks {

namespace {
template <typename Model>
std::shared_ptr<Model> Cached(const std::string& path, const std::string& config, const nn::RuntimeOptions& rt) {
  static std::mutex mu;
  static std::map<std::string, std::shared_ptr<Model>> cache;
  const std::string key = path + "|" + config + "|" + rt.Key();
  std::lock_guard<std::mutex> lock(mu);
  auto& m = cache[key];
  if (!m) {
    m = Model::Load(path, config, rt);
    nn::ReleaseFreedMemory();  // the checkpoint (and, in bf16, the fp32 weights) is gone now
  }
  return m;
}
}  // namespace

std::shared_ptr<nn::Dust3rModel> CachedDust3r(const std::string& path, const std::string& config,
                                              const nn::RuntimeOptions& rt) {
  return Cached<nn::Dust3rModel>(path, config, rt);
}

std::shared_ptr<nn::SegGptModel> CachedSegGpt(const std::string& path, const nn::RuntimeOptions& rt) {
  return Cached<nn::SegGptModel>(path, "", rt);
}

std::shared_ptr<nn::Metric3dModel> CachedMetric3d(const std::string& path, const nn::RuntimeOptions& rt) {
  return Cached<nn::Metric3dModel>(path, "", rt);
}

}  // namespace freeloc::networks
