// Parity of the DUSt3R port with the reference implementation on every fixture case (../shared/fixtures/dust3r):
// encoder, decoder and head intermediates and the final pointmaps, from the stored network inputs and from the
// PNGs through freeloc's preprocessing, with weights from safetensors and from the .pth.
#include "freeloc/nn/dust3r.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/vision/dust3r_preprocess.h"
#include "testing/png_pair.h"
#include "testing/tensor_compare.h"
#include "testing/testing.h"

namespace freeloc::nn {
namespace {

using testing::SharedPath;

double Budget(const io::TensorView& a, const io::TensorView& b, double atol = 1e-4, double rtol = 1e-3) {
  return testing::BudgetUse(a, b, atol, rtol);
}

std::shared_ptr<Dust3rModel> TinyModel(bool pth = false) {
  if (pth) return Dust3rModel::Load(SharedPath("fixtures/pth/dust3r_tiny.pth"));
  return Dust3rModel::Load(SharedPath("fixtures/dust3r/weights.safetensors"),
                           SharedPath("fixtures/dust3r/config.json"));
}

// freeloc's own tiny DUSt3R (the fixture's architecture, its own values; written by the build): for what needs no
// reference outputs.
std::shared_ptr<Dust3rModel> OwnTinyModel(bool pth = false) {
  if (pth) return Dust3rModel::Load(testing::TinyModelPath("dust3r_tiny.pth"));
  return Dust3rModel::Load(testing::TinyModelPath("dust3r/model.safetensors"),
                           testing::TinyModelPath("dust3r/config.json"));
}

Dust3rView ViewOf(const io::TensorView& img) {
  return {img.as<float>(), static_cast<int>(img.shape[2]), static_cast<int>(img.shape[3])};
}

void CheckCase(const std::string& name, const Dust3rModel& model, bool intermediates) {
  SCOPED_TRACE(name);
  const io::SafetensorsFile f = io::SafetensorsFile::Open(SharedPath("fixtures/dust3r/cases/" + name + ".safetensors"));
  std::map<std::string, io::TensorView> taps;
  model.SetTapSink(intermediates ? &taps : nullptr);
  const Dust3rPrediction p = model.Run(ViewOf(f.Get("view1.img")), ViewOf(f.Get("view2.img")));
  model.SetTapSink(nullptr);
  const double worst_pred =
      std::max({Budget(p.pts3d_1, f.Get("pred1.pts3d")), Budget(p.conf_1, f.Get("pred1.conf")),
                Budget(p.pts3d_2, f.Get("pred2.pts3d_in_other_view")), Budget(p.conf_2, f.Get("pred2.conf"))});
  EXPECT_LE(worst_pred, 1.0);
  EXPECT_EQ(p.pts3d_1.shape, (std::vector<int64_t>{f.Get("view1.img").shape[2], f.Get("view1.img").shape[3], 3}));
  if (!intermediates) return;
  const testing::TapComparison taps_vs_fixture = testing::CompareTaps(taps, f, [](const std::string& n) {
    return (n.rfind("enc", 0) == 0 || n.rfind("dec", 0) == 0 || n.rfind("head", 0) == 0) &&
           n.find(".pos") == std::string::npos;
  });
  EXPECT_GT(taps_vs_fixture.compared, 30);
  std::printf("%s: %d intermediates, worst budget use %.1f %%, outputs %.1f %% (atol 1e-4, rtol 1e-3)\n", name.c_str(),
              taps_vs_fixture.compared, 100 * taps_vs_fixture.worst, 100 * worst_pred);
}

TEST(Dust3r, ConfigFromShapesAndConstructorString) {
  const auto m = OwnTinyModel();
  const Dust3rConfig& c = m->config();
  EXPECT_EQ(c.enc_dim, 64);
  EXPECT_EQ(c.enc_depth, 2);
  EXPECT_EQ(c.enc_heads, 4);
  EXPECT_EQ(c.dec_dim, 48);
  EXPECT_EQ(c.dec_depth, 12);
  EXPECT_EQ(c.dpt_feature_dim, 32);
  EXPECT_EQ(c.dpt_last_dim, 16);
  EXPECT_EQ(c.dpt_layer_dims, (std::array<int, 4>{12, 24, 48, 96}));
  EXPECT_EQ(c.hooks, (std::array<int, 4>{0, 6, 9, 12}));
  const auto kw = ParseConstructorKwargs(
      "AsymmetricCroCo3DStereo(pos_embed='RoPE100', img_size=(512, 512), depth_mode=('exp', -inf, inf), "
      "enc_num_heads=4, dec_num_heads=4)");
  EXPECT_EQ(kw.at("pos_embed"), "RoPE100");
  EXPECT_EQ(kw.at("img_size"), "(512, 512)");
  EXPECT_EQ(kw.at("depth_mode"), "('exp', -inf, inf)");
  EXPECT_EQ(kw.at("dec_num_heads"), "4");
}

TEST(Dust3r, ParityOnEveryFixtureCase) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/cases/png_s80.safetensors");
  const auto m = TinyModel();
  for (const char* c : {"land_64x48", "port_48x64", "png_s80", "png_s80_mixed", "png_s128"}) CheckCase(c, *m, true);
}

TEST(Dust3r, PthWeightsGiveTheSameResults) {
  // The same weights as model.safetensors + config.json and as a .pth with args.model (the parity of the network
  // itself: Dust3r.ParityOnEveryFixtureCase).
  const auto a = OwnTinyModel(false), b = OwnTinyModel(true);
  EXPECT_EQ(b->config().enc_heads, 4);  // from args.model
  const std::vector<float> i1 = testing::RandomImage(80, 64, 1), i2 = testing::RandomImage(64, 80, 2);
  const auto pa = a->Run({i1.data(), 80, 64}, {i2.data(), 64, 80});
  const auto pb = b->Run({i1.data(), 80, 64}, {i2.data(), 64, 80});
  EXPECT_TRUE(testing::SameBytes(pa.pts3d_2, pb.pts3d_2));
  EXPECT_TRUE(testing::SameBytes(pa.conf_1, pb.conf_1));
}

TEST(Dust3r, FromPngsThroughFreelocPreprocessing) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/images/img_a.png");
  const auto m = TinyModel();
  for (const testing::PngPairCase& c : {testing::PngPairCase{"png_s80", "img_a", "img_b", 80},
                                        testing::PngPairCase{"png_s80_mixed", "img_a", "img_c", 80},
                                        testing::PngPairCase{"png_s128", "img_a", "img_b", 128}}) {
    SCOPED_TRACE(c.name);
    const auto p = testing::PreprocessPngPair(SharedPath("fixtures/dust3r/images"), c).Run(*m);
    const io::SafetensorsFile f =
        io::SafetensorsFile::Open(SharedPath(std::string("fixtures/dust3r/cases/") + c.name + ".safetensors"));
    EXPECT_LE(Budget(p.pts3d_1, f.Get("pred1.pts3d")), 1.0);
    EXPECT_LE(Budget(p.pts3d_2, f.Get("pred2.pts3d_in_other_view")), 1.0);
    EXPECT_LE(Budget(p.conf_2, f.Get("pred2.conf")), 1.0);
  }
}

