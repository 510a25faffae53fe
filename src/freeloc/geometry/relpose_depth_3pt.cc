#include "freeloc/geometry/relpose_depth_3pt.h"

#include <Eigen/Dense>
#include <cmath>

namespace freeloc::geometry {

bool AlignRigid(const Eigen::Vector3d* a, const Eigen::Vector3d* b, int n, Eigen::Matrix3d* R, Eigen::Vector3d* t) {
  if (n < 3) return false;
  Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    ca += a[i];
    cb += b[i];
  }
  ca /= n;
  cb /= n;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  double spread = 0;
  for (int i = 0; i < n; ++i) {
    H += (b[i] - cb) * (a[i] - ca).transpose();
    spread += (a[i] - ca).squaredNorm();
  }
  if (!(spread > 0) || !H.allFinite()) return false;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  // A triangle's cross-covariance has rank 2; a line's rank 1: then the rotation about it is free.
  if (sv(1) <= 1e-10 * sv(0) || sv(0) <= 0) return false;
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  *R = svd.matrixU() * D * svd.matrixV().transpose();
  *t = cb - *R * ca;
  return R->allFinite() && t->allFinite();
}

int RelPoseDepthScale3pt(const Eigen::Vector3d x[3], const double dr[3], const Eigen::Vector3d y[3], const double dq[3],
                         std::vector<DepthRelPose>* out) {
  Eigen::Vector3d a[3], b[3];
  for (int i = 0; i < 3; ++i) {
    if (!(dr[i] > 0) || !(dq[i] > 0)) return 0;
    a[i] = dr[i] * x[i];
    b[i] = dq[i] * y[i];
  }
  // s² = Σ‖a_i − a_j‖² / Σ‖b_i − b_j‖²: the least-squares ratio of the side lengths (squared).
  double la = 0, lb = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      la += (a[i] - a[j]).squaredNorm();
      lb += (b[i] - b[j]).squaredNorm();
    }
  if (!(la > 0) || !(lb > 0)) return 0;
  DepthRelPose p;
  p.scale = std::sqrt(la / lb);
  for (int i = 0; i < 3; ++i) b[i] *= p.scale;
  if (!AlignRigid(a, b, 3, &p.R, &p.t)) return 0;
  out->push_back(p);
  return 1;
}

}  // namespace freeloc::geometry
