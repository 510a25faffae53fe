#include "freeloc/vision/dust3r_preprocess.h"

#include <gtest/gtest.h>

#include <cstring>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "testing/testing.h"

namespace freeloc::vision {
namespace {

// Every load_images result in the fixture (4 images × sizes 80/128/224/512): crop bytes and true_shape exact.
TEST(Dust3rPreprocess, BitExactOnEveryFixtureEntry) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/preprocess.safetensors");
  const io::SafetensorsFile pre =
      io::SafetensorsFile::Open(testing::SharedPath("fixtures/dust3r/preprocess.safetensors"));
  int checked = 0;
  for (const auto& name : pre.names) {
    const size_t p = name.find(".u8");
    if (p == std::string::npos || name.find(".s") == std::string::npos) continue;
    SCOPED_TRACE(name);
    const std::string key = name.substr(0, name.find('.'));
    const std::string stem = name.substr(0, p);  // img_a.s80
    const int size = std::stoi(stem.substr(stem.find(".s") + 2));
    const Image src = io::ReadImage(testing::SharedPath("fixtures/dust3r/images/" + key + ".png"));
    Dust3rPreprocessOptions o;
    o.size = size;
    const Dust3rInput in = PreprocessForDust3r(src, o);
    const io::TensorView& ref = pre.Get(name);
    const io::TensorView& shape = pre.Get(stem + ".true_shape");
    EXPECT_EQ(shape.as<int32_t>()[0], in.height());
    EXPECT_EQ(shape.as<int32_t>()[1], in.width());
    ASSERT_EQ(ref.shape, (std::vector<int64_t>{in.height(), in.width(), 3}));
    size_t diff = 0;
    for (size_t i = 0; i < ref.nbytes; ++i) diff += in.image.data[i] != ref.data[i];
    EXPECT_EQ(diff, 0u);
    if (pre.tensors.count(stem + ".resized_u8")) {
      const io::TensorView& rs = pre.Get(stem + ".resized_u8");
      EXPECT_EQ(rs.shape[0], in.resized_height);
      EXPECT_EQ(rs.shape[1], in.resized_width);
    }
    ++checked;
  }
  EXPECT_EQ(checked, 15);  // img_b has no 512 entry
}

// The normalised network input of the PNG cases equals the stored view*.img bit for bit.
TEST(Dust3rPreprocess, NormalisedInputMatchesCases) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/cases/png_s80.safetensors");
  struct Case {
    const char* file;
    const char* img1;
    const char* img2;
    int size;
  };
  for (const Case& c : {Case{"png_s80", "img_a", "img_b", 80}, Case{"png_s80_mixed", "img_a", "img_c", 80},
                        Case{"png_s128", "img_a", "img_b", 128}}) {
    SCOPED_TRACE(c.file);
    const io::SafetensorsFile f =
        io::SafetensorsFile::Open(testing::SharedPath(std::string("fixtures/dust3r/cases/") + c.file + ".safetensors"));
    int v = 1;
    for (const char* img : {c.img1, c.img2}) {
      Dust3rPreprocessOptions o;
      o.size = c.size;
      const Dust3rInput in = PreprocessForDust3r(
          io::ReadImage(testing::SharedPath(std::string("fixtures/dust3r/images/") + img + ".png")), o);
      const io::TensorView& ref = f.Get("view" + std::to_string(v) + ".img");
      ASSERT_EQ(ref.shape, (std::vector<int64_t>{1, 3, in.height(), in.width()}));
      EXPECT_EQ(std::memcmp(ref.data, in.normalized.data(), ref.nbytes), 0);
      const io::TensorView& u8 = f.Get("view" + std::to_string(v) + ".img_u8");
      EXPECT_EQ(std::memcmp(u8.data, in.image.data.data(), u8.nbytes), 0);
      ++v;
    }
  }
}

TEST(Dust3rPreprocess, SizesFollowLoadImagesRules) {
  int w, h;
  bool lanczos;
  Dust3rPreprocessOptions o;
  o.size = 80;
  Dust3rResizedSize(160, 105, o, &w, &h, &lanczos);
  EXPECT_EQ(h, 52);  // 52.5 rounds half to even
  EXPECT_TRUE(lanczos);
  o.size = 512;
  Dust3rResizedSize(640, 480, o, &w, &h, &lanczos);
  EXPECT_EQ(w, 512);
  EXPECT_EQ(h, 384);
  o.size = 224;
  Dust3rResizedSize(160, 120, o, &w, &h, &lanczos);
  EXPECT_EQ(w, 299);
  EXPECT_EQ(h, 224);
  EXPECT_FALSE(lanczos);
  // Square images at 512 become 512×384; with square_ok they stay square.
  Image sq(600, 600);
  EXPECT_EQ(PreprocessForDust3r(sq).height(), 384);
  o = {};
  o.square_ok = true;
  EXPECT_EQ(PreprocessForDust3r(sq, o).height(), 512);
  // Typical shapes.
  EXPECT_EQ(PreprocessForDust3r(Image(1920, 1080)).height(), 288);
  EXPECT_EQ(PreprocessForDust3r(Image(480, 640)).width(), 384);
}

TEST(Dust3rPreprocess, RejectsBadSizes) {
  Dust3rPreprocessOptions o;
  o.size = 500;
  EXPECT_THROW(PreprocessForDust3r(Image(64, 48), o), Error);
  o.size = 0;
  EXPECT_THROW(o.Validate(), Error);
  EXPECT_THROW(PreprocessForDust3r(Image()), Error);
}

TEST(Dust3rPreprocess, PixelMappingRoundTrip) {
  // 1000×700 at 512: resized 512×358, cropped to 512×352 (3 rows off the top).
  const Dust3rInput in = PreprocessForDust3r(Image(1000, 700));
  EXPECT_EQ(in.resized_height, 358);
  EXPECT_EQ(in.crop_y, 3);
  double xo, yo, xn, yn;
  in.ToOriginal(0, 0, &xo, &yo);
  in.ToNetwork(xo, yo, &xn, &yn);
  EXPECT_NEAR(xn, 0, 1e-12);
  EXPECT_NEAR(yn, 0, 1e-12);
  // The exact image centre maps to the exact centre (pixel-centre convention).
  in.ToOriginal(255.5, 175.5 - 0.0, &xo, &yo);
  EXPECT_NEAR(xo, 499.5, 1e-9);
  in.ToNetwork(499.5, 349.5, &xn, &yn);
  EXPECT_NEAR(xn, 255.5, 1e-9);
  EXPECT_NEAR(yn, 358.0 / 2 - 0.5 - 3, 1e-9);
}

}  // namespace
}  // namespace freeloc::vision
