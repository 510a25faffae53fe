#include "freeloc/vision/resize.h"

#include <gtest/gtest.h>

#include <cstring>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "testing/testing.h"

namespace freeloc::vision {
namespace {

TEST(Resize, ConstantImageStaysConstant) {
  Image im(37, 23);
  std::fill(im.data.begin(), im.data.end(), 77);
  for (auto f : {ResampleFilter::kBilinear, ResampleFilter::kBicubic, ResampleFilter::kLanczos}) {
    for (auto [w, h] : std::vector<std::pair<int, int>>{{10, 7}, {80, 51}, {37, 5}, {3, 23}}) {
      const Image out = PillowResize(im, w, h, f);
      ASSERT_EQ(out.width, w);
      ASSERT_EQ(out.height, h);
      for (uint8_t v : out.data) ASSERT_EQ(v, 77);
    }
  }
}

TEST(Resize, SameSizeIsIdentity) {
  Image im(9, 4);
  for (size_t i = 0; i < im.data.size(); ++i) im.data[i] = static_cast<uint8_t>(i * 13);
  EXPECT_EQ(PillowResize(im, 9, 4, ResampleFilter::kLanczos), im);
}

TEST(Resize, RejectsZeroSize) {
  Image im(4, 4);
  EXPECT_THROW(PillowResize(im, 0, 4, ResampleFilter::kBicubic), Error);
}

// Pillow 9.4 results stored in the fixture (`k.s{S}.resized_u8`, before the crop): bit-exact.
TEST(Resize, BitExactWithPillowFixture) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/preprocess.safetensors");
  const io::SafetensorsFile pre =
      io::SafetensorsFile::Open(testing::SharedPath("fixtures/dust3r/preprocess.safetensors"));
  int checked = 0;
  for (const auto& name : pre.names) {
    const size_t p = name.find(".resized_u8");
    if (p == std::string::npos) continue;
    SCOPED_TRACE(name);
    const std::string key = name.substr(0, name.find('.'));
    const Image src = io::ReadImage(testing::SharedPath("fixtures/dust3r/images/" + key + ".png"));
    const io::TensorView& ref = pre.Get(name);
    const int h = static_cast<int>(ref.shape[0]), w = static_cast<int>(ref.shape[1]);
    const bool lanczos = std::max(src.width, src.height) > std::max(w, h);  // shrinking
    const Image out = PillowResize(src, w, h, lanczos ? ResampleFilter::kLanczos : ResampleFilter::kBicubic);
    ASSERT_EQ(out.data.size(), ref.nbytes);
    size_t diff = 0;
    for (size_t i = 0; i < ref.nbytes; ++i) diff += out.data[i] != ref.data[i];
    EXPECT_EQ(diff, 0u);
    ++checked;
  }
  EXPECT_GE(checked, 8);
}

}  // namespace
}  // namespace freeloc::vision
