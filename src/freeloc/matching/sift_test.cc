// The SIFT baseline on real TUM frames, and the geometry engine's acceptance check: on s00002 and s00003 of
// ../shared/data/tum_mapfree, freeloc's essential + scale must be at least as accurate as the official map-free
// recipe (OpenCV USAC_MAGSAC 3 px p=0.9999 + recoverPose + exhaustive 0.1 m scale) on the same correspondences and
// sensor depth. The correspondence files are saved for `freeloc pose`.
#include "freeloc/matching/sift.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>

#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/io/mapfree.h"
#include "testing/official_baseline.h"
#include "testing/testing.h"

namespace freeloc::matching {
namespace {

struct Errors {
  double rot_deg, centre_m;
};

Errors Compare(const Rigid3d& est, const Rigid3d& gt) {
  return {RotationAngleDeg(est.rotation, gt.rotation), (est.Center() - gt.Center()).norm()};
}

// ExtractSift once + MatchSiftFeatures per query gives exactly MatchSift's correspondences.
TEST(Sift, CachedReferenceFeaturesGiveTheSameMatches) {
  const io::MapfreeScene s = io::MapfreeScene::Load(testing::DemoPath("val/s00003"));
  const Image ref = s.LoadImage(s.reference), query = s.LoadImage(s.queries.at(0));
  const matching::Correspondences a = matching::MatchSift(ref, query);
  const matching::SiftFeatures fr = matching::ExtractSift(ref);
  EXPECT_LE(fr.size(), 2048u + 16u);  // OpenCV keeps ties at the cut
  EXPECT_EQ(fr.descriptors.size(), fr.size() * 128);
  const matching::Correspondences b = matching::MatchSiftFeatures(fr, matching::ExtractSift(query));
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 100u);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.ref[i], b.ref[i]);
    EXPECT_EQ(a.query[i], b.query[i]);
  }
}

TEST(Sift, FreelocBeatsOfficialRecipeOnRealTumPairs) {
  const std::string out_dir = std::string(FREELOC_BINARY_DIR) + "/test_outputs";
  std::filesystem::create_directories(out_dir);
  for (const char* name : {"s00002", "s00003"}) {
    SCOPED_TRACE(name);
    const io::MapfreeScene s = io::MapfreeScene::Load(testing::DemoPath(std::string("val/") + name));
    const io::MapfreeFrame& q = s.queries.at(0);
    const matching::Correspondences c = matching::MatchSift(s.LoadImage(s.reference), s.LoadImage(q));
    ASSERT_GT(c.size(), 100u);
    const DepthMap d0 = s.LoadDepth(s.reference, "sensor"), d1 = s.LoadDepth(q, "sensor");
    const Rigid3d gt = s.gt.at(q.name);
    // Save the correspondences for `freeloc pose`.
    std::ofstream f(out_dir + "/" + name + "_sift_matches.txt");
    f.precision(9);
    for (size_t i = 0; i < c.size(); ++i)
      f << c.ref[i].x() << " " << c.ref[i].y() << " " << c.query[i].x() << " " << c.query[i].y() << "\n";

    Rigid3d official;
    ASSERT_TRUE(testing::OfficialEssentialScale(c, s.reference.camera, q.camera, d0, d1, &official));
    const Errors eo = Compare(official, gt);

    // freeloc with its defaults (1 px Sampson threshold, robust scale).
    const auto rel = geometry::EstimateRelativePose(c.ref, c.query, s.reference.camera, q.camera);
    ASSERT_TRUE(rel.status.success());
    std::vector<Eigen::Vector2d> r, qq;
    for (size_t i = 0; i < c.size(); ++i)
      if (rel.inliers[i]) {
        r.push_back(c.ref[i]);
        qq.push_back(c.query[i]);
      }
    const auto sc = geometry::EstimateMetricScale(r, qq, rel.query_from_ref, d0, d1, s.reference.camera, q.camera);
    ASSERT_TRUE(sc.success());
    Rigid3d mine = rel.query_from_ref;
    mine.translation *= sc.scale;
    const Errors ef = Compare(mine, gt);
    std::printf(
        "%s: %zu matches | official: rot %.3f° centre %.2f cm | freeloc: rot %.3f° centre %.2f cm (%d inliers)\n", name,
        c.size(), eo.rot_deg, eo.centre_m * 100, ef.rot_deg, ef.centre_m * 100, rel.status.num_inliers);
    EXPECT_LE(ef.rot_deg, eo.rot_deg * 1.05 + 0.02);
    EXPECT_LE(ef.centre_m, eo.centre_m * 1.05 + 0.002);
  }
}

}  // namespace
}  // namespace freeloc::matching
