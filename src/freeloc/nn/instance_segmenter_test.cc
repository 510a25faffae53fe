#include "freeloc/nn/instance_segmenter.h"

#include <gtest/gtest.h>

#include "freeloc/io/image_io.h"
#include "testing/testing.h"

namespace freeloc::nn {
namespace {

TEST(InstanceSegmenter, BatchedInstancesEqualSinglePrompts) {
  FREELOC_REQUIRE_SHARED("fixtures/seggpt/images/a_instance/target_image.png");
  const auto model = SegGptModel::Load(testing::SharedPath("fixtures/seggpt/weights.safetensors"),
                                       testing::SharedPath("fixtures/seggpt/config.json"));
  const std::string dir = testing::SharedPath("fixtures/seggpt/images/a_instance/");
  const Image ref = ReadImage(dir + "prompt_image_0.png"), query = ReadImage(dir + "target_image.png");
  const Image mask_rgb = ReadImage(dir + "prompt_mask_0.png");
  std::vector<uint8_t> m1(ref.num_pixels()), m2(ref.num_pixels(), 0);
  for (size_t i = 0; i < m1.size(); ++i) m1[i] = mask_rgb.data[3 * i] > 127;
  for (int y = 10; y < 40; ++y)
    for (int x = 5; x < 30; ++x) m2[static_cast<size_t>(y) * ref.width + x] = 1;
  InstanceSegmenterOptions o;
  o.min_score = 0;
  o.min_area_ratio = 0;
  o.max_area_ratio = 1e9;
  const InstanceSegmenter seg(model, o);
  const auto both = seg.Propagate(ref, {{1, m1}, {2, m2}}, query);
  ASSERT_EQ(both.size(), 2u);
  // The first instance equals SegGPT's own single-prompt result (the fixture's case a).
  const SegGptMask single = model->Segment({ref}, {mask_rgb}, query);
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
