// The SIFT baseline on real TUM frames, and the geometry engine's acceptance check: on s00002 and s00003 of
// ../shared/data/tum_mapfree, freeloc's essential + scale must be at least as accurate as the official map-free
// recipe (OpenCV USAC_MAGSAC 3 px p=0.9999 + recoverPose + exhaustive 0.1 m scale) on the same correspondences and
// sensor depth. The correspondence files are saved for `freeloc pose`.
#include "freeloc/matching/sift.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/relative_pose.h"
#include "freeloc/io/mapfree.h"
#include "testing/testing.h"

namespace freeloc {
namespace {

struct Errors {
  double rot_deg, centre_m;
};

Errors Compare(const Rigid3d& est, const Rigid3d& gt) {
  return {RotationAngleDeg(est.rotation, gt.rotation), (est.Center() - gt.Center()).norm()};
}

// The official recipe (map-free EssentialMatrixMetricSolver).
bool OfficialRecipe(const matching::Correspondences& c, const Camera& k0, const Camera& k1, const DepthMap& d0,
                    const DepthMap& d1, Rigid3d* out) {
  std::vector<cv::Point2d> a, b;
  for (size_t i = 0; i < c.size(); ++i) {
    a.emplace_back((c.ref[i].x() - k0.cx) / k0.fx, (c.ref[i].y() - k0.cy) / k0.fy);
    b.emplace_back((c.query[i].x() - k1.cx) / k1.fx, (c.query[i].y() - k1.cy) / k1.fy);
  }
  const double thr = 3.0 / ((k0.fx + k1.fy + k0.fy + k1.fx) / 4);
  cv::Mat mask;
  cv::Mat E = cv::findEssentialMat(a, b, cv::Mat::eye(3, 3, CV_64F), cv::USAC_MAGSAC, 0.9999, thr, mask);
  if (E.empty()) return false;
  int best = 0;
  cv::Mat R, t;
  for (int k = 0; k + 3 <= E.rows; k += 3) {
    cv::Mat Rk, tk, m = mask.clone();
    const int n = cv::recoverPose(E.rowRange(k, k + 3), a, b, cv::Mat::eye(3, 3, CV_64F), Rk, tk, 1e9, m);
    if (n > best) {
      best = n;
      R = Rk;
      t = tk;
    }
  }
  if (best == 0) return false;
  Eigen::Matrix3d Re;
  Eigen::Vector3d te;
  cv::cv2eigen(R, Re);
  cv::cv2eigen(t, te);
  std::vector<Eigen::Vector2d> r, q;
  for (size_t i = 0; i < c.size(); ++i)
    if (mask.at<uchar>(static_cast<int>(i))) {
      r.push_back(c.ref[i]);
      q.push_back(c.query[i]);
    }
  geometry::ScaleOptions so;
  so.method = geometry::ScaleMethod::kOfficial;
  const auto s = geometry::EstimateMetricScale(r, q, Rigid3d(Re, te), d0, d1, k0, k1, so);
  if (!s.success) return false;
  *out = Rigid3d(Re, te.normalized() * s.scale);
  return true;
}

TEST(Sift, FreelocBeatsOfficialRecipeOnRealTumPairs) {
  FREELOC_REQUIRE_SHARED("data/tum_mapfree/val/s00002/poses.txt");
  const std::string out_dir = std::string(FREELOC_BINARY_DIR) + "/test_outputs";
  std::filesystem::create_directories(out_dir);
  for (const char* name : {"s00002", "s00003"}) {
    SCOPED_TRACE(name);
    const MapfreeScene s = MapfreeScene::Load(testing::SharedPath(std::string("data/tum_mapfree/val/") + name));
    const MapfreeFrame& q = s.queries.at(0);
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
    ASSERT_TRUE(OfficialRecipe(c, s.reference.camera, q.camera, d0, d1, &official));
    const Errors eo = Compare(official, gt);

    // freeloc with its defaults (1 px Sampson threshold, robust scale).
    const auto rel = geometry::EstimateRelativePose(c.ref, c.query, s.reference.camera, q.camera);
    ASSERT_TRUE(rel.status.success);
    std::vector<Eigen::Vector2d> r, qq;
    for (size_t i = 0; i < c.size(); ++i)
      if (rel.inliers[i]) {
        r.push_back(c.ref[i]);
        qq.push_back(c.query[i]);
      }
    const auto sc = geometry::EstimateMetricScale(r, qq, rel.query_from_ref, d0, d1, s.reference.camera, q.camera);
    ASSERT_TRUE(sc.success);
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
}  // namespace freeloc
