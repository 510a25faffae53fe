#include "freeloc/pipeline/dust3r_stage.h"

#include <map>
#include <mutex>

#include "freeloc/nn/dust3r.h"

namespace freeloc::pipeline {

matching::PointmapFn Dust3rPointmapFn(std::shared_ptr<nn::Dust3rModel> model) {
  return [model](const Dust3rInput& a, const Dust3rInput& b) {
    const auto p =
        model->Run({a.normalized.data(), a.height(), a.width()}, {b.normalized.data(), b.height(), b.width()});
    matching::PairPointmaps pm;
    pm.pts1.assign(p.pts3d_1.as<float>(), p.pts3d_1.as<float>() + p.pts3d_1.numel());
    pm.conf1.assign(p.conf_1.as<float>(), p.conf_1.as<float>() + p.conf_1.numel());
    pm.pts2.assign(p.pts3d_2.as<float>(), p.pts3d_2.as<float>() + p.pts3d_2.numel());
    pm.conf2.assign(p.conf_2.as<float>(), p.conf_2.as<float>() + p.conf_2.numel());
    pm.h1 = a.height();
    pm.w1 = a.width();
    pm.h2 = b.height();
    pm.w2 = b.width();
    return pm;
  };
}

std::shared_ptr<nn::Dust3rModel> CachedDust3r(const std::string& path, const std::string& config,
                                              const nn::RuntimeOptions& rt) {
  static std::mutex mu;
  static std::map<std::string, std::shared_ptr<nn::Dust3rModel>> cache;
  const std::string key = path + "|" + config + "|" + rt.device + "|" + rt.precision + "|" + std::to_string(rt.threads);
  std::lock_guard<std::mutex> lock(mu);
  auto& m = cache[key];
  if (!m) m = nn::Dust3rModel::Load(path, config, rt);
  return m;
}

}  // namespace freeloc::pipeline
