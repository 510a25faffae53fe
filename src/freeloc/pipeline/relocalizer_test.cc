#include "freeloc/pipeline/relocalizer.h"

#include <gtest/gtest.h>

#include "freeloc/core/error.h"
#include "testing/testing.h"

namespace freeloc::pipeline {
namespace {

// sift-essential with the sensor depth on the real TUM scenes: errors near the geometry engine's (s00002: 3.7 cm
// baseline with unmodelled lens distortion; s00003: pseudo ground truth).
TEST(Relocalizer, SiftEssentialOnTumScenes) {
  FREELOC_REQUIRE_SHARED("data/tum_mapfree/val/s00002/poses.txt");
  const PipelineOptions o = ResolvePreset("sift-essential");
  for (const char* name : {"s00002", "s00003"}) {
    SCOPED_TRACE(name);
    const MapfreeScene s = MapfreeScene::Load(testing::SharedPath(std::string("data/tum_mapfree/val/") + name));
    const auto res = RelocalizeScene(s, o);
    ASSERT_EQ(res.size(), 1u);
    ASSERT_TRUE(res[0].ok) << res[0].status;
    EXPECT_EQ(res[0].status, "ok");
    const Rigid3d& gt = s.gt.at(res[0].frame);
    EXPECT_LT(RotationAngleDeg(res[0].query_from_ref.rotation, gt.rotation), 1.5);
    EXPECT_LT((res[0].query_from_ref.Center() - gt.Center()).norm(), 0.03);
    EXPECT_GT(res[0].confidence, 0);
  }
  // A scene without depth: every query fails with a status, nothing thrown.
  const MapfreeScene s1 = MapfreeScene::Load(testing::SharedPath("data/tum_mapfree/val/s00001"));
  const auto r1 = RelocalizeScene(s1, o);
  ASSERT_EQ(r1.size(), 5u);
  for (const auto& q : r1) {
    EXPECT_FALSE(q.ok);
    EXPECT_EQ(q.status, "no-depth");
  }
  // Without depth the essential solver gives unit translations.
  PipelineOptions nd = o;
  nd.depth = "none";
  const auto r2 = RelocalizeScene(s1, nd);
  int ok = 0;
  for (const auto& q : r2) {
    ok += q.ok;
    if (q.ok) {
      EXPECT_EQ(q.status, "ok-unit-translation");
      EXPECT_NEAR(q.query_from_ref.translation.norm(), 1.0, 1e-9);
    }
  }
  EXPECT_GE(ok, 4);
}

TEST(Relocalizer, PresetsAndOverrides) {
  EXPECT_EQ(ResolvePreset("sift-pnp").solver, "pnp");
  EXPECT_EQ(ResolvePreset("precomputed:LoFTR-procrustes").matcher, "precomputed:LoFTR");
  EXPECT_EQ(ResolvePreset("precomputed:SG-essential").threshold_px, 2.0);
  EXPECT_THROW(ResolvePreset("magic"), Error);
  EXPECT_THROW(ResolvePreset("precomputed:SIFT"), Error);
  try {
    ResolvePreset("seed");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not wired into the pipeline"), std::string::npos) << e.what();
  }
  PipelineOptions o = ResolvePreset("sift-pnp");
  o.depth = "none";
  EXPECT_THROW(o.Validate(), Error);
  o.depth = "prov:x";
  EXPECT_THROW(o.Validate(), Error);
  // dust3r: a real matcher now, but only with its weights named.
  PipelineOptions d = ResolvePreset("dust3r");
  EXPECT_EQ(d.matcher, "dust3r");
  EXPECT_EQ(d.solver, "essential");
  EXPECT_THROW(d.Validate(), Error);
  d.dust3r_model = "weights.pth";
  EXPECT_NO_THROW(d.Validate());
  EXPECT_NE(d.Summary().find("dust3r weights.pth at 512"), std::string::npos) << d.Summary();
  d.dust3r_size = 100;
  EXPECT_THROW(d.Validate(), Error);
}

}  // namespace
}  // namespace freeloc::pipeline
