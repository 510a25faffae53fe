#include "freeloc/geometry/essential.h"

#include <Eigen/Dense>
#include <cmath>

namespace freeloc::geometry {

Eigen::Matrix3d EssentialFromPose(const PoseRt& p) { return Skew(p.t) * p.R; }

// Hartley & Zisserman, Multiple View Geometry, 2nd ed., Result 9.19: E = U·diag(1,1,0)·Vᵀ gives
// R ∈ {U·W·Vᵀ, U·Wᵀ·Vᵀ} and t = ±u₃.
namespace {

void DecomposeEssentialSvd(const Eigen::Matrix3d& E, PoseRt out[4]) {
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

}  // namespace

void DecomposeEssential(const Eigen::Matrix3d& E_in, PoseRt out[4]) {
  // B. K. P. Horn, "Recovering baseline and orientation from essential matrix", JOSA A, 1990: with E = [t]×R
  // scaled to ‖E‖²_F = 2 and |t| = 1, cof(E) = t·tᵀ·R and [t]×E = (t·tᵀ − I)·R, so R = cof(E) − [t]×E, and the
  // twisted pair (rotated by π about t) is cof(E) + [t]×E. t spans the left null space: the largest cross product
  // of two columns. No SVD — the 5-point solver decomposes every root of every sample.
  const double norm = E_in.norm();
  if (norm > 0 && std::isfinite(norm)) {
    const Eigen::Matrix3d E = E_in * (std::sqrt(2.0) / norm);
    Eigen::Vector3d t = E.col(0).cross(E.col(1));
    for (const Eigen::Vector3d& c : {E.col(0).cross(E.col(2)), E.col(1).cross(E.col(2))})
      if (c.squaredNorm() > t.squaredNorm()) t = c;
    if (t.squaredNorm() > 1e-20) {
      t.normalize();
      Eigen::Matrix3d cof;  // the cofactor matrix: its columns are cross products of E's columns
      cof.col(0) = E.col(1).cross(E.col(2));
      cof.col(1) = E.col(2).cross(E.col(0));
      cof.col(2) = E.col(0).cross(E.col(1));
      const Eigen::Matrix3d tE = Skew(t) * E;
      const Eigen::Matrix3d Ra = cof - tE, Rb = cof + tE;
      // E is essential only up to rounding: project each onto the rotations (a unit quaternion).
      const Eigen::Matrix3d R1 = Eigen::Quaterniond(Ra).normalized().toRotationMatrix();
      const Eigen::Matrix3d R2 = Eigen::Quaterniond(Rb).normalized().toRotationMatrix();
      // Far from a rotation means E was far from essential: the SVD projection below handles that.
      if (R1.allFinite() && R2.allFinite() && (R1 - Ra).squaredNorm() < 1e-6 && (R2 - Rb).squaredNorm() < 1e-6) {
        out[0] = {R1, t};
        out[1] = {R1, -t};
        out[2] = {R2, t};
        out[3] = {R2, -t};
        return;
      }
    }
  }
  DecomposeEssentialSvd(E_in, out);
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
