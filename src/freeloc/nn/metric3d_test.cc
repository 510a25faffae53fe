// Parity of the Metric3D v2 port with the upstream code on both encoder paths (final norm ×4 and intermediate
// SwiGLU blocks) and every case (../shared/fixtures/metric3d), with the README's tolerances.
#include "freeloc/nn/metric3d.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "testing/testing.h"

namespace freeloc::nn {
namespace {

using testing::SharedPath;

double MaxAbs(const float* a, const io::TensorView& b, int64_t n, double skip_below = -1) {
  EXPECT_EQ(n, b.numel());
  double w = 0;
  for (int64_t i = 0; i < std::min(n, b.numel()); ++i) {
    const double y = b.as<float>()[i];
    if (skip_below > 0 && (a[i] <= skip_below || y <= skip_below)) continue;
    w = std::max(w, std::abs(a[i] - y));
  }
  return w;
}
double MaxAbs(const io::TensorView& a, const io::TensorView& b, double skip_below = -1) {
  return MaxAbs(a.as<float>(), b, a.numel(), skip_below);
}

struct Tol {
  const char* name;
  double tol;
};

TEST(Metric3d, ParityOnBothPathsAndEveryCase) {
  FREELOC_REQUIRE_SHARED("fixtures/metric3d/final_norm/weights.safetensors");
  for (const char* variant : {"final_norm", "intermediate"}) {
    const std::string dir = SharedPath(std::string("fixtures/metric3d/") + variant + "/");
    const auto m = Metric3dModel::Load(dir + "weights.safetensors", dir + "config.json");
    EXPECT_EQ(m->config().multi_output, std::string(variant) == "intermediate");
    for (const char* name : {"nyu", "kitti", "portrait"}) {
      SCOPED_TRACE(std::string(variant) + " " + name);
      const io::SafetensorsFile f = io::SafetensorsFile::Open(dir + "cases/" + name + ".safetensors");
      // Preprocessing from the stored image.
      const io::TensorView& rgb = f.Get("image_rgb");
      Image im(static_cast<int>(rgb.shape[1]), static_cast<int>(rgb.shape[0]));
      std::memcpy(im.data.data(), rgb.data, rgb.nbytes);
      const vision::Metric3dInput in = vision::PrepareMetric3dInput(im, m->config().input_h, m->config().input_w);
      EXPECT_EQ(in.resized_h, f.Get("resized_hw").as<int64_t>()[0]);
      EXPECT_EQ(in.resized_w, f.Get("resized_hw").as<int64_t>()[1]);
      for (int k = 0; k < 4; ++k) EXPECT_EQ(in.pad[k], f.Get("pad_info").as<int64_t>()[k]);
      EXPECT_EQ(std::memcmp(in.resized.data.data(), f.Get("image_resized").data, f.Get("image_resized").nbytes), 0);
      EXPECT_EQ(std::memcmp(in.padded.data.data(), f.Get("image_padded").data, f.Get("image_padded").nbytes), 0);
      EXPECT_LE(MaxAbs(in.input.data(), f.Get("input"), static_cast<int64_t>(in.input.size())), 1e-6);
      // Network from the stored input, every stored intermediate.
      std::map<std::string, io::TensorView> taps;
      m->SetTapSink(&taps);
      const io::TensorView& x = f.Get("input");
      io::TensorView d, c, n;
      m->Forward(std::vector<float>(x.as<float>(), x.as<float>() + x.numel()), &d, &c, &n);
      m->SetTapSink(nullptr);
      const Tol tols[] = {{"patch_embed_out", 1e-4}, {"pos_embed_interp", 1e-4},
                          {"tokens_prepared", 1e-4}, {"encoder_features", 1e-4},
                          {"readout_0", 1e-4},       {"readout_1", 1e-4},
                          {"readout_2", 1e-4},       {"readout_3", 1e-4},
                          {"ref_feat", 2e-4},        {"init_depth_expectation", 5e-3},
                          {"normal_head_raw", 2e-4}, {"depth_init", 1e-4},
                          {"net_init_04", 2e-4},     {"net_init_08", 2e-4},
                          {"net_init_16", 2e-4},     {"context_04", 2e-4},
                          {"context_08", 2e-4},      {"context_16", 2e-4},
                          {"iter_state", 1e-4},      {"net_final_04", 2e-4},
                          {"net_final_08", 2e-4},    {"net_final_16", 2e-4},
                          {"up_mask_final", 2e-4}};
      double worst_ratio = 0;
      for (const Tol& t : tols) {
        if (!f.tensors.count(t.name)) continue;
        ASSERT_TRUE(taps.count(t.name)) << t.name;
        const double e = MaxAbs(taps.at(t.name), f.Get(t.name));
        EXPECT_LE(e, t.tol) << t.name;
        worst_ratio = std::max(worst_ratio, e / t.tol);
      }
      const double ed = MaxAbs(d, f.Get("pred_depth"), 0.1001), ec = MaxAbs(c, f.Get("confidence")),
                   en = MaxAbs(n, f.Get("pred_normal"));
      EXPECT_LE(ed, 5e-3);
      EXPECT_LE(ec, 2e-4);
      EXPECT_LE(en, 2e-4);
      worst_ratio = std::max({worst_ratio, ed / 5e-3, ec / 2e-4, en / 2e-4});
      // Metric depth and normals at the original resolution, through Estimate() with the case's intrinsics.
      const io::TensorView& K = f.Get("intrinsics");
      const Camera cam{K.as<double>()[0], K.as<double>()[1], K.as<double>()[2], K.as<double>()[3], im.width, im.height};
      const Metric3dOutput out = m->Estimate(im, cam);
      const double factor = K.as<double>()[0] * in.scale / 1000.0;
      const double em =
          MaxAbs(out.depth.data.data(), f.Get("depth_metric"), static_cast<int64_t>(out.depth.data.size()));
      EXPECT_LE(em, 5e-3 * factor);
      const double eno = MaxAbs(out.normal.data(), f.Get("normal_orig"), static_cast<int64_t>(out.normal.size()));
      EXPECT_LE(eno, 2e-4);
      worst_ratio = std::max({worst_ratio, em / (5e-3 * factor), eno / 2e-4});
      std::printf("%s/%s: worst use of the README tolerance %.1f %%\n", variant, name, 100 * worst_ratio);
    }
  }
}

TEST(Metric3d, MissingAndUnexpectedTensorsAreListed) {
  const std::string dir = testing::TinyModelPath("metric3d/");  // freeloc's own tiny model, written by the build
  const io::SafetensorsFile w = io::SafetensorsFile::Open(dir + "model.safetensors");
  std::map<std::string, io::TensorView> sd;
  for (const auto& n : w.names)
    if (n != "depth_model.decoder.update_block.gru16.convq.bias") sd[n] = w.Get(n);
  const float z = 0;
  sd["depth_model.decoder.extra"] = io::MakeTensor(io::DType::kF32, {1}, &z, 4);
  try {
    Metric3dModel::Create(sd, testing::ReadText(dir + "config.json"), "broken.pth");
    FAIL();
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("update_block.gru16.convq.bias"), std::string::npos) << msg;
    EXPECT_NE(msg.find("decoder.extra"), std::string::npos) << msg;
  }
}

// The GRU refinement runs `iters` times and its last iteration's mask upsamples the result: a config without one
// is refused by name, not run into an undefined tensor.
TEST(Metric3d, IterationCountOutsideItsRangeIsRefused) {
  const std::string dir = testing::TinyModelPath("metric3d/");
  const io::SafetensorsFile w = io::SafetensorsFile::Open(dir + "model.safetensors");
  std::map<std::string, io::TensorView> sd;
  for (const auto& n : w.names) sd[n] = w.Get(n);
  const std::string config = testing::ReadText(dir + "config.json");
  EXPECT_NO_THROW(Metric3dModel::Create(sd, config, "tiny"));
  for (const char* iters : {"0", "-3", "1000"}) {
    std::string bad = config;
    const size_t at = bad.find("\"iters\":", bad.find("\"decoder\""));
    ASSERT_NE(at, std::string::npos);
    const size_t value = at + std::strlen("\"iters\":");
    bad.replace(value, bad.find_first_of(",}", value) - value, std::string(" ") + iters);
    try {
      Metric3dModel::Create(sd, bad, "tiny");
      ADD_FAILURE() << "iters " << iters << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("\"iters\" is " + std::string(iters)), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace freeloc::nn
