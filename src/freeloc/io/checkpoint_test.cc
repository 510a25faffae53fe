#include "freeloc/io/checkpoint.h"

#include <gtest/gtest.h>

#include "freeloc/core/error.h"
#include "freeloc/io/safetensors.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

TEST(Checkpoint, SafetensorsView) {
  testing::TempDir tmp;
  const float w[4] = {1, 2, 3, 4};
  WriteSafetensors(
      tmp.File("m.safetensors"),
      {{"encoder.w", MakeTensor(DType::kF32, {2, 2}, w, sizeof(w))}, {"encoder.b", MakeTensor(DType::kF32, {2}, w, 8)}},
      {{"format", "pt"}});
  const Checkpoint c = Checkpoint::Open(tmp.File("m.safetensors"));
  EXPECT_EQ(c.format(), Checkpoint::Format::kSafetensors);
  EXPECT_EQ(c.names(), (std::vector<std::string>{"encoder.w", "encoder.b"}));
  EXPECT_TRUE(c.Has("encoder.b"));
  EXPECT_EQ(c.Get("encoder.w").ToFloat()[3], 4.0f);
  EXPECT_EQ(c.MetadataOr("format", ""), "pt");
  EXPECT_EQ(c.MetadataOr("nope", "x"), "x");
  EXPECT_EQ(c.root(), nullptr);
  EXPECT_EQ(c.StateDictRoot(), "");
  EXPECT_EQ(c.StateDict().size(), 2u);
  try {
    c.Get("decoder.w");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'decoder.w'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("m.safetensors"), std::string::npos);
  }
}

TEST(Checkpoint, PthStateDictUnderModel) {
  const Checkpoint c = Checkpoint::Open(testing::TinyModelPath("dust3r_tiny.pth"));
  EXPECT_EQ(c.size(), 745u);
  EXPECT_TRUE(c.Has("model.enc_norm.weight"));
  const auto sd = c.StateDict({"model_state_dict", "model"});
  EXPECT_TRUE(sd.count("enc_norm.weight"));
  EXPECT_EQ(sd.at("dec_blocks2.11.norm_y.bias").shape, std::vector<int64_t>{48});
}

TEST(Checkpoint, MissingFile) { EXPECT_THROW(Checkpoint::Open("/nonexistent/model.pth"), Error); }

}  // namespace
}  // namespace freeloc::io
