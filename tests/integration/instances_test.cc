// Instance knowledge end to end on real photos with the tiny fixture weights (numbers meaningless, the path real):
// DUSt3R pointmap of the TUM reference → reference-instance proposals → SegGPT propagation into the query →
// instance-restricted DUSt3R matching → the Eq. 3 merge.
#include <gtest/gtest.h>

#include "freeloc/io/image_io.h"
#include "freeloc/matching/instance.h"
#include "freeloc/matching/proposals.h"
#include "freeloc/networks/dust3r_stage.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/instance_segmenter.h"
#include "freeloc/vision/dust3r_preprocess.h"
#include "testing/testing.h"

namespace freeloc {
namespace {

TEST(Instances, ProposalsPropagationAndMatchingOnTumPhotos) {
  const auto dust3r = nn::Dust3rModel::Load(testing::TinyModelPath("dust3r_tiny.pth"));
  const auto seggpt = nn::SegGptModel::Load(testing::TinyModelPath("seggpt/model.safetensors"),
                                            testing::TinyModelPath("seggpt/config.json"));
  const std::string s = testing::DemoPath("val/s00001/");
  const Image ref = io::ReadImage(s + "seq0/frame_00000.png"), query = io::ReadImage(s + "seq1/frame_00002.png");
  vision::Dust3rPreprocessOptions po;
  po.size = 224;
  const vision::Dust3rInput a = vision::PreprocessForDust3r(ref, po), b = vision::PreprocessForDust3r(query, po);
  const auto pred =
      dust3r->Run({a.normalized.data(), a.height(), a.width()}, {b.normalized.data(), b.height(), b.width()});
  // Proposals on the reference's own pointmap, mapped to the photo's resolution.
  matching::ProposalOptions prop;
  // Random weights give a noise-like surface: loose thresholds so regions exist; the path, not the quality, is tested.
  prop.depth_jump = 0.5;
  prop.normal_angle_deg = 179;
  const auto labels_net =
      matching::ProposeInstances(pred.pts3d_1.as<float>(), pred.conf_1.as<float>(), a.height(), a.width(), prop);
  const auto labels = matching::ProposalsToImage(labels_net, a);
  ASSERT_EQ(labels.size(), ref.num_pixels());
  std::vector<uint16_t> labels16(labels.begin(), labels.end());
  const auto ref_masks = matching::SplitLabels(labels16);
  ASSERT_FALSE(ref_masks.empty());
  EXPECT_LE(ref_masks.size(), 5u);
  // Propagation into the query.
  nn::InstanceSegmenterOptions so;
  so.min_score = 0;
  so.min_area_ratio = 0;
  so.max_area_ratio = 1e9;
  const auto props = nn::InstanceSegmenter(seggpt, so).Propagate(ref, ref_masks, query);
  ASSERT_EQ(props.size(), ref_masks.size());
  std::vector<matching::InstanceMasks> pairs;
  for (size_t i = 0; i < props.size(); ++i) {
    EXPECT_EQ(props[i].query_mask.size(), query.num_pixels());
    if (props[i].kept) pairs.push_back({props[i].id, ref_masks[i].second, props[i].query_mask});
  }
  // Instance matching with DUSt3R on the masked pairs, then the merge.
  const matching::PointmapFn fn = networks::Dust3rPointmapFn(dust3r);
  matching::InstanceOptions io;
  io.preprocess.size = 224;
  io.min_matches = 1;
  std::vector<matching::InstanceResult> results;
  for (const auto& p : pairs) results.push_back(matching::MatchInstance(ref, query, p, fn, io));
  matching::PairPointmaps gpm = fn(a, b);
  const auto global = matching::GlobalCorrespondences(gpm, a, b, io.match);
  const auto merged = matching::MergeMatches(global, results, pairs, ref.width, ref.height);
  EXPECT_FALSE(merged.empty());
  for (const auto& c : merged) {
    EXPECT_GE(c.ref.x(), -0.5);
    EXPECT_LE(c.ref.x(), ref.width - 0.5);
    EXPECT_GE(c.query.y(), -0.5);
    EXPECT_LE(c.query.y(), query.height - 0.5);
  }
}

}  // namespace
}  // namespace freeloc
