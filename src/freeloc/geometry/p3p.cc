#include "freeloc/geometry/p3p.h"

#include <Eigen/Dense>
#include <cmath>

#include "freeloc/geometry/polynomial.h"

namespace freeloc::geometry {

PoseRt RigidAlign(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  // S. Umeyama, "Least-squares estimation of transformation parameters between two point patterns", TPAMI 1991.
  const size_t n = src.size();
  Eigen::Vector3d ms = Eigen::Vector3d::Zero(), md = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    ms += src[i];
    md += dst[i];
  }
  ms /= static_cast<double>(n);
  md /= static_cast<double>(n);
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < n; ++i) C += (dst[i] - md) * (src[i] - ms).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  PoseRt p;
  p.R = svd.matrixU() * D * svd.matrixV().transpose();
  p.t = md - p.R * ms;
  return p;
}

int P3P(const Eigen::Vector3d X[3], const Eigen::Vector3d bin[3], std::vector<PoseRt>* poses) {
  Eigen::Vector3d j[3];
  for (int i = 0; i < 3; ++i) j[i] = bin[i].normalized();
  const double a2 = (X[1] - X[2]).squaredNorm(), b2 = (X[0] - X[2]).squaredNorm(), c2 = (X[0] - X[1]).squaredNorm();
  if (a2 < 1e-18 || b2 < 1e-18 || c2 < 1e-18) return 0;
  const double ca = j[1].dot(j[2]), cb = j[0].dot(j[2]), cg = j[0].dot(j[1]);
  // Unknown distances s1, s2 = u·s1, s3 = v·s1. Law of cosines:
  //   s1²(u² + v² − 2uv·cosα) = a², s1²(1 + v² − 2v·cosβ) = b², s1²(1 + u² − 2u·cosγ) = c².
  // Eliminating u² between the a- and c-equations (both divided by the b-equation) gives u = N(v)/D(v), with
  //   N(v) = (a² − c²)(1 + v² − 2v·cosβ) − b²(v² − 1),  D(v) = 2b²(cosγ − v·cosα),
  // and substituting into the c-equation: b²N² − 2b²·cosγ·N·D + (b² − c²(1 + v² − 2v·cosβ))·D² = 0, a quartic.
  const Poly w = {1.0, -2.0 * cb, 1.0};  // 1 + v² − 2v·cosβ
  const Poly N = PolySub(PolyScale(w, a2 - c2), PolyScale(Poly{-1.0, 0.0, 1.0}, b2));
  const Poly D = {2 * b2 * cg, -2 * b2 * ca};
  const Poly quartic = PolyAdd(PolySub(PolyScale(PolyMul(N, N), b2), PolyScale(PolyMul(N, D), 2 * b2 * cg)),
                               PolyMul(PolySub(Poly{b2}, PolyScale(w, c2)), PolyMul(D, D)));
  int found = 0;
  for (double v : RealRoots(quartic)) {
    if (v <= 0) continue;
    const double d = PolyEval(D, v);
    if (std::abs(d) < 1e-14) continue;
    const double u = PolyEval(N, v) / d;
    if (u <= 0) continue;
    const double den = 1 + v * v - 2 * v * cb;
    if (den <= 0) continue;
    const double s1 = std::sqrt(b2 / den);
    const std::vector<Eigen::Vector3d> cam = {s1 * j[0], u * s1 * j[1], v * s1 * j[2]};
    const std::vector<Eigen::Vector3d> src = {X[0], X[1], X[2]};
    PoseRt p = RigidAlign(src, cam);
    if (!p.R.allFinite() || !p.t.allFinite()) continue;
    poses->push_back(p);
    ++found;
  }
  return found;
}

}  // namespace freeloc::geometry
