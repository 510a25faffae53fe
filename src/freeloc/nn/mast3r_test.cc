// Parity of the MASt3R port (Dust3rModel with the 'catmlp+dpt' head) with upstream on every case of
// ../shared/fixtures/mast3r: every stored intermediate of the new head, pointmaps, descriptors and desc_conf, from the
// stored network inputs and from the PNGs, with weights from safetensors + config.json, from the .pth (constructor
// string) and from an HF folder (flat config.json with Infinity tokens, one name per shared tensor); the
// two_confs=False variant and the desc_conf_mode fallback.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/vision/dust3r_preprocess.h"
#include "testing/png_pair.h"
#include "testing/tensor_compare.h"
#include "testing/testing.h"

namespace freeloc::nn {
namespace {

using testing::SharedPath;

constexpr const char* kCases[] = {"land_s128", "mixed_s80", "odd_s112"};

double Budget(const io::TensorView& a, const io::TensorView& b) { return testing::BudgetUse(a, b, 1e-4, 1e-3); }

std::string Fixture(const std::string& f) { return SharedPath("fixtures/mast3r/" + f); }

std::shared_ptr<Dust3rModel> TinyModel() {
  return Dust3rModel::Load(Fixture("weights.safetensors"), Fixture("config.json"));
}

// freeloc's own tiny MASt3R (the fixture's architecture, its own values; written by the build): for what needs no
// reference outputs.
std::string Own(const std::string& f) { return testing::TinyModelPath(f); }
std::shared_ptr<Dust3rModel> OwnTinyModel() {
  return Dust3rModel::Load(Own("mast3r/model.safetensors"), Own("mast3r/config.json"));
}

Dust3rView ViewOf(const io::TensorView& img) {
  return {img.as<float>(), static_cast<int>(img.shape[2]), static_cast<int>(img.shape[3])};
}

// The fixture's tensors with a leading batch dimension of 1 compare against ours without it.
double WorstPrediction(const Dust3rPrediction& p, const io::SafetensorsFile& f, const std::string& prefix = "") {
  return std::max({Budget(p.pts3d_1, f.Get("pred1.pts3d")), Budget(p.conf_1, f.Get("pred1.conf")),
                   Budget(p.pts3d_2, f.Get("pred2.pts3d_in_other_view")), Budget(p.conf_2, f.Get("pred2.conf")),
                   Budget(p.desc_1, f.Get("pred1.desc")), Budget(p.desc_2, f.Get("pred2.desc")),
                   Budget(p.desc_conf_1, f.Get(prefix + "pred1.desc_conf")),
                   Budget(p.desc_conf_2, f.Get(prefix + "pred2.desc_conf"))});
}

void CheckCase(const std::string& name, const Dust3rModel& model, bool intermediates) {
  SCOPED_TRACE(name);
  const io::SafetensorsFile f = io::SafetensorsFile::Open(Fixture("cases/" + name + ".safetensors"));
  std::map<std::string, io::TensorView> taps;
  model.SetTapSink(intermediates ? &taps : nullptr);
  const Dust3rPrediction p = model.Run(ViewOf(f.Get("view1.img")), ViewOf(f.Get("view2.img")));
  model.SetTapSink(nullptr);
  ASSERT_EQ(p.desc_1.shape.size(), 3u);
  EXPECT_EQ(p.desc_1.shape[2], 8);
  const double worst_pred = WorstPrediction(p, f);
  EXPECT_LE(worst_pred, 1.0);
  if (!intermediates) return;
  const testing::TapComparison taps_vs_fixture = testing::CompareTaps(taps, f, [](const std::string& n) {
    return n.rfind("enc", 0) == 0 || n.rfind("dec", 0) == 0 || n.rfind("head", 0) == 0;
  });
  EXPECT_EQ(taps_vs_fixture.compared, 14);  // enc, dec, mlp_in, mlp_hidden, mlp_out, local, raw per view
  std::printf("%s: %d intermediates, worst budget use %.1f %%, outputs %.1f %% (atol 1e-4, rtol 1e-3)\n", name.c_str(),
              taps_vs_fixture.compared, 100 * taps_vs_fixture.worst, 100 * worst_pred);
}

TEST(Mast3r, ConfigFromConstructorArgumentsAndShapes) {
  const auto m = OwnTinyModel();
  const Dust3rConfig& c = m->config();
  EXPECT_TRUE(c.is_mast3r());
  EXPECT_EQ(c.local_feat_dim, 8);
  EXPECT_TRUE(c.two_confs);
  EXPECT_EQ(c.local_mlp_hidden, 224);
  EXPECT_EQ(c.desc_conf_min, 0.0);
  EXPECT_TRUE(std::isinf(c.desc_conf_max));
  EXPECT_EQ(c.conf_min, 1.0);
  EXPECT_EQ(c.enc_dim, 32);
  EXPECT_EQ(c.dec_dim, 24);
  EXPECT_EQ(c.dpt_feature_dim, 24);
  EXPECT_EQ(c.dpt_last_dim, 12);
  EXPECT_NE(c.Summary().find("desc_conf 0 + exp(x) from desc_conf_mode"), std::string::npos) << c.Summary();
  double lo = 0, hi = 0;
  ParseConfMode("('exp', 0, inf)", "x", &lo, &hi);
  EXPECT_EQ(lo, 0);
  EXPECT_TRUE(std::isinf(hi) && hi > 0);
  ParseConfMode("[\"exp\", -1.5, \"inf\"]", "x", &lo, &hi);
  EXPECT_EQ(lo, -1.5);
  EXPECT_THROW(ParseConfMode("('sigmoid', 0, 1)", "desc_conf_mode", &lo, &hi), Error);
  EXPECT_EQ(ParseConstructorKwargs("AsymmetricMASt3R(two_confs=True)").at("__class__"), "AsymmetricMASt3R");
}

TEST(Mast3r, ParityOnEveryFixtureCase) {
  FREELOC_REQUIRE_SHARED("fixtures/mast3r/cases/odd_s112.safetensors");
  const auto m = TinyModel();
  for (const char* c : kCases) CheckCase(c, *m, true);
}

TEST(Mast3r, PthWithConstructorStringGivesTheSameResults) {
  // The same weights as model.safetensors + config.json and as a .pth with its constructor string (the network's
  // parity itself: Mast3r.ParityOnEveryFixtureCase).
  const auto a = OwnTinyModel();
  const auto b = Dust3rModel::Load(Own("mast3r_tiny.pth"));
  EXPECT_EQ(b->config().local_feat_dim, 8);
  EXPECT_TRUE(b->config().two_confs);
  EXPECT_EQ(b->config().enc_heads, 2);
  EXPECT_EQ(b->config().desc_conf_min, 0.0);
  const std::vector<float> i1 = testing::RandomImage(80, 64, 1), i2 = testing::RandomImage(64, 80, 2);
  const auto pa = a->Run({i1.data(), 80, 64}, {i2.data(), 64, 80});
  const auto pb = b->Run({i1.data(), 80, 64}, {i2.data(), 64, 80});
  EXPECT_TRUE(testing::SameBytes(pa.desc_2, pb.desc_2));
  EXPECT_TRUE(testing::SameBytes(pa.desc_conf_1, pb.desc_conf_1));
  EXPECT_TRUE(testing::SameBytes(pa.pts3d_1, pb.pts3d_1));
}

TEST(Mast3r, FromPngsThroughFreelocPreprocessing) {
  FREELOC_REQUIRE_SHARED("fixtures/mast3r/images/img_a.png");
  const auto m = TinyModel();
  for (const testing::PngPairCase& c : {testing::PngPairCase{"land_s128", "img_a", "img_d", 128},
                                        testing::PngPairCase{"mixed_s80", "img_a", "img_c", 80},
                                        testing::PngPairCase{"odd_s112", "img_b", "img_a", 112}}) {
    SCOPED_TRACE(c.name);
    const testing::PreprocessedPair in = testing::PreprocessPngPair(Fixture("images"), c);
    const io::SafetensorsFile f = io::SafetensorsFile::Open(Fixture(std::string("cases/") + c.name + ".safetensors"));
    // Preprocessing is bit-exact.
    EXPECT_TRUE(testing::SameBytes(io::MakeTensor(io::DType::kU8, {static_cast<int64_t>(in.a.image.data.size())},
                                                  in.a.image.data.data(), in.a.image.data.size()),
                                   f.Get("view1.img_u8")));
    EXPECT_TRUE(testing::SameBytes(io::MakeTensor(io::DType::kU8, {static_cast<int64_t>(in.b.image.data.size())},
                                                  in.b.image.data.data(), in.b.image.data.size()),
                                   f.Get("view2.img_u8")));
    EXPECT_LE(WorstPrediction(in.Run(*m), f), 1.0);
  }
}

// two_confs=False (fixture README §2): fc2 cut to its first D·256 rows; desc unchanged, desc_conf = conf.
TEST(Mast3r, TwoConfsFalseVariant) {
  FREELOC_REQUIRE_SHARED("fixtures/mast3r/weights.safetensors");
  const io::SafetensorsFile w = io::SafetensorsFile::Open(Fixture("weights.safetensors"));
  std::map<std::string, io::TensorView> sd;
  std::vector<std::vector<float>> keep;
  for (const auto& n : w.names) {
    io::TensorView t = w.Get(n);
    if (n.find("head_local_features.fc2") != std::string::npos) {
      const int64_t rows = 8 * 256;
      const int64_t cols = t.shape.size() == 2 ? t.shape[1] : 1;
      keep.emplace_back(t.as<float>(), t.as<float>() + rows * cols);
      t = io::MakeTensor(io::DType::kF32,
                         t.shape.size() == 2 ? std::vector<int64_t>{rows, cols} : std::vector<int64_t>{rows},
                         keep.back().data(), keep.back().size() * 4);
    }
    sd[n] = t;
  }
  std::map<std::string, std::string> kw = {{"output_mode", "pts3d+desc8"}, {"head_type", "catmlp+dpt"},
                                           {"enc_num_heads", "2"},         {"dec_num_heads", "2"},
                                           {"two_confs", "False"},         {"desc_conf_mode", "('exp', 0, inf)"}};
  const auto m = Dust3rModel::Create(sd, kw, "two_confs=False variant");
  EXPECT_FALSE(m->config().two_confs);
  const io::SafetensorsFile f = io::SafetensorsFile::Open(Fixture("cases/mixed_s80.safetensors"));
  const auto p = m->Run(ViewOf(f.Get("view1.img")), ViewOf(f.Get("view2.img")));
  EXPECT_LE(WorstPrediction(p, f, "noconf."), 1.0);
  // Saying two_confs=True of the cut weights is refused with both row counts.
  kw["two_confs"] = "True";
  const std::string e = testing::ErrorOf([&] { Dust3rModel::Create(sd, kw, "cfg"); });
  EXPECT_NE(e.find("need [2304, 224]"), std::string::npos) << e;
}

// A missing desc_conf_mode falls back to conf_mode ('exp', 1, inf): desc_conf = 1 + exp(x), i.e. the stored
// exp(x) + 1 (naver/mast3r).
TEST(Mast3r, DescConfModeFallsBackToConfMode) {
  const io::SafetensorsFile w = io::SafetensorsFile::Open(Own("mast3r/model.safetensors"));
  std::map<std::string, io::TensorView> sd;
  for (const auto& n : w.names) sd[n] = w.Get(n);
  const auto m = Dust3rModel::Create(
      sd, {{"output_mode", "pts3d+desc8"}, {"enc_num_heads", "2"}, {"dec_num_heads", "2"}, {"two_confs", "True"}},
      "no desc_conf_mode");
  EXPECT_EQ(m->config().desc_conf_min, 1.0);
  EXPECT_NE(m->config().Summary().find("conf_mode (desc_conf_mode absent)"), std::string::npos);
  // desc_conf then follows conf_mode ('exp', 1, inf): the same network's desc_conf_mode ('exp', 0, inf) answer + 1.
  const std::vector<float> i1 = testing::RandomImage(112, 80, 3), i2 = testing::RandomImage(80, 112, 4);
  const auto p = m->Run({i1.data(), 112, 80}, {i2.data(), 80, 112});
  const auto normal = OwnTinyModel()->Run({i1.data(), 112, 80}, {i2.data(), 80, 112});
  const io::TensorView& ref = normal.desc_conf_2;
  double worst = 0;
  for (int64_t i = 0; i < ref.numel(); ++i)
    worst = std::max(worst, std::abs(p.desc_conf_2.as<float>()[i] - (ref.as<float>()[i] + 1.0)) /
                                (1e-4 + 1e-3 * (ref.as<float>()[i] + 1.0)));
  EXPECT_LE(worst, 1.0);
  // Without output_mode the descriptor size is unknown: a clear error, not a guess from fc2's shape.
  const std::string e = testing::ErrorOf([&] { Dust3rModel::Create(sd, {{"enc_num_heads", "2"}}, "cfg"); });
  EXPECT_NE(e.find("pts3d+desc<D>"), std::string::npos) << e;
}

// The HF layout (PyTorchModelHubMixin): model.safetensors keeps one name per shared tensor (scratch.layer{i+1}_rn,
// not scratch.layer_rn.{i}) and config.json is the flat kwargs with bare Infinity tokens.
TEST(Mast3r, HfFolderWithInfinityTokens) {
  testing::TempDir tmp;
  const io::SafetensorsFile w = io::SafetensorsFile::Open(Own("mast3r/model.safetensors"));
  std::vector<std::pair<std::string, io::TensorView>> ts;
  std::map<std::string, std::string> dropped;
  for (const auto& n : w.names) {
    if (n.find("scratch.layer_rn.") != std::string::npos) {
      dropped[n] = "alias";
      continue;
    }
    ts.emplace_back(n, w.Get(n));
  }
  EXPECT_EQ(dropped.size(), 8u);
  io::WriteSafetensors(tmp.File("model.safetensors"), ts, dropped);
  testing::WriteText(tmp.File("config.json"), R"({
  "conf_mode": ["exp", 1, Infinity],
  "dec_depth": 12, "dec_embed_dim": 24, "dec_num_heads": 2,
  "depth_mode": ["exp", -Infinity, Infinity],
  "desc_conf_mode": ["exp", 0, Infinity], "desc_mode": "norm",
  "enc_depth": 2, "enc_embed_dim": 32, "enc_num_heads": 2,
  "head_type": "catmlp+dpt", "img_size": [512, 512], "landscape_only": false,
  "output_mode": "pts3d+desc8", "patch_embed_cls": "PatchEmbedDust3R", "pos_embed": "RoPE100",
  "two_confs": true
})");
  const auto m = Dust3rModel::Load(tmp.File("model.safetensors"));
  EXPECT_EQ(m->config().source, tmp.File("config.json"));
  EXPECT_EQ(m->config().desc_conf_min, 0.0);
  const std::vector<float> i1 =
      testing::RandomImage(112, 80, 5);  // the same network as the .pth with its constructor string
  const auto ph = m->Run({i1.data(), 112, 80}, {i1.data(), 112, 80});
  const auto pp = Dust3rModel::Load(Own("mast3r_tiny.pth"))->Run({i1.data(), 112, 80}, {i1.data(), 112, 80});
  EXPECT_TRUE(testing::SameBytes(ph.desc_1, pp.desc_1));
  EXPECT_TRUE(testing::SameBytes(ph.pts3d_2, pp.pts3d_2));
}

TEST(Mast3r, SkippedOutputsAreNotComputed) {
  const auto m = OwnTinyModel();
  const std::vector<float> i1 = testing::RandomImage(96, 128, 6), i2 = testing::RandomImage(96, 128, 7);
  const auto e1 = m->Encode({i1.data(), 96, 128});
  const auto e2 = m->Encode({i2.data(), 96, 128});
  const auto full = m->Decode(*e1, *e2);
  DecodeOutputs only1;
  only1.view2 = false;
  only1.descriptors = false;
  const auto p = m->Decode(*e1, *e2, only1);
  EXPECT_EQ(p.pts3d_2.nbytes, 0u);
  EXPECT_EQ(p.desc_1.nbytes, 0u);
  EXPECT_TRUE(testing::SameBytes(p.pts3d_1, full.pts3d_1));
}

}  // namespace
}  // namespace freeloc::nn

