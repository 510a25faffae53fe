#include "freeloc/networks/dust3r_stage.h"

#include <gtest/gtest.h>

#include "freeloc/io/image_io.h"
#include "freeloc/nn/dust3r.h"
#include "testing/testing.h"

namespace freeloc::networks {
namespace {

// The caching function encodes each distinct reference input once and gives the pointmaps of the one-shot path.
TEST(CachingDust3r, ReusesReferenceEncodingsAndMatchesTheOneShotPath) {
  const auto model = nn::Dust3rModel::Load(testing::TinyModelPath("dust3r_tiny.pth"));
  const std::string s = testing::DemoPath("val/s00001/");
  vision::Dust3rPreprocessOptions po;
  po.size = 224;
  const vision::Dust3rInput ref = vision::PreprocessForDust3r(io::ReadImage(s + "seq0/frame_00000.png"), po);
  const vision::Dust3rInput q1 = vision::PreprocessForDust3r(io::ReadImage(s + "seq1/frame_00000.png"), po);
  const vision::Dust3rInput q2 = vision::PreprocessForDust3r(io::ReadImage(s + "seq1/frame_00004.png"), po);
  vision::Dust3rInput ref_copy = ref;  // same content, other object: still a hit
  vision::Dust3rInput other = ref;
  other.normalized[12345] += 0.01f;  // one value differs: a miss

  CachingDust3r cache(model);
  const auto plain = Dust3rPointmapFn(model);
  const auto fn = cache.Fn();
  for (const vision::Dust3rInput* q : {&q1, &q2}) {
    const auto a = fn(ref_copy, *q), b = plain(ref, *q);
    ASSERT_EQ(a.pts2.size(), b.pts2.size());
    ASSERT_EQ(a.h1, b.h1);
    double worst = 0;
    for (size_t i = 0; i < a.pts2.size(); ++i) worst = std::max(worst, std::abs(double(a.pts2[i]) - b.pts2[i]));
    for (size_t i = 0; i < a.conf1.size(); ++i) worst = std::max(worst, std::abs(double(a.conf1[i]) - b.conf1[i]));
    EXPECT_LT(worst, 1e-4);
  }
  EXPECT_EQ(cache.encoded(), 1);
  EXPECT_EQ(cache.reused(), 1);
  fn(other, q1);
  EXPECT_EQ(cache.encoded(), 2);
  fn(ref, q2);
  EXPECT_EQ(cache.reused(), 2);
  cache.Clear();
  fn(ref, q1);
  EXPECT_EQ(cache.encoded(), 3);
}

}  // namespace
}  // namespace freeloc::networks
