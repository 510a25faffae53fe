#include "freeloc/geometry/rotation_only.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

#include "freeloc/geometry/metric_scale.h"

namespace freeloc::geometry {

Eigen::Matrix3d RotationBetweenBearings(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) h += b[i] * a[i].transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

namespace {

// ransac.h's estimator: data are unit bearings, the error the squared sine of the angle between b_i and R·a_i.
class RotationEstimator {
 public:
  using Model = Eigen::Matrix3d;
  static constexpr int kSampleSize = 2;
  static constexpr double kSolveCost = 10;
  RotationEstimator(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) : a_(a), b_(b) {}
  size_t num_data() const { return a_.size(); }
  void MinimalSolve(const int* sample, std::vector<Model>* models) const {
    models->clear();
    const Eigen::Vector3d &a0 = a_[sample[0]], &a1 = a_[sample[1]];
    if (a0.cross(a1).norm() < 1e-6) return;  // the same direction twice: no rotation
    models->push_back(RotationBetweenBearings({a0, a1}, {b_[sample[0]], b_[sample[1]]}));
  }
  double SquaredError(const Model& r, size_t i) const { return (r * a_[i]).cross(b_[i]).squaredNorm(); }
  void LocalOptimize(Model* r, double threshold_sq) const {
    std::vector<Eigen::Vector3d> a, b;
    for (size_t i = 0; i < a_.size(); ++i)
      if (SquaredError(*r, i) < threshold_sq) {
        a.push_back(a_[i]);
        b.push_back(b_[i]);
      }
    if (a.size() >= 2) *r = RotationBetweenBearings(a, b);
  }

 private:
  const std::vector<Eigen::Vector3d>& a_;
  const std::vector<Eigen::Vector3d>& b_;
};

}  // namespace

RotationOnlyResult EstimateRotationOnly(const std::vector<Eigen::Vector2d>& px_ref,
                                        const std::vector<Eigen::Vector2d>& px_query, const Camera& ref,
                                        const Camera& query, double threshold_px, const RansacOptions& ransac) {
  RotationOnlyResult res;
  const size_t n = std::min(px_ref.size(), px_query.size());
  res.inliers.assign(n, 0);
  std::vector<Eigen::Vector3d> a(n), b(n);
  for (size_t i = 0; i < n; ++i) {
    a[i] = ref.Unproject(px_ref[i].x(), px_ref[i].y()).normalized();
    b[i] = query.Unproject(px_query[i].x(), px_query[i].y()).normalized();
  }
  const double focal = 0.25 * (ref.fx + ref.fy + query.fx + query.fy);
  const double th = threshold_px / focal;
  const RotationEstimator est(a, b);
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  const RansacStats st = Ransac(est, ransac, th * th, &r);
  if (!st.found()) return res;
  est.LocalOptimize(&r, th * th);
  double sq = 0;
  for (size_t i = 0; i < n; ++i) {
    const double e = est.SquaredError(r, i);
    if (e < th * th) {
      res.inliers[i] = 1;
      ++res.num_inliers;
      sq += e;
    }
  }
  res.query_from_ref = r;
  res.residual_px = res.num_inliers ? std::sqrt(sq / res.num_inliers) * focal : 0;
  res.found = res.num_inliers >= 2;
  return res;
}

DepthTranslation TranslationFromDepths(const std::vector<Eigen::Vector2d>& px_ref,
                                       const std::vector<Eigen::Vector2d>& px_query, const Camera& ref,
                                       const Camera& query, const RotationOnlyResult& rotation, const DepthMap& d_ref,
                                       const DepthMap& d_query) {
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  DepthTranslation out;
  std::vector<Eigen::Vector3d> diff;
  double depth_sum = 0;
  for (size_t i = 0; i < rotation.inliers.size() && i < px_ref.size(); ++i) {
    if (!rotation.inliers[i]) continue;
    const double zr = BilinearDepth(d_ref, px_ref[i].x(), px_ref[i].y());
    const double zq = BilinearDepth(d_query, px_query[i].x(), px_query[i].y());
    if (!(zr > 0) || !(zq > 0)) continue;
    diff.push_back(zq * query.Unproject(px_query[i].x(), px_query[i].y()) -
                   rotation.query_from_ref * (zr * ref.Unproject(px_ref[i].x(), px_ref[i].y())));
    depth_sum += zr;
  }
  out.samples = static_cast<int>(diff.size());
  if (diff.size() < 5) return out;
  for (int k = 0; k < 3; ++k) {
    std::vector<double> v;
    for (const auto& d : diff) v.push_back(d[k]);
    out.t[k] = median(std::move(v));
  }
  std::vector<double> dev;
  for (const auto& d : diff) dev.push_back((d - out.t).norm());
  const double mad = median(dev);
  out.mean_depth_m = depth_sum / static_cast<double>(diff.size());
  for (double d : dev) out.agree += d <= std::max(3 * 1.4826 * mad, 0.01 * out.mean_depth_m);
  out.std_error_m = 1.4826 * mad / std::sqrt(std::max(1, out.agree));
  out.found = true;
  return out;
}

}  // namespace freeloc::geometry