TEST(Dust3r, CachedReferenceEqualsOneShot) {
  const auto m = OwnTinyModel();
  const std::vector<float> i1 = testing::RandomImage(96, 128, 3), i2 = testing::RandomImage(96, 128, 4);
  const Dust3rView v1{i1.data(), 96, 128}, v2{i2.data(), 96, 128};
  const auto one = m->Run(v1, v2);
  const auto ref = m->Encode(v1);
  for (int rep = 0; rep < 2; ++rep) {  // the cached encoding serves several queries
    const auto q = m->Encode(v2);
    const auto two = m->Decode(*ref, *q);
    EXPECT_TRUE(testing::SameBytes(one.pts3d_1, two.pts3d_1));
    EXPECT_TRUE(testing::SameBytes(one.pts3d_2, two.pts3d_2));
    EXPECT_TRUE(testing::SameBytes(one.conf_2, two.conf_2));
  }
}

// HF layout: model.safetensors with config.json (the constructor kwargs at the top level) beside it.
TEST(Dust3r, HfLayoutReadsTheSiblingConfig) {
  testing::TempDir tmp;
  std::filesystem::copy_file(testing::TinyModelPath("dust3r/model.safetensors"), tmp.File("model.safetensors"));
  testing::WriteText(tmp.File("config.json"),
                     R"({"enc_embed_dim": 64, "enc_depth": 2, "enc_num_heads": 4, "dec_embed_dim": 48, "dec_depth": 12,
                         "dec_num_heads": 4, "pos_embed": "RoPE100", "head_type": "dpt", "output_mode": "pts3d",
                         "depth_mode": ["exp", "-inf", "inf"], "conf_mode": ["exp", 1, "inf"]})");
  const auto m = Dust3rModel::Load(tmp.File("model.safetensors"));
  EXPECT_EQ(m->config().enc_heads, 4);
  EXPECT_EQ(m->config().source, tmp.File("config.json"));
  const std::vector<float> i1 = testing::RandomImage(64, 80, 5);  // the same network as the .pth with args.model
  const auto pm = m->Run({i1.data(), 64, 80}, {i1.data(), 64, 80});
  const auto pp = OwnTinyModel(true)->Run({i1.data(), 64, 80}, {i1.data(), 64, 80});
  EXPECT_TRUE(testing::SameBytes(pm.pts3d_1, pp.pts3d_1));
  // A config that does not belong to the weights is refused.
  testing::WriteText(tmp.File("config.json"), R"({"enc_depth": 3, "enc_num_heads": 4, "dec_num_heads": 4})");
  try {
    Dust3rModel::Load(tmp.File("model.safetensors"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("enc_depth=3 but the weights have 2"), std::string::npos) << e.what();
  }
}

TEST(Dust3r, BadWeightsAndInputs) {
  testing::TempDir tmp;
  // Drop one tensor and add a stray one: the error lists both.
  const io::SafetensorsFile w = io::SafetensorsFile::Open(testing::TinyModelPath("dust3r/model.safetensors"));
  std::vector<std::pair<std::string, io::TensorView>> ts;
  for (const auto& n : w.names)
    if (n != "dec_blocks2.3.norm_y.bias") ts.emplace_back(n, w.Get(n));
  const float z = 0;
  ts.emplace_back("extra.thing", io::MakeTensor(io::DType::kF32, {1}, &z, 4));
  io::WriteSafetensors(tmp.File("bad.safetensors"), ts);
  try {
    Dust3rModel::Load(tmp.File("bad.safetensors"), testing::TinyModelPath("dust3r/config.json"));
    FAIL();
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("dec_blocks2.3.norm_y.bias"), std::string::npos) << m;
    EXPECT_NE(m.find("extra.thing"), std::string::npos) << m;
  }
  const auto m = OwnTinyModel();
  std::vector<float> img(3 * 50 * 64, 0.f);
  EXPECT_THROW(m->Run({img.data(), 50, 64}, {img.data(), 50, 64}), Error);  // 50 not a multiple of 16
  RuntimeOptions bad;
  bad.threads = -1;
  EXPECT_THROW(Dust3rModel::Load(testing::TinyModelPath("dust3r/model.safetensors"),
                                 testing::TinyModelPath("dust3r/config.json"), bad),
               Error);
}

}  // namespace
}  // namespace freeloc::nn
