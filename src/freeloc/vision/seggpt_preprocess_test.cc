#include "freeloc/vision/seggpt_preprocess.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "testing/testing.h"

namespace freeloc::vision {
namespace {

Image FromU8(const io::TensorView& t) {
  Image im(static_cast<int>(t.shape[1]), static_cast<int>(t.shape[0]));
  std::memcpy(im.data.data(), t.data, t.nbytes);
  return im;
}

// Every SegGPT fixture case: the Pillow resizes bit-exact, the network inputs to float rounding, and the
// post-processing from the stored network output to the stored painted map and binary mask.
TEST(SegGptPreprocess, MatchesFixturesFromThePngs) {
  FREELOC_REQUIRE_SHARED("fixtures/seggpt/cases/a_instance.safetensors");
  for (const char* name : {"a_instance", "b_semantic", "c_ensemble", "d_resize_back"}) {
    SCOPED_TRACE(name);
    const io::SafetensorsFile f =
        io::SafetensorsFile::Open(testing::SharedPath(std::string("fixtures/seggpt/cases/") + name + ".safetensors"));
    const std::string dir = testing::SharedPath(std::string("fixtures/seggpt/images/") + name + "/");
    std::vector<Image> pi, pm;
    for (int k = 0; f.tensors.count("prompt_image_" + std::to_string(k)); ++k) {
      pi.push_back(io::ReadImage(dir + "prompt_image_" + std::to_string(k) + ".png"));
      pm.push_back(io::ReadImage(dir + "prompt_mask_" + std::to_string(k) + ".png"));
      EXPECT_EQ(pi.back(), FromU8(f.Get("prompt_image_" + std::to_string(k))));
    }
    const Image target = io::ReadImage(dir + "target_image.png");
    const SegGptInputs in = PrepareSegGptInputs(pi, pm, target, 64);
    EXPECT_EQ(in.target_resized, FromU8(f.Get("target_image_resized")));
    for (int k = 0; k < in.k; ++k) {
      EXPECT_EQ(in.prompt_images_resized[k], FromU8(f.Get("prompt_image_" + std::to_string(k) + "_resized")));
      EXPECT_EQ(in.prompt_masks_resized[k], FromU8(f.Get("prompt_mask_" + std::to_string(k) + "_resized")));
    }
    const io::TensorView& imgs = f.Get("imgs");
    const io::TensorView& tgts = f.Get("tgts");
    ASSERT_EQ(static_cast<size_t>(imgs.numel()), in.imgs.size());
    double worst = 0;
    for (size_t i = 0; i < in.imgs.size(); ++i) {
      worst = std::max(worst, static_cast<double>(std::abs(in.imgs[i] - imgs.as<float>()[i])));
      worst = std::max(worst, static_cast<double>(std::abs(in.tgts[i] - tgts.as<float>()[i])));
    }
    EXPECT_LE(worst, 5e-7);
    // Post-processing from the stored prediction.
    const io::TensorView& th = f.Get("mask");
    const int ht = static_cast<int>(th.shape[0]), wt = static_cast<int>(th.shape[1]);
    const SegGptMask m = PostprocessSegGpt(f.Get("pred").as<float>(), 64, wt, ht);
    const io::TensorView& painted = f.Get("painted");
    double pw = 0;
    for (size_t i = 0; i < m.painted.size(); ++i)
      pw = std::max(pw,
                    std::abs(m.painted[i] - painted.as<float>()[i]) / (0.03 + 1e-3 * std::abs(painted.as<float>()[i])));
    EXPECT_LE(pw, 1.0);
    int flips = 0;
    for (size_t i = 0; i < m.mask.size(); ++i) flips += m.mask[i] != th.as<uint8_t>()[i];
    EXPECT_EQ(flips, 0);
    const Image expected = io::ReadImage(dir + "expected_mask.png");
    EXPECT_EQ(expected.at(0, 0, 0) == 255, m.mask[0] == 1);
  }
}

}  // namespace
}  // namespace freeloc::vision
