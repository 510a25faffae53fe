// The network stages behind pipeline::MakeMatcher / MakeDepthEstimator (pipeline/stages.h), built into the networks
// module (pipeline/networks.h) so that only presets that run a network load LibTorch.
#include "freeloc/networks/network_stages.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/timing.h"
#include "freeloc/geometry/focal_from_pointmap.h"
#include "freeloc/matching/instance.h"
#include "freeloc/matching/proposals.h"
#include "freeloc/networks/dust3r_stage.h"
#include "freeloc/networks/model_cache.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/instance_segmenter.h"
#include "freeloc/nn/metric3d.h"
#include "freeloc/nn/seggpt.h"

namespace freeloc::networks {

using namespace freeloc::pipeline;  // NOLINT: the networks module implements the pipeline's stages

namespace {

// DUSt3R global matches; with instances, the paper's instance knowledge on top (Eq. 1–3): reference instances
// (given labels, or proposals from the reference's own pointmap) matched into the query (SegGPT propagation, or the
// query's given labels), DUSt3R re-run per masked pair, instance matches replacing the global ones inside them.
class Dust3rMatcher : public Matcher {
 public:
  Dust3rMatcher(const PipelineOptions& o, std::shared_ptr<nn::Dust3rModel> dust3r,
                std::shared_ptr<nn::SegGptModel> seggpt)
      : o_(o), fn_(dust3r, o.UsesMast3r()), seggpt_(std::move(seggpt)) {
    FREELOC_CHECK(!o.UsesMast3r() || dust3r->config().is_mast3r(),
                  "mast3r_model " << o.models.mast3r_model
                                  << ": a DUSt3R checkpoint (no local-feature head); give the MASt3R weights "
                                     "(MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric.pth)");
    instance_.mode = o.instances.instance_mode;
    instance_.preprocess.size = o.pointmap.dust3r_size;
    instance_.match.conf_threshold = o.pointmap.match_conf_threshold;
    instance_.match.subsample = o.pointmap.match_subsample;
    instance_.match.threads = o.runtime.threads;
    instance_.descriptors = o.UsesMast3r();
    instance_.fast_nn.subsample = o.pointmap.mast3r_subsample;
    instance_.fast_nn.threads = o.runtime.threads;
    instance_.descriptor_filter.border = o.pointmap.mast3r_border;
    instance_.descriptor_filter.min_conf = o.pointmap.mast3r_conf_threshold;
    instance_.min_matches = o.instances.min_instance_matches;
    instance_.Validate();
  }

  void SetReference(const Image& image, const Camera&, const std::vector<uint16_t>* labels) override {
    ref_ = image;
    fn_.Clear();
    have_last_ = have_swapped_ = false;
    ref_focal_ = -1;
    ref_in_ = vision::PreprocessForDust3r(image, instance_.preprocess);
    ref_masks_.clear();
    fn_.Prime(ref_in_);  // the reference's encoder pass, once per scene
    if (!o_.UsesInstances()) return;
    if (labels) {
      CheckLabels(*labels, image, "reference");
      ref_masks_ = matching::SplitLabels(*labels);
    } else if (o_.UsesSegGpt()) {
      // Reference instances from the reference's own pointmap: DUSt3R on (reference, reference), its monocular
      // convention; the encoder pass is the one every query reuses.
      const matching::PairPointmaps pm = fn_.Run(ref_in_, ref_in_);
      const auto proposals =
          matching::ProposeInstances(pm.pts1.data(), pm.conf1.data(), pm.h1, pm.w1, o_.instances.proposals);
      ref_masks_ = matching::SplitLabels(matching::ProposalsToImage(proposals, ref_in_));
    }
    // The reference side of every instance's masked pair, encoded once here (queries reuse them).
    for (const auto& [id, mask] : ref_masks_)
      if (std::count(mask.begin(), mask.end(), 1) >= instance_.min_mask_pixels)
        fn_.Prime(matching::InstanceReferenceInput(image, mask, instance_));
  }