namespace freeloc::nn {
namespace {

// Configurations the fixtures do not have: other descriptor sizes, MLP widths and two_confs settings, on odd token
// grids. The fixture trunk with a random local-feature head; desc/desc_conf recomputed from the tapped MLP output
// with plain index arithmetic (pixel shuffle k = c·256 + i·16 + j, f/‖f‖, exp or conf copy).
TEST(Mast3r, OtherDescriptorSizesAndWidths) {
  const io::SafetensorsFile w = io::SafetensorsFile::Open(Own("mast3r/model.safetensors"));
  const std::vector<float> i1 = testing::RandomImage(112, 80, 8), i2 = testing::RandomImage(80, 112, 9);
  uint32_t state = 99;
  auto rnd = [&] {
    state = state * 1664525u + 1013904223u;
    return (static_cast<int>(state >> 9) % 2001 - 1000) / 1000.0f;
  };
  struct Variant {
    int D, hidden;
    bool two_confs;
  };
  for (const Variant& v : {Variant{16, 40, false}, Variant{3, 17, true}, Variant{24, 64, true}}) {
    SCOPED_TRACE(::testing::Message() << "D=" << v.D << " hidden " << v.hidden << " two_confs " << v.two_confs);
    std::map<std::string, io::TensorView> sd;
    std::vector<std::vector<float>> keep;
    for (const auto& n : w.names)
      if (n.find("head_local_features") == std::string::npos) sd[n] = w.Get(n);
    const int64_t rows = (v.D + (v.two_confs ? 1 : 0)) * 256;
    for (int h = 1; h <= 2; ++h) {
      const std::string pre = "downstream_head" + std::to_string(h) + ".head_local_features.";
      auto add = [&](const std::string& name, std::vector<int64_t> shape, float scale) {
        int64_t n = 1;
        for (int64_t s : shape) n *= s;
        keep.emplace_back(static_cast<size_t>(n));
        for (auto& x : keep.back()) x = scale * rnd();
        sd[name] = io::MakeTensor(io::DType::kF32, shape, keep.back().data(), keep.back().size() * 4);
      };
      add(pre + "fc1.weight", {v.hidden, 56}, 0.3f);
      add(pre + "fc1.bias", {v.hidden}, 0.1f);
      add(pre + "fc2.weight", {rows, v.hidden}, 0.3f);
      add(pre + "fc2.bias", {rows}, 0.1f);
    }
    const auto m = Dust3rModel::Create(sd,
                                       {{"output_mode", "pts3d+desc" + std::to_string(v.D)},
                                        {"enc_num_heads", "2"},
                                        {"dec_num_heads", "2"},
                                        {"two_confs", v.two_confs ? "True" : "False"},
                                        {"desc_conf_mode", "('exp', 0, inf)"}},
                                       "variant");
    std::map<std::string, io::TensorView> taps;
    m->SetTapSink(&taps);
    const auto p = m->Run({i1.data(), 112, 80}, {i2.data(), 80, 112});
    m->SetTapSink(nullptr);
    for (int view = 1; view <= 2; ++view) {
      const io::TensorView& out = taps.at("head" + std::to_string(view) + ".mlp_out");
      const io::TensorView& desc = view == 1 ? p.desc_1 : p.desc_2;
      const io::TensorView& dconf = view == 1 ? p.desc_conf_1 : p.desc_conf_2;
      const io::TensorView& conf = view == 1 ? p.conf_1 : p.conf_2;
      const int64_t H = desc.shape[0], W = desc.shape[1], wt = W / 16;
      ASSERT_EQ(desc.shape[2], v.D);
      double worst = 0;
      for (int64_t y = 0; y < H; ++y)
        for (int64_t x = 0; x < W; ++x) {
          const float* row = out.as<float>() + ((y / 16) * wt + x / 16) * rows;
          const int64_t k0 = (y % 16) * 16 + x % 16;
          double n2 = 0;
          for (int c = 0; c < v.D; ++c) n2 += static_cast<double>(row[c * 256 + k0]) * row[c * 256 + k0];
          for (int c = 0; c < v.D; ++c) {
            const double want = row[c * 256 + k0] / std::sqrt(n2);
            worst = std::max(worst,
                             std::abs(desc.as<float>()[(y * W + x) * v.D + c] - want) / (1e-5 + 1e-4 * std::abs(want)));
          }
          const double wc = v.two_confs ? std::exp(row[v.D * 256 + k0]) : conf.as<float>()[y * W + x];
          worst = std::max(worst, std::abs(dconf.as<float>()[y * W + x] - wc) / (1e-5 + 1e-4 * std::abs(wc)));
        }
      EXPECT_LE(worst, 1.0) << "view " << view;
    }
  }
}

}  // namespace
}  // namespace freeloc::nn
