#include "freeloc/networks/dust3r_stage.h"

#include <cstring>

#include "freeloc/core/error.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/runtime.h"

namespace freeloc::networks {

namespace {
matching::PairPointmaps ToHost(const nn::Dust3rPrediction& p, const vision::Dust3rInput& a,
                               const vision::Dust3rInput& b) {
  matching::PairPointmaps pm;
  pm.pts1.assign(p.pts3d_1.as<float>(), p.pts3d_1.as<float>() + p.pts3d_1.numel());
  pm.conf1.assign(p.conf_1.as<float>(), p.conf_1.as<float>() + p.conf_1.numel());
  pm.pts2.assign(p.pts3d_2.as<float>(), p.pts3d_2.as<float>() + p.pts3d_2.numel());
  pm.conf2.assign(p.conf_2.as<float>(), p.conf_2.as<float>() + p.conf_2.numel());
  pm.h1 = a.height();
  pm.w1 = a.width();
  pm.h2 = b.height();
  pm.w2 = b.width();
  if (p.desc_1.nbytes && p.desc_2.nbytes) {
    pm.desc_dim = static_cast<int>(p.desc_1.shape.back());
    pm.desc1.assign(p.desc_1.as<float>(), p.desc_1.as<float>() + p.desc_1.numel());
    pm.desc2.assign(p.desc_2.as<float>(), p.desc_2.as<float>() + p.desc_2.numel());
    pm.desc_conf1.assign(p.desc_conf_1.as<float>(), p.desc_conf_1.as<float>() + p.desc_conf_1.numel());
    pm.desc_conf2.assign(p.desc_conf_2.as<float>(), p.desc_conf_2.as<float>() + p.desc_conf_2.numel());
  }
  return pm;
}

nn::Dust3rView ViewOf(const vision::Dust3rInput& in) { return {in.normalized.data(), in.height(), in.width()}; }

uint64_t Fnv1a(const void* data, size_t bytes) {
  uint64_t h = 1469598103934665603ull;
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}
}  // namespace

nn::DecodeOutputs Outputs(bool descriptors) {
  nn::DecodeOutputs o;
  o.descriptors = descriptors;
  return o;
}

matching::PointmapFn Dust3rPointmapFn(std::shared_ptr<nn::Dust3rModel> model, bool descriptors) {
  return [model, descriptors](const vision::Dust3rInput& a, const vision::Dust3rInput& b) {
    const auto ea = model->Encode(ViewOf(a));
    const auto eb = model->Encode(ViewOf(b));
    return ToHost(model->Decode(*ea, *eb, Outputs(descriptors)), a, b);
  };
}

struct CachingDust3r::Entry {
  uint64_t hash = 0;
  int h = 0, w = 0;
  std::vector<float> data;
  std::shared_ptr<const nn::Dust3rModel::Encoding> encoding;
};

CachingDust3r::CachingDust3r(std::shared_ptr<nn::Dust3rModel> model, bool descriptors)
    : model_(std::move(model)), descriptors_(descriptors) {}
CachingDust3r::~CachingDust3r() = default;

void CachingDust3r::Clear() {
  entries_.clear();
  last_ref_.reset();
  last_query_.reset();
}

matching::PairPointmaps CachingDust3r::RunSwappedLast() {
  FREELOC_CHECK(last_ref_ && last_query_, "CachingDust3r::RunSwappedLast before Run");
  using Enc = nn::Dust3rModel::Encoding;
  nn::DecodeOutputs only1;
  only1.view2 = false;
  only1.descriptors = false;
  matching::PairPointmaps pm;
  nn::BeginNetworkPass(model_.get());
  {
    const nn::Dust3rPrediction p = model_->Decode(*std::static_pointer_cast<const Enc>(last_query_),
                                                  *std::static_pointer_cast<const Enc>(last_ref_), only1);
    pm.pts1.assign(p.pts3d_1.as<float>(), p.pts3d_1.as<float>() + p.pts3d_1.numel());
    pm.conf1.assign(p.conf_1.as<float>(), p.conf_1.as<float>() + p.conf_1.numel());
  }
  pm.h1 = last_h_;
  pm.w1 = last_w_;
  nn::ReleaseFreedMemory(model_.get());  // as after Run, once the prediction's tensors are gone
  return pm;
}

void CachingDust3r::Prime(const vision::Dust3rInput& ref) {
  nn::BeginNetworkPass(model_.get());
  Cached(ref);
}

const CachingDust3r::Entry* CachingDust3r::Cached(const vision::Dust3rInput& a) {
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
  return hit;
}

matching::PairPointmaps CachingDust3r::Run(const vision::Dust3rInput& a, const vision::Dust3rInput& b) {
  nn::BeginNetworkPass(model_.get());
  const Entry* hit = Cached(a);
  // (reference, reference), as for the instance proposals: the query side is that same encoding.
  const auto query = &a == &b ? hit->encoding : model_->Encode(ViewOf(b));
  last_ref_ = hit->encoding;
  last_query_ = query;
  last_h_ = b.height();
  last_w_ = b.width();
  matching::PairPointmaps pm = ToHost(model_->Decode(*hit->encoding, *query, Outputs(descriptors_)), a, b);
  // The pass's freed activations back to the system (nn::ReleaseFreedMemory): glibc would keep them as fragmented
  // free space in its heap, resident between queries. The tensor pool keeps its cache for this model's next pass.
  nn::ReleaseFreedMemory(model_.get());
  return pm;
}

matching::PointmapFn CachingDust3r::Fn() {
  return [this](const vision::Dust3rInput& a, const vision::Dust3rInput& b) { return Run(a, b); };
}

}  // namespace freeloc::networks
