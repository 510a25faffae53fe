#include "freeloc/networks/bindings.h"

#include "freeloc/core/error.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/metric3d.h"
#include "freeloc/nn/seggpt.h"
#include "freeloc/vision/dust3r_preprocess.h"

namespace freeloc::networks {

using namespace freeloc::pipeline;  // NOLINT: the networks module implements the pipeline's stages

namespace {

// What a handle points to: one network of one kind.
struct Bound {
  BoundNetwork kind;
  std::shared_ptr<nn::Dust3rModel> dust3r;
  std::shared_ptr<nn::Metric3dModel> metric3d;
  std::shared_ptr<nn::SegGptModel> seggpt;
};

const Bound& As(const std::shared_ptr<void>& network, BoundNetwork kind, const char* what) {
  FREELOC_CHECK(network != nullptr, what << ": no network");
  const Bound& b = *static_cast<const Bound*>(network.get());
  FREELOC_CHECK(b.kind == kind, what << ": the handle holds another network");
  return b;
}

}  // namespace

std::shared_ptr<void> LoadBoundNetwork(BoundNetwork kind, const std::string& path, const std::string& config,
                                       const nn::RuntimeOptions& rt) {
  auto b = std::make_shared<Bound>();
  b->kind = kind;
  if (kind == BoundNetwork::kDust3r) b->dust3r = nn::Dust3rModel::Load(path, config, rt);
  if (kind == BoundNetwork::kMetric3d) b->metric3d = nn::Metric3dModel::Load(path, config, rt);
  if (kind == BoundNetwork::kSegGpt) b->seggpt = nn::SegGptModel::Load(path, config, rt);
  return b;
}

std::string BoundNetworkFamily(const std::shared_ptr<void>& network) {
  const Bound& b = *static_cast<const Bound*>(network.get());
  if (b.kind == BoundNetwork::kDust3r) return b.dust3r->config().family();
  return b.kind == BoundNetwork::kMetric3d ? "Metric3D" : "SegGPT";
}

NamedTensors RunBoundPointmaps(const std::shared_ptr<void>& network, const Image& a, const Image& b, int size) {
  const nn::Dust3rModel& m = *As(network, BoundNetwork::kDust3r, "Dust3r").dust3r;
  vision::Dust3rPreprocessOptions po;
  po.size = size;
  const vision::Dust3rInput ia = vision::PreprocessForDust3r(a, po), ib = vision::PreprocessForDust3r(b, po);
  const nn::Dust3rPrediction pr =
      m.Run({ia.normalized.data(), ia.height(), ia.width()}, {ib.normalized.data(), ib.height(), ib.width()});
  NamedTensors t = {{"pts3d_1", pr.pts3d_1},
                    {"conf_1", pr.conf_1},
                    {"pts3d_2", pr.pts3d_2},
                    {"conf_2", pr.conf_2},
                    {"image_1", io::MakeTensor(io::DType::kU8, {ia.height(), ia.width(), 3}, ia.image.data.data(),
                                               ia.image.data.size())},
                    {"image_2", io::MakeTensor(io::DType::kU8, {ib.height(), ib.width(), 3}, ib.image.data.data(),
                                               ib.image.data.size())}};
  if (pr.desc_1.nbytes) {
    t.push_back({"desc_1", pr.desc_1});
    t.push_back({"desc_conf_1", pr.desc_conf_1});
    t.push_back({"desc_2", pr.desc_2});
    t.push_back({"desc_conf_2", pr.desc_conf_2});
  }
  return t;
}

NamedTensors RunBoundDepth(const std::shared_ptr<void>& network, const Image& image, const Camera& camera) {
  const nn::Metric3dModel& m = *As(network, BoundNetwork::kMetric3d, "Metric3D").metric3d;
  const nn::Metric3dOutput o = m.Estimate(image, camera);
  const int64_t h = o.depth.height, w = o.depth.width;
  return {{"depth", io::MakeTensor(io::DType::kF32, {h, w}, o.depth.data.data(), o.depth.data.size() * 4)},
          {"confidence", io::MakeTensor(io::DType::kF32, {h, w}, o.confidence.data(), o.confidence.size() * 4)},
          {"normal", io::MakeTensor(io::DType::kF32, {3, h, w}, o.normal.data(), o.normal.size() * 4)},
          {"canonical_depth", o.canonical_depth}};
}

std::vector<uint8_t> RunBoundSegment(const std::shared_ptr<void>& network, const std::vector<Image>& prompt_images,
                                     const std::vector<Image>& prompt_masks, const Image& target,
                                     const std::string& type) {
  const nn::SegGptModel& m = *As(network, BoundNetwork::kSegGpt, "SegGPT").seggpt;
  return m.Segment(prompt_images, prompt_masks, target, nn::ParseSegType(type)).mask;
}

}  // namespace freeloc::networks
