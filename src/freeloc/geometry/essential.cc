#include "freeloc/geometry/essential.h"

#include <Eigen/Dense>
#include <cmath>

namespace freeloc::geometry {

Eigen::Matrix3d EssentialFromPose(const PoseRt& p) { return Skew(p.t) * p.R; }

// Hartley & Zisserman, Multiple View Geometry, 2nd ed., Result 9.19: E = U·diag(1,1,0)·Vᵀ gives
// R ∈ {U·W·Vᵀ, U·Wᵀ·Vᵀ} and t = ±u₃.
void DecomposeEssential(const Eigen::Matrix3d& E, PoseRt out[4]) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  if (U.determinant() < 0) U.col(2) *= -1;
  if (V.determinant() < 0) V.col(2) *= -1;
  Eigen::Matrix3d W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d R1 = U * W * V.transpose(), R2 = U * W.transpose() * V.transpose();
  const Eigen::Vector3d t = U.col(2).normalized();
  out[0] = {R1, t};
  out[1] = {R1, -t};
  out[2] = {R2, t};
  out[3] = {R2, -t};
}

bool TriangulateDepths(const PoseRt& p, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, double* d1, double* d2) {
  // λ1·(R·x1) − λ2·x2 = −t in least squares.
  const Eigen::Vector3d a = p.R * x1;
  const Eigen::Vector3d& b = x2;
  const double aa = a.dot(a), ab = a.dot(b), bb = b.dot(b), at = a.dot(p.t), bt = b.dot(p.t);
  const double det = aa * bb - ab * ab;
  if (std::abs(det) < 1e-12 * aa * bb) return false;
  *d1 = (-at * bb + ab * bt) / det;
  *d2 = (aa * bt - ab * at) / det;
  return true;
}

bool InFront(const PoseRt& p, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2) {
  double d1, d2;
  return TriangulateDepths(p, x1, x2, &d1, &d2) && d1 > 0 && d2 > 0;
}

}  // namespace freeloc::geometry
