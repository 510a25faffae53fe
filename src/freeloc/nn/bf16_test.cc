// bf16 that pays: the rule that decides it, the prepacked oneDNN layer against fp32, and the accuracy
// cost of `--precision bf16` on the parity fixtures (bf16 forced with FREELOC_BF16=force so every CPU measures it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "freeloc/io/safetensors.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/internal/bf16_linear.h"
#include "freeloc/nn/internal/layers.h"
#include "freeloc/nn/internal/torch_util.h"
#include "freeloc/nn/metric3d.h"
#include "freeloc/nn/seggpt.h"
#include "testing/testing.h"

namespace freeloc::nn {
namespace {

using testing::SharedPath;

// ‖a − b‖ / ‖b‖ over every element.
double RelRms(const float* a, const float* b, int64_t n) {
  double num = 0, den = 0;
  for (int64_t i = 0; i < n; ++i) {
    num += (static_cast<double>(a[i]) - b[i]) * (static_cast<double>(a[i]) - b[i]);
    den += static_cast<double>(b[i]) * b[i];
  }
  return std::sqrt(num / std::max(den, 1e-30));
}
double RelRms(const io::TensorView& a, const io::TensorView& b) {
  EXPECT_EQ(a.numel(), b.numel());
  return RelRms(a.as<float>(), b.as<float>(), std::min(a.numel(), b.numel()));
}

RuntimeOptions Bf16() {
  setenv("FREELOC_BF16", "force", 1);  // the decision is per process; every test here forces bf16
  RuntimeOptions rt;
  rt.precision = Precision::kBf16;
  return rt;
}

TEST(Bf16, RuleRunsBf16OnlyWhereItPays) {
  using internal::ChooseBf16;
  EXPECT_TRUE(ChooseBf16(true, 1.0, 0.5, false));    // native and twice as fast
  EXPECT_FALSE(ChooseBf16(true, 1.0, 0.95, false));  // native but not 10 % faster (the Xeon)
  EXPECT_FALSE(ChooseBf16(false, 1.0, 0.5, false));  // emulated: never, even if a measurement says so
  EXPECT_FALSE(ChooseBf16(true, 1.0, 0.0, false));   // no measurement
  EXPECT_TRUE(ChooseBf16(false, 1.0, 2.0, true));    // forced
}

// A bf16 model holds its weights once: whatever row counts a layer is called with (the token counts of DUSt3R,
// SegGPT, Metric3D, single rows), its kernels share one packed copy of the weights (or, where oneDNN asks for another
// layout, as few as it needs), never one per row count.
TEST(Bf16, PackedLayerKeepsItsWeightsOnce) {
  if (!internal::CpuBf16Decision().native) GTEST_SKIP() << "no native bf16 on this CPU";
  torch::manual_seed(4);
  const int64_t in = 1024, out = 4096;
  const internal::PackedLinearBf16 lin(torch::randn({out, in}) * 0.03, torch::randn({out}));
  for (int64_t rows : {768, 1568, 3136, 3349, 1, 7, 64, 129, 2000}) {
    (void)lin(torch::randn({rows, in}));
    (void)lin.Forward(torch::randn({rows, in}), /*gelu=*/true, /*bf16_out=*/true);
  }
  std::printf("packed copies: %d, %.1f MB (bf16 weights %.1f MB)\n", lin.PackedCopies(), lin.PackedBytes() / 1e6,
              in * out * 2 / 1e6);
  EXPECT_EQ(lin.PackedCopies(), 1);
  EXPECT_LE(lin.PackedBytes(), static_cast<size_t>(in * out * 2 * 1.05));
}

TEST(Bf16, PackedLayerMatchesFp32WithinBf16Rounding) {
  torch::manual_seed(3);
  struct Case {
    int64_t rows, in, out;
    bool bias;
  };
  for (const Case& c : {Case{1, 16, 8, true}, Case{37, 96, 40, false}, Case{300, 256, 1024, true}}) {
    const torch::Tensor x = torch::randn({c.rows, c.in}), w = torch::randn({c.out, c.in}) / std::sqrt(c.in);
    const torch::Tensor b = c.bias ? torch::randn({c.out}) : torch::Tensor();
    const internal::PackedLinearBf16 lin(w, b);
    const torch::Tensor ref = torch::linear(x, w, b);
    const torch::Tensor got = lin(x);
    ASSERT_EQ(got.sizes(), ref.sizes());
    const double err = ((got - ref).norm() / ref.norm()).item<double>();
    EXPECT_LT(err, 8e-3) << c.rows << "x" << c.in << "->" << c.out;  // bf16 inputs: ≈ 2^-9 relative
    EXPECT_GT(err, 0.0);                                             // it did run in bf16
    // Batched input keeps its leading shape; the fused GELU variant equals GELU of the plain output (bf16 out).
    const torch::Tensor x3 = x.reshape({1, c.rows, c.in});
    EXPECT_EQ(lin(x3).sizes(), (std::vector<int64_t>{1, c.rows, c.out}));
    const torch::Tensor g = lin.Forward(x, /*gelu=*/true, /*bf16_out=*/true);
    EXPECT_EQ(g.scalar_type(), torch::kBFloat16);
    // bf16 output alone: the plain output rounded to bf16.
    const torch::Tensor o16 = lin.Forward(x, /*gelu=*/false, /*bf16_out=*/true);
    EXPECT_EQ(o16.scalar_type(), torch::kBFloat16);
    EXPECT_TRUE(torch::equal(o16, got.to(torch::kBFloat16)));
    const torch::Tensor gr = torch::gelu(ref);
    EXPECT_LT(((g.to(torch::kFloat32) - gr).norm() / gr.norm()).item<double>(), 1.2e-2);
  }
}

// The DPT head's last 1×1 convolution on a bf16 channels-last activation: its split weights (hi + lo bf16) give the
// fp32 convolution of the same activation to 2⁻¹⁷ — far below plain bf16 weights' 2⁻⁹ — as fp32 NCHW.
TEST(Bf16, PointwiseOutKeepsFp32WeightsOnABf16Chain) {
  torch::manual_seed(6);
  const int64_t in = 40, out = 4, h = 13, w = 17;
  const torch::Tensor wt = torch::randn({out, in, 1, 1}) / std::sqrt(in), bias = torch::randn({out});
  const torch::Tensor x =
      torch::relu(torch::randn({1, in, h, w})).to(torch::kBFloat16).contiguous(torch::MemoryFormat::ChannelsLast);
  const torch::Tensor ref = torch::conv2d(x.to(torch::kFloat32), wt, bias);
  for (const bool bf16 : {false, true}) {
    internal::PrecisionPolicy p;
    p.bf16 = bf16;
    internal::WeightStore ws({{"h.weight", wt.clone()}, {"h.bias", bias.clone()}}, "test", torch::kCPU);
    internal::PointwiseOut layer;
    layer.Load(ws, "h", out, in, true, p);
    EXPECT_EQ(layer.packed != nullptr, bf16);
    const torch::Tensor got = layer(x);
    ASSERT_EQ(got.sizes(), ref.sizes());
    EXPECT_EQ(got.scalar_type(), torch::kFloat32);
    EXPECT_TRUE(got.is_contiguous());
    EXPECT_LT(((got - ref).norm() / ref.norm()).item<double>(), bf16 ? 2e-5 : 1e-6) << "bf16 " << bf16;
  }
}

// The accuracy cost of bf16 on the fixtures' tiny models, against the reference implementation's fp32 outputs.
TEST(Bf16, AccuracyCostOnTheParityFixtures) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/cases/png_s80.safetensors");
  const RuntimeOptions rt = Bf16();
  // DUSt3R and MASt3R (whose DPT heads and local-feature MLP run bf16 too): pointmaps, and MASt3R's descriptors.
  const auto pair_cases = [&](const std::string& net, const std::vector<std::string>& cases) {
    const auto model = Dust3rModel::Load(SharedPath("fixtures/" + net + "/weights.safetensors"),
                                         SharedPath("fixtures/" + net + "/config.json"), rt);
    for (const std::string& name : cases) {
      const io::SafetensorsFile f =
          io::SafetensorsFile::Open(SharedPath("fixtures/" + net + "/cases/" + name + ".safetensors"));
      const auto view = [&](const char* k) {
        const io::TensorView& t = f.Get(k);
        return Dust3rView{t.as<float>(), static_cast<int>(t.shape[2]), static_cast<int>(t.shape[3])};
      };
      const Dust3rPrediction p = model->Run(view("view1.img"), view("view2.img"));
      double e =
          std::max(RelRms(p.pts3d_1, f.Get("pred1.pts3d")), RelRms(p.pts3d_2, f.Get("pred2.pts3d_in_other_view")));
      if (net == "mast3r")
        e = std::max({e, RelRms(p.desc_1, f.Get("pred1.desc")), RelRms(p.desc_2, f.Get("pred2.desc"))});
      std::printf("bf16 %s %s: worst output %.2e relative RMS from the fp32 reference\n", net.c_str(), name.c_str(), e);
      EXPECT_LT(e, 3e-2) << net << " " << name;
      EXPECT_GT(e, 1e-6) << net << " " << name;  // bf16 did run
    }
  };
  pair_cases("dust3r", {"land_64x48", "png_s80", "png_s128"});
  pair_cases("mast3r", {"land_s128", "mixed_s80", "odd_s112"});
  const auto seggpt = SegGptModel::Load(SharedPath("fixtures/seggpt/weights.safetensors"),
                                        SharedPath("fixtures/seggpt/config.json"), rt);
  const io::SafetensorsFile s = io::SafetensorsFile::Open(SharedPath("fixtures/seggpt/cases/a_instance.safetensors"));
  const io::TensorView& imgs = s.Get("imgs");
  const io::TensorView pred =
      seggpt->Forward(std::vector<float>(imgs.as<float>(), imgs.as<float>() + imgs.numel()),
                      std::vector<float>(s.Get("tgts").as<float>(), s.Get("tgts").as<float>() + s.Get("tgts").numel()),
                      static_cast<int>(imgs.shape[0]), SegType::kInstance, false);
  const double es = RelRms(pred, s.Get("pred"));
  std::printf("bf16 SegGPT a_instance: pred %.2e relative RMS from the fp32 reference\n", es);
  EXPECT_LT(es, 3e-2);
  const std::string dir = SharedPath("fixtures/metric3d/final_norm/");
  const auto m3d = Metric3dModel::Load(dir + "weights.safetensors", dir + "config.json", rt);
  const io::SafetensorsFile m = io::SafetensorsFile::Open(dir + "cases/nyu.safetensors");
  const io::TensorView& x = m.Get("input");
  io::TensorView d, c, n;
  m3d->Forward(std::vector<float>(x.as<float>(), x.as<float>() + x.numel()), &d, &c, &n);
  const double ed = RelRms(d, m.Get("pred_depth"));
  std::printf("bf16 Metric3D nyu: depth %.2e relative RMS from the fp32 reference\n", ed);
  EXPECT_LT(ed, 3e-2);
}

}  // namespace
}  // namespace freeloc::nn