  matching::Correspondences Match(const Image& query, const Camera&, const FrameInputs& in, QueryResult* r) override {
    auto t0 = std::chrono::steady_clock::now();
    q_in_ = vision::PreprocessForDust3r(query, instance_.preprocess);
    const vision::Dust3rInput& q_in = q_in_;
    const auto tp = std::chrono::steady_clock::now();
    last_ = fn_.Fn()(ref_in_, q_in);
    r->timings.pair_ms = MsSince(tp);
    have_last_ = true;
    have_swapped_ = false;
    swapped_ms_ = 0;
    std::vector<matching::Correspondence> merged = matching::GlobalCorrespondences(last_, ref_in_, q_in, instance_);
    r->global_matches = static_cast<int>(merged.size());
    r->timings.match_ms = MsSince(t0);
    if (o_.UsesInstances() && !ref_masks_.empty()) {
      t0 = std::chrono::steady_clock::now();
      merged = MatchInstances(query, in, merged, r);
      r->timings.instance_ms = MsSince(t0);
    }
    matching::Correspondences c;
    for (const auto& m : merged) {
      c.ref.push_back(m.ref);
      c.query.push_back(m.query);
      c.source.push_back(m.source);
    }
    return c;
  }

  bool PairDepth(bool with_query, DepthMap* ref, DepthMap* query) override {
    if (!o_.UsesMast3r() || !have_last_) return false;
    *ref = NetworkDepthToImage(last_.pts1, last_.h1, last_.w1, ref_in_);
    *query = DepthMap();
    if (with_query) {
      const matching::PairPointmaps& sw = Swapped();
      *query = NetworkDepthToImage(sw.pts1, sw.h1, sw.w1, q_in_);
    }
    return true;
  }

  double ReferenceFocal() override {
    if (ref_focal_ < 0) {
      // The reference's own pointmap from its (reference, reference) pass — the encoder pass is the cached one.
      const matching::PairPointmaps pm = fn_.Run(ref_in_, ref_in_);
      ref_focal_ = FocalOfOwnPointmap(pm.pts1, pm.h1, pm.w1, ref_in_);
    }
    return ref_focal_;
  }

  double own_pass_ms() const override { return swapped_ms_; }

  double QueryFocal() override {
    if (!have_last_) return 0;
    const matching::PairPointmaps& sw = Swapped();
    return FocalOfOwnPointmap(sw.pts1, sw.h1, sw.w1, q_in_);
  }

  void AddStats(CacheStats* s) const override {
    s->reference_encodings = fn_.encoded();
    s->reference_reuses = fn_.reused();
    s->reference_instances = static_cast<int>(ref_masks_.size());
  }

 private:
  // The last pair swapped (the query as view 1: its points in its own frame), run once per Match.
  const matching::PairPointmaps& Swapped() {
    if (!have_swapped_) {
      const auto t0 = std::chrono::steady_clock::now();
      swapped_ = fn_.RunSwappedLast();
      swapped_ms_ = MsSince(t0);
      have_swapped_ = true;
    }
    return swapped_;
  }

  // The focal (original pixels, principal point at the original image's centre) of view 1's own pointmap at network
  // resolution: each network pixel is placed where it lies in the original image (the pixel-centre mapping of
  // docs/architecture.md §2), so the resize and crop need no separate correction.
  static double FocalOfOwnPointmap(const std::vector<float>& pts, int h, int w, const vision::Dust3rInput& in) {
    std::vector<Eigen::Vector2d> pixels;
    std::vector<Eigen::Vector3d> points;
    pixels.reserve(static_cast<size_t>(h) * w);
    points.reserve(static_cast<size_t>(h) * w);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float* p = &pts[(static_cast<size_t>(y) * w + x) * 3];
        double xo, yo;
        in.ToOriginal(x, y, &xo, &yo);
        pixels.emplace_back(xo, yo);
        points.emplace_back(p[0], p[1], p[2]);
      }
    return geometry::FocalFromPointmap(pixels, points, {(in.orig_width - 1) / 2.0, (in.orig_height - 1) / 2.0});
  }

