#include "freeloc/nn/instance_segmenter.h"

#include <gtest/gtest.h>

#include "freeloc/io/image_io.h"
#include "testing/testing.h"

namespace freeloc::nn {
namespace {

TEST(InstanceSegmenter, BatchedInstancesEqualSinglePrompts) {
  // freeloc's own tiny SegGPT (written by the build) on two bundled TUM frames with two rectangular instances.
  const auto model = SegGptModel::Load(testing::TinyModelPath("seggpt/model.safetensors"),
                                       testing::TinyModelPath("seggpt/config.json"));
  const Image ref = io::ReadImage(testing::DemoPath("val/s00001/seq0/frame_00000.png"));
  const Image query = io::ReadImage(testing::DemoPath("val/s00001/seq1/frame_00000.png"));
  Image mask_rgb(ref.width, ref.height);
  std::vector<uint8_t> m1(ref.num_pixels(), 0), m2(ref.num_pixels(), 0);
  for (int y = 120; y < 320; ++y)
    for (int x = 200; x < 420; ++x) {
      m1[static_cast<size_t>(y) * ref.width + x] = 1;
      for (int c = 0; c < 3; ++c) mask_rgb.pixel(x, y)[c] = 255;
    }
  for (int y = 10; y < 40; ++y)
    for (int x = 5; x < 30; ++x) m2[static_cast<size_t>(y) * ref.width + x] = 1;
  InstanceSegmenterOptions o;
  o.min_score = 0;
  o.min_area_ratio = 0;
  o.max_area_ratio = 1e9;
  const InstanceSegmenter seg(model, o);
  const auto both = seg.Propagate(ref, {{1, m1}, {2, m2}}, query);
  ASSERT_EQ(both.size(), 2u);
  // The first instance equals SegGPT's own single-prompt result.
  const vision::SegGptMask single = model->Segment({ref}, {mask_rgb}, query);
  EXPECT_EQ(both[0].query_mask, single.mask);
  EXPECT_EQ(both[0].id, 1);
  // Batching does not mix instances: instance 2 alone gives the same mask as in the batch.
  const auto alone = seg.Propagate(ref, {{2, m2}}, query);
  EXPECT_EQ(alone[0].query_mask, both[1].query_mask);
  EXPECT_GE(both[0].score, 0.0);
  EXPECT_LE(both[0].score, 1.0);
}

}  // namespace
}  // namespace freeloc::nn
