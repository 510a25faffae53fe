#include "freeloc/inputs/model_files.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/pipeline/relocalizer.h"
#include "testing/testing.h"

namespace freeloc::pipeline {
namespace {

// Sets $FREELOC_MODELS for one scope and restores the previous value.
class ScopedModelsEnv {
 public:
  explicit ScopedModelsEnv(const char* value) {
    if (const char* old = getenv("FREELOC_MODELS")) old_ = old, had_ = true;
    if (value)
      setenv("FREELOC_MODELS", value, 1);
    else
      unsetenv("FREELOC_MODELS");
  }
  ~ScopedModelsEnv() {
    if (had_)
      setenv("FREELOC_MODELS", old_.c_str(), 1);
    else
      unsetenv("FREELOC_MODELS");
  }

 private:
  std::string old_;
  bool had_ = false;
};

TEST(Models, FoundByPublishedNamesInModelsDirThenEnvironment) {
  ScopedModelsEnv env(nullptr);
  testing::TempDir a, b;
  // --models holds the DUSt3R .pth; $FREELOC_MODELS (second entry) the HF SegGPT layout and two Metric3D variants.
  testing::WriteText(a.File("DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth"), "x");
  std::filesystem::create_directories(b.File("seggpt-vit-large"));
  testing::WriteText(b.File("seggpt-vit-large/model.safetensors"), "x");
  testing::WriteText(b.File("metric_depth_vit_small_800k.pth"), "x");
  testing::WriteText(b.File("metric_depth_vit_large_800k.pth"), "x");
  EXPECT_EQ(inputs::FindModel(inputs::Network::kDust3r, inputs::ModelDirs(a.path())),
            a.File("DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth"));
  EXPECT_EQ(inputs::FindModel(inputs::Network::kSegGpt, inputs::ModelDirs(a.path())), "");
  ScopedModelsEnv set(("/nonexistent:" + b.path()).c_str());
  const auto dirs = inputs::ModelDirs(a.path());
  ASSERT_EQ(dirs.size(), 3u);
  EXPECT_EQ(dirs[0], a.path());
  EXPECT_EQ(inputs::FindModel(inputs::Network::kSegGpt, dirs), b.File("seggpt-vit-large/model.safetensors"));
  EXPECT_EQ(inputs::FindModel(inputs::Network::kMetric3d, dirs),
            b.File("metric_depth_vit_large_800k.pth"));  // large before small

  PipelineOptions o = ResolvePreset("seed");
  o.models.models_dir = a.path();
  FindModels(&o);
  EXPECT_EQ(o.models.dust3r_model, a.File("DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth"));
  EXPECT_EQ(o.models.seggpt_model, b.File("seggpt-vit-large/model.safetensors"));
  EXPECT_EQ(o.models.metric3d_model, b.File("metric_depth_vit_large_800k.pth"));
  EXPECT_NO_THROW(o.Validate());
  // An explicit file wins over discovery.
  PipelineOptions e = ResolvePreset("seed");
  e.models.models_dir = a.path();
  e.models.metric3d_model = "/my/metric3d.safetensors";
  FindModels(&e);
  EXPECT_EQ(e.models.metric3d_model, "/my/metric3d.safetensors");
}

TEST(Models, MissingWeightsNameTheFileWhereToGetItAndTheAlternatives) {
  ScopedModelsEnv env(nullptr);
  testing::TempDir a;
  for (const char* preset : {"seed", "seed-no-instance", "seed-provided-depth", "dust3r"}) {
    SCOPED_TRACE(preset);
    PipelineOptions o = ResolvePreset(preset);
    o.models.models_dir = a.path();
    FindModels(&o);
    try {
      o.Validate();
      FAIL() << "no weights, yet valid";
    } catch (const Error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth"), std::string::npos) << m;
      EXPECT_NE(m.find(a.path()), std::string::npos) << m;
      EXPECT_NE(m.find("docs/models.md"), std::string::npos) << m;
      EXPECT_NE(m.find("sift-essential"), std::string::npos) << m;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
  }
  // With DUSt3R given, seed-no-instance asks for Metric3D next, seed-provided-depth for SegGPT.
  PipelineOptions o = ResolvePreset("seed-no-instance");
  o.models.dust3r_model = "d.pth";
  try {
    o.Validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("metric_depth_vit_giant2_800k.pth"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("neither models_dir nor $FREELOC_MODELS"), std::string::npos) << e.what();
  }
  PipelineOptions p = ResolvePreset("seed-provided-depth");
  p.models.dust3r_model = "d.pth";
  try {
    p.Validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("seggpt_vit_large.pth"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace freeloc::pipeline