  // z of a network-resolution pointmap (view 1's own camera frame) at every pixel of the original image: the network
  // pixel nearest to each original pixel (the pixel-centre mapping of docs/architecture.md §2); 0 outside the crop or
  // behind the camera.
  static DepthMap NetworkDepthToImage(const std::vector<float>& pts, int h, int w, const vision::Dust3rInput& in) {
    DepthMap d(in.orig_width, in.orig_height);
    for (int y = 0; y < d.height; ++y)
      for (int x = 0; x < d.width; ++x) {
        double xn, yn;
        in.ToNetwork(x, y, &xn, &yn);
        const long xi = std::lround(xn), yi = std::lround(yn);
        if (xi < 0 || yi < 0 || xi >= w || yi >= h) continue;
        const float z = pts[(static_cast<size_t>(yi) * w + static_cast<size_t>(xi)) * 3 + 2];
        if (z > 0 && std::isfinite(z)) d.at(x, y) = z;
      }
    return d;
  }

  static void CheckLabels(const std::vector<uint16_t>& labels, const Image& image, const char* frame) {
    FREELOC_CHECK(labels.size() == static_cast<size_t>(image.width) * image.height,
                  "instance labels of the " << frame << ": " << labels.size() << " values for a " << image.width << "x"
                                            << image.height << " image; give a label image at the photo's resolution");
  }

  // The (reference, query) mask pairs: the query's given labels with the same ids, or SegGPT's propagations.
  std::vector<matching::InstanceMasks> InstancePairs(const Image& query, const FrameInputs& in) const {
    std::vector<matching::InstanceMasks> pairs;
    if (o_.instances.instance_source == InstanceSource::kGiven) {
      FREELOC_CHECK(in.instance_labels != nullptr,
                    "instance_source given: the query has no instance labels; give a label image for each frame");
      CheckLabels(*in.instance_labels, query, "query");
      for (const auto& [id, mq] : matching::SplitLabels(*in.instance_labels))
        for (const auto& [idr, mr] : ref_masks_)
          if (id == idr) pairs.push_back({id, mr, mq});
      return pairs;
    }
    nn::BeginNetworkPass(seggpt_.get());
    const auto props = nn::InstanceSegmenter(seggpt_, o_.instances.segmenter).Propagate(ref_, ref_masks_, query);
    nn::ReleaseFreedMemory(seggpt_.get());  // as after each pair pass (CachingDust3r::Run)
    for (size_t i = 0; i < props.size(); ++i)
      if (props[i].kept) pairs.push_back({props[i].id, ref_masks_[i].second, props[i].query_mask});
    return pairs;
  }

  // Re-runs DUSt3R on each masked pair; the instances with enough matches replace the global ones inside them.
  std::vector<matching::Correspondence> MatchInstances(const Image& query, const FrameInputs& in,
                                                       const std::vector<matching::Correspondence>& global,
                                                       QueryResult* r) {
    const auto ts = std::chrono::steady_clock::now();
    const std::vector<matching::InstanceMasks> pairs = InstancePairs(query, in);
    r->timings.segment_ms = o_.instances.instance_source == InstanceSource::kGiven ? 0.0 : MsSince(ts);
    // The masked pairs' network passes, timed and counted.
    const matching::PointmapFn model = fn_.Fn();
    const matching::PointmapFn timed = [&](const vision::Dust3rInput& a, const vision::Dust3rInput& b) {
      const auto t0 = std::chrono::steady_clock::now();
      matching::PairPointmaps pm = model(a, b);
      r->timings.instance_pass_ms += MsSince(t0);
      ++r->timings.instance_pairs;
      return pm;
    };
    std::vector<matching::InstanceResult> results;
    for (const auto& p : pairs) {
      results.push_back(matching::MatchInstance(ref_, query, p, timed, instance_));
      r->instances_used += results.back().used;
      if (!results.back().used) FREELOC_LOG(DEBUG) << "instance " << p.id << " not used: " << results.back().reason;
    }
    r->instances = o_.instances.instance_source == InstanceSource::kGiven ? static_cast<int>(pairs.size())
                                                                          : static_cast<int>(ref_masks_.size());
    return matching::MergeMatches(global, results, pairs, ref_.width, ref_.height);
  }

