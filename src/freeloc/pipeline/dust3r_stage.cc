#include "freeloc/pipeline/dust3r_stage.h"

#include <cstring>

#include "freeloc/nn/dust3r.h"

namespace freeloc::pipeline {

namespace {
matching::PairPointmaps ToHost(const nn::Dust3rPrediction& p, const Dust3rInput& a, const Dust3rInput& b) {
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
}

nn::Dust3rView ViewOf(const Dust3rInput& in) { return {in.normalized.data(), in.height(), in.width()}; }

uint64_t Fnv1a(const void* data, size_t bytes) {
  uint64_t h = 1469598103934665603ull;
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}
}  // namespace

matching::PointmapFn Dust3rPointmapFn(std::shared_ptr<nn::Dust3rModel> model) {
  return [model](const Dust3rInput& a, const Dust3rInput& b) { return ToHost(model->Run(ViewOf(a), ViewOf(b)), a, b); };
}

struct CachingDust3r::Entry {
  uint64_t hash = 0;
  int h = 0, w = 0;
  std::vector<float> data;
  std::shared_ptr<const nn::Dust3rModel::Encoding> encoding;
};

CachingDust3r::CachingDust3r(std::shared_ptr<nn::Dust3rModel> model) : model_(std::move(model)) {}
CachingDust3r::~CachingDust3r() = default;

void CachingDust3r::Clear() { entries_.clear(); }

matching::PairPointmaps CachingDust3r::Run(const Dust3rInput& a, const Dust3rInput& b) {
  const size_t bytes = a.normalized.size() * sizeof(float);
  const uint64_t hash = Fnv1a(a.normalized.data(), bytes);
  const Entry* hit = nullptr;
  for (const auto& e : entries_)
    if (e->hash == hash && e->h == a.height() && e->w == a.width() && e->data.size() == a.normalized.size() &&
        std::memcmp(e->data.data(), a.normalized.data(), bytes) == 0) {
      hit = e.get();
      break;
    }
  if (hit) {
    ++reused_;
  } else {
    auto e = std::make_unique<Entry>();
    e->hash = hash;
    e->h = a.height();
    e->w = a.width();
    e->data = a.normalized;
    e->encoding = model_->Encode(ViewOf(a));
    hit = e.get();
    entries_.push_back(std::move(e));
    ++encoded_;
  }
  // (reference, reference), as for the instance proposals: the query side is that same encoding.
  const auto query = &a == &b ? hit->encoding : model_->Encode(ViewOf(b));
  return ToHost(model_->Decode(*hit->encoding, *query), a, b);
}

matching::PointmapFn CachingDust3r::Fn() {
  return [this](const Dust3rInput& a, const Dust3rInput& b) { return Run(a, b); };
}


}  // namespace freeloc::pipeline
