// The map-free benchmark code's Ess.Mat + D.Scale solver (EssentialMatrixMetricSolver, nianticlabs/map-free-reloc
// §4) reproduced with the same OpenCV calls, for side-by-side comparisons in tests and benchmarks: pixels normalised
// by each K, findEssentialMat(USAC_MAGSAC, prob 0.9999, 3 px / mean focal) on identity K, recoverPose per returned
// E (no depth cut) keeping the one with most cheirality inliers, the official scale vote on the essential inliers,
// confidence = its support. Header-only; needs opencv_calib3d.
#pragma once

#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <vector>

#include "freeloc/geometry/metric_scale.h"
#include "freeloc/matching/correspondences.h"

namespace freeloc::testing {

inline bool OfficialEssentialScale(const matching::Correspondences& c, const Camera& k0, const Camera& k1,
                                   const DepthMap& d0, const DepthMap& d1, Rigid3d* out, double* confidence = nullptr,
                                   double pix_threshold = 3.0) {
  if (c.size() < 5) return false;
  std::vector<cv::Point2d> a, b;
  for (size_t i = 0; i < c.size(); ++i) {
    a.emplace_back((c.ref[i].x() - k0.cx) / k0.fx, (c.ref[i].y() - k0.cy) / k0.fy);
    b.emplace_back((c.query[i].x() - k1.cx) / k1.fx, (c.query[i].y() - k1.cy) / k1.fy);
  }
  const double thr = pix_threshold / ((k0.fx + k1.fy + k0.fy + k1.fx) / 4);
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
  if (!s.success()) return false;
  *out = Rigid3d(Re, te.normalized() * s.scale);
  if (confidence) *confidence = s.confidence;
  return true;
}

}  // namespace freeloc::testing