  PipelineOptions o_;
  CachingDust3r fn_;
  std::shared_ptr<nn::SegGptModel> seggpt_;
  matching::InstanceOptions instance_;
  Image ref_;
  vision::Dust3rInput ref_in_, q_in_;
  matching::PairPointmaps last_;  // the last query's global pass (MASt3R depth comes from it)
  bool have_last_ = false;
  matching::PairPointmaps swapped_;  // … and its swapped pass, when asked for (the query's own pointmap)
  bool have_swapped_ = false;
  double swapped_ms_ = 0;  // the swapped pass's time since the last Match
  double ref_focal_ = -1;  // the reference's pointmap focal (-1: not estimated yet)
  std::vector<std::pair<int, std::vector<uint8_t>>> ref_masks_;  // 0/1 at the reference's resolution
};
class Metric3dDepth : public DepthEstimator {
 public:
  explicit Metric3dDepth(std::shared_ptr<nn::Metric3dModel> m) : model_(std::move(m)) {}
  DepthMap Depth(const Image& image, const Camera& camera, DepthMap) override {
    ++passes_;
    nn::BeginNetworkPass(model_.get());
    DepthMap d = model_->Estimate(image, camera).depth;
    nn::ReleaseFreedMemory(model_.get());  // as after each pair pass (CachingDust3r::Run)
    return d;
  }
  void AddStats(CacheStats* s) const override { s->depth_estimates = passes_; }

 private:
  std::shared_ptr<nn::Metric3dModel> model_;
  int passes_ = 0;
};

}  // namespace

std::unique_ptr<Matcher> MakeNetworkMatcher(const PipelineOptions& o) {
  FREELOC_CHECK(o.UsesPointmapModel(), "matcher: " << o.matcher.ToString() << " runs no network");
  return MakeNetworkMatcher(o,
                            o.UsesMast3r() ? CachedDust3r(o.models.mast3r_model, "", o.runtime)
                                           : CachedDust3r(o.models.dust3r_model, o.models.dust3r_config, o.runtime),
                            o.UsesSegGpt() ? CachedSegGpt(o.models.seggpt_model, o.runtime) : nullptr);
}

std::unique_ptr<DepthEstimator> MakeNetworkDepthEstimator(const PipelineOptions& o) {
  FREELOC_CHECK(o.depth.kind == DepthKind::kMetric3d, "depth: " << o.depth.ToString() << " runs no network");
  return MakeNetworkDepthEstimator(CachedMetric3d(o.models.metric3d_model, o.runtime));
}

std::unique_ptr<Matcher> MakeNetworkMatcher(const PipelineOptions& o, std::shared_ptr<nn::Dust3rModel> model,
                                            std::shared_ptr<nn::SegGptModel> seggpt) {
  FREELOC_CHECK(model != nullptr, "MakeNetworkMatcher: no pointmap model given");
  FREELOC_CHECK(!o.UsesSegGpt() || seggpt != nullptr, "MakeNetworkMatcher: the matcher needs SegGPT; none given");
  return std::make_unique<Dust3rMatcher>(o, std::move(model), std::move(seggpt));
}

std::unique_ptr<DepthEstimator> MakeNetworkDepthEstimator(std::shared_ptr<nn::Metric3dModel> model) {
  FREELOC_CHECK(model != nullptr, "MakeNetworkDepthEstimator: no Metric3D model given");
  return std::make_unique<Metric3dDepth>(std::move(model));
}

}  // namespace freeloc::networks
