// Parity of the SegGPT port with the original Painter code on every fixture case (../shared/fixtures/seggpt).
#include "freeloc/nn/seggpt.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "testing/tensor_compare.h"
#include "testing/testing.h"

namespace freeloc::nn {
namespace {

using testing::SharedPath;

double Budget(const io::TensorView& a, const io::TensorView& b, double atol = 1e-4, double rtol = 1e-3) {
  return testing::BudgetUse(a, b, atol, rtol);
}

std::shared_ptr<SegGptModel> Tiny() {
  return SegGptModel::Load(SharedPath("fixtures/seggpt/weights.safetensors"),
                           SharedPath("fixtures/seggpt/config.json"));
}

// freeloc's own tiny SegGPT (the fixture's architecture, its own values; written by the build): for what needs no
// reference outputs.
std::shared_ptr<SegGptModel> OwnTiny() {
  return SegGptModel::Load(testing::TinyModelPath("seggpt/model.safetensors"),
                           testing::TinyModelPath("seggpt/config.json"));
}

std::vector<float> Vec(const io::TensorView& t) { return std::vector<float>(t.as<float>(), t.as<float>() + t.numel()); }

TEST(SegGpt, ConfigFromShapesAndJson) {
  const auto m = OwnTiny();
  const SegGptConfig& c = m->config();
  // embed_dim, depth, heads, half, grid (h, w), pos_grid, decoder_dim
  EXPECT_EQ((std::vector<int>{c.embed_dim, c.depth, c.heads, c.half, c.grid_h, c.grid_w, c.pos_grid, c.decoder_dim}),
            (std::vector<int>{64, 24, 4, 64, 8, 4, 14, 16}));
  EXPECT_EQ(c.out_indices, (std::vector<int>{5, 11, 17, 23}));
}

TEST(SegGpt, ParityOnEveryCaseFromStoredInputs) {
  FREELOC_REQUIRE_SHARED("fixtures/seggpt/cases/a_instance.safetensors");
  const auto m = Tiny();
  for (const char* name : {"a_instance", "b_semantic", "c_ensemble", "d_resize_back"}) {
    SCOPED_TRACE(name);
    const io::SafetensorsFile f =
        io::SafetensorsFile::Open(SharedPath(std::string("fixtures/seggpt/cases/") + name + ".safetensors"));
    const io::TensorView& imgs = f.Get("imgs");
    const int k = static_cast<int>(imgs.shape[0]);
    const SegType type = f.Get("seg_type").as<float>()[0] > 0.5f ? SegType::kInstance : SegType::kSemantic;
    const bool ensemble = f.Get("merge_between_batch").as<int64_t>()[0] >= 0;
    std::map<std::string, io::TensorView> taps;
    m->SetTapSink(&taps);
    const io::TensorView pred = m->Forward(Vec(imgs), Vec(f.Get("tgts")), k, type, ensemble);
    m->SetTapSink(nullptr);
    double worst = Budget(pred, f.Get("pred"));
    EXPECT_LE(worst, 1.0) << "pred";
    for (const char* tap :
         {"pos_embed_resized", "embeddings", "block0_out", "merged", "decoder_input", "decoder_pixel_shuffled"}) {
      if (!f.tensors.count(tap)) continue;
      const double b = Budget(taps.at(tap), f.Get(tap));
      EXPECT_LE(b, 1.0) << tap;
      worst = std::max(worst, b);
    }
    std::printf("%s: worst budget use %.1f %% (atol 1e-4, rtol 1e-3)\n", name, 100 * worst);
    if (f.tensors.count("pred_hf_rule")) {
      // The HF ensemble schedule differs; our output must be far from it (we follow the original).
      EXPECT_GT(Budget(pred, f.Get("pred_hf_rule")), 10.0);
    }
  }
}

// Instance propagation sends K prompts with one image pair (reference and query) and K masks: the image stream is
// then computed once up to the merge. Each item's prediction is the one it gets alone (fp32 and bf16).
TEST(SegGpt, SharedImagePairGivesEachItemsOwnPrediction) {
  for (const Precision precision : {Precision::kFp32, Precision::kBf16}) {
    RuntimeOptions rt;
    rt.precision = precision;
    const auto m = SegGptModel::Load(testing::TinyModelPath("seggpt/model.safetensors"),
                                     testing::TinyModelPath("seggpt/config.json"), rt);
    const size_t item = 3 * 128 * 64;
    const int K = 3;
    std::vector<float> img(item), imgs, tgts(item * K);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-2, 2);
    for (auto& x : img) x = u(rng);
    for (int k = 0; k < K; ++k) imgs.insert(imgs.end(), img.begin(), img.end());
    for (auto& x : tgts) x = u(rng) > 0 ? 1.5f : -1.5f;
    const io::TensorView batch = m->Forward(imgs, tgts, K, SegType::kInstance, false);
    ASSERT_EQ(batch.numel(), static_cast<int64_t>(item * K));
    for (int k = 0; k < K; ++k) {
      const std::vector<float> t(tgts.begin() + k * item, tgts.begin() + (k + 1) * item);
      const io::TensorView alone = m->Forward(img, t, 1, SegType::kInstance, false);
      double worst = 0;
      for (size_t i = 0; i < item; ++i)
        worst = std::max(worst, static_cast<double>(std::abs(batch.as<float>()[k * item + i] - alone.as<float>()[i])));
      EXPECT_LE(worst, 1e-5) << (precision == Precision::kBf16 ? "bf16" : "fp32") << " item " << k;
    }
  }
}

TEST(SegGpt, FromPngsToTheBinaryMask) {
  FREELOC_REQUIRE_SHARED("fixtures/seggpt/images/a_instance/target_image.png");
  const auto m = Tiny();
  for (const char* name : {"a_instance", "b_semantic", "c_ensemble", "d_resize_back"}) {
    SCOPED_TRACE(name);
    const std::string dir = SharedPath(std::string("fixtures/seggpt/images/") + name + "/");
    const io::SafetensorsFile f =
        io::SafetensorsFile::Open(SharedPath(std::string("fixtures/seggpt/cases/") + name + ".safetensors"));
    std::vector<Image> pi, pm;
    for (int k = 0; std::filesystem::exists(dir + "prompt_image_" + std::to_string(k) + ".png"); ++k) {
      pi.push_back(io::ReadImage(dir + "prompt_image_" + std::to_string(k) + ".png"));
      pm.push_back(io::ReadImage(dir + "prompt_mask_" + std::to_string(k) + ".png"));
    }
    const Image target = io::ReadImage(dir + "target_image.png");
    const SegType type = std::string(name) == "b_semantic" ? SegType::kSemantic : SegType::kInstance;
    io::TensorView pred;
    const vision::SegGptMask out = m->Segment(pi, pm, target, type, &pred);
    EXPECT_LE(Budget(pred, f.Get("pred")), 1.0);
    const io::TensorView& gold = f.Get("mask");
    ASSERT_EQ(out.mask.size(), static_cast<size_t>(gold.numel()));
    int flips = 0;
    for (size_t i = 0; i < out.mask.size(); ++i) flips += out.mask[i] != gold.as<uint8_t>()[i];
    const int footprint = static_cast<int>(std::ceil(target.height / 64.0) * std::ceil(target.width / 64.0));
    EXPECT_LE(flips, 4 * footprint);  // the README's allowance; 0 expected
    const Image expected = io::ReadImage(dir + "expected_mask.png");
    int png_flips = 0;
    for (size_t i = 0; i < out.mask.size(); ++i) png_flips += (expected.data[3 * i] == 255) != (out.mask[i] == 1);
    EXPECT_LE(png_flips, 4 * footprint);
  }
}

TEST(SegGpt, HfNamesAreRenamedOnLoad) {
  const io::SafetensorsFile w = io::SafetensorsFile::Open(testing::TinyModelPath("seggpt/model.safetensors"));
  auto hf = [](std::string n) {
    const std::vector<std::pair<std::string, std::string>> m = {
        {"patch_embed.proj.", "model.embeddings.patch_embeddings.projection."},
        {"mask_token", "model.embeddings.mask_token"},
        {"segment_token_x", "model.embeddings.segment_token_input"},
        {"segment_token_y", "model.embeddings.segment_token_prompt"},
        {"type_token_cls", "model.embeddings.type_token_semantic"},
        {"type_token_ins", "model.embeddings.type_token_instance"},
        {"pos_embed", "model.embeddings.position_embeddings"},
        {"norm.", "model.encoder.layernorm."},
        {"decoder_embed.", "decoder.decoder_embed."},
        {"decoder_pred.0.", "decoder.decoder_pred.conv."},
        {"decoder_pred.1.", "decoder.decoder_pred.layernorm."},
        {"decoder_pred.3.", "decoder.decoder_pred.head."}};
    for (const auto& [a, b] : m)
      if (n.rfind(a, 0) == 0) return b + n.substr(a.size());
    if (n.rfind("blocks.", 0) == 0) {
      const size_t dot = n.find('.', 7);
      std::string rest = n.substr(dot + 1);
      for (const auto& [a, b] : std::vector<std::pair<std::string, std::string>>{{"attn.", "attention."},
                                                                                 {"mlp.fc1.", "mlp.lin1."},
                                                                                 {"mlp.fc2.", "mlp.lin2."},
                                                                                 {"norm1.", "layernorm_before."},
                                                                                 {"norm2.", "layernorm_after."}})
        if (rest.rfind(a, 0) == 0) rest = b + rest.substr(a.size());
      return "model.encoder.layers." + n.substr(7, dot - 7) + "." + rest;
    }
    return n;
  };
  std::map<std::string, io::TensorView> sd;
  for (const auto& n : w.names) sd[hf(n)] = w.Get(n);
  const std::string cfg = testing::ReadText(testing::TinyModelPath("seggpt/config.json"));
  const auto a = OwnTiny();
  const auto b = SegGptModel::Create(sd, cfg, "hf-named");
  // One prompt and its target stacked (2S × S, normalised pixels), seeded.
  std::vector<float> imgs(3 * 128 * 64), tgts(imgs.size());
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-2, 2);
  for (auto& x : imgs) x = u(rng);
  for (auto& x : tgts) x = u(rng);
  const io::TensorView pa = a->Forward(imgs, tgts, 1, SegType::kInstance, false);
  const io::TensorView pb = b->Forward(imgs, tgts, 1, SegType::kInstance, false);
  ASSERT_EQ(pa.nbytes, pb.nbytes);
  EXPECT_TRUE(testing::SameBytes(pa, pb));
  // Missing and unexpected tensors are listed.
  sd.erase("model.encoder.layers.7.attention.rel_pos_w");
  const float z = 0;
  sd["something.else"] = io::MakeTensor(io::DType::kF32, {1}, &z, 4);
  try {
    SegGptModel::Create(sd, cfg, "broken.safetensors");
    FAIL();
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("blocks.7.attn.rel_pos_w"), std::string::npos) << msg;
    EXPECT_NE(msg.find("something.else"), std::string::npos) << msg;
  }
}

}  // namespace
}  // namespace freeloc::nn
