#include "freeloc/geometry/relpose_depth_shift_3pt.h"

#include <algorithm>
#include <cmath>

#include "freeloc/geometry/polynomial.h"

namespace freeloc::geometry {

namespace {

// ‖(d_i + w)·r_i − (d_j + w)·r_j‖² as a quadratic in the shift w (coefficients lowest first).
Poly SideSquared(const Eigen::Vector3d& ri, double di, const Eigen::Vector3d& rj, double dj) {
  const Eigen::Vector3d P = di * ri - dj * rj, D = ri - rj;
  return {P.dot(P), 2 * P.dot(D), D.dot(D)};
}

// E(u, v) = A1(u)·B2(v) − A2(u)·B1(v) as the three coefficients (in v) that are quadratics in u.
void Eliminated(const Poly& A1, const Poly& A2, const Poly& B1, const Poly& B2, Poly c[3]) {
  for (int k = 0; k < 3; ++k) c[k] = PolySub(PolyScale(A1, B2[k]), PolyScale(A2, B1[k]));
}

double Quad(const Poly& p, double x) { return p[0] + x * (p[1] + x * p[2]); }

}  // namespace

int RelPoseDepthShift3pt(const Eigen::Vector3d x[3], const double dr[3], const Eigen::Vector3d y[3], const double dq[3],
                         std::vector<DepthRelPose>* out) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(dr[i]) || !std::isfinite(dq[i])) return 0;
  const Poly A12 = SideSquared(x[0], dr[0], x[1], dr[1]), A13 = SideSquared(x[0], dr[0], x[2], dr[2]),
             A23 = SideSquared(x[1], dr[1], x[2], dr[2]);
  const Poly B12 = SideSquared(y[0], dq[0], y[1], dq[1]), B13 = SideSquared(y[0], dq[0], y[2], dq[2]),
             B23 = SideSquared(y[1], dq[1], y[2], dq[2]);
  // p(v) = A12·B13 − A13·B12 = 0 and q(v) = A12·B23 − A23·B12 = 0 (s² eliminated).
  Poly p[3], q[3];
  Eliminated(A12, A13, B12, B13, p);
  Eliminated(A12, A23, B12, B23, q);
  // Resultant of two quadratics in v: (p2q0 − p0q2)² − (p2q1 − p1q2)(p1q0 − p0q1), degree 8 in u.
  const Poly m = PolySub(PolyMul(p[2], q[0]), PolyMul(p[0], q[2]));
  const Poly n = PolySub(PolyMul(p[2], q[1]), PolyMul(p[1], q[2]));
  const Poly o = PolySub(PolyMul(p[1], q[0]), PolyMul(p[0], q[1]));
  Poly res = PolySub(PolyMul(m, m), PolyMul(n, o));
  double big = 0;
  for (double c : res) big = std::max(big, std::abs(c));
  if (!(big > 0) || !std::isfinite(big)) return 0;
  for (double& c : res) c /= big;
  while (res.size() > 1 && std::abs(res.back()) < 1e-14) res.pop_back();
  if (res.size() < 2) return 0;
  const double min_dr = std::min({dr[0], dr[1], dr[2]}), min_dq = std::min({dq[0], dq[1], dq[2]});
  int added = 0;
  for (double u : RealRoots(res)) {
    if (!(min_dr + u > 0)) continue;
    double pc[3], qc[3];
    for (int k = 0; k < 3; ++k) {
      pc[k] = PolyEval(p[k], u);
      qc[k] = PolyEval(q[k], u);
    }
    // The common root of p(v) and q(v): q2·p − p2·q is linear in v; when it vanishes, the roots of p checked on q.
    std::vector<double> cands;
    const double den = qc[2] * pc[1] - pc[2] * qc[1];
    const double scale = std::abs(qc[2] * pc[1]) + std::abs(pc[2] * qc[1]) + 1e-300;
    if (std::abs(den) > 1e-10 * scale) {
      cands.push_back((pc[2] * qc[0] - qc[2] * pc[0]) / den);
    } else if (std::abs(pc[2]) > 0) {
      const double disc = pc[1] * pc[1] - 4 * pc[2] * pc[0];
      if (disc >= 0) {
        cands.push_back((-pc[1] + std::sqrt(disc)) / (2 * pc[2]));
        cands.push_back((-pc[1] - std::sqrt(disc)) / (2 * pc[2]));
      }
    }
    for (double v : cands) {
      if (!std::isfinite(v) || !(min_dq + v > 0)) continue;
      const double b12 = Quad(B12, v);
      if (!(b12 > 0)) continue;
      const double s2 = Quad(A12, u) / b12;
      if (!(s2 > 0) || !std::isfinite(s2)) continue;
      DepthRelPose sol;
      sol.scale = std::sqrt(s2);
      sol.shift_ref = u;
      sol.shift_query = v;
      Eigen::Vector3d a[3], b[3];
      for (int i = 0; i < 3; ++i) {
        a[i] = (dr[i] + u) * x[i];
        b[i] = sol.scale * (dq[i] + v) * y[i];
      }
      // The other two sides must agree too (a spurious root of the resultant satisfies only the eliminated pair).
      const double e13 = std::abs((a[0] - a[2]).squaredNorm() - (b[0] - b[2]).squaredNorm());
      const double e23 = std::abs((a[1] - a[2]).squaredNorm() - (b[1] - b[2]).squaredNorm());
      const double ref = (a[0] - a[1]).squaredNorm() + (a[0] - a[2]).squaredNorm() + (a[1] - a[2]).squaredNorm();
      if (!(e13 + e23 <= 1e-6 * ref)) continue;
      if (!AlignRigid(a, b, 3, &sol.R, &sol.t)) continue;
      out->push_back(sol);
      ++added;
    }
  }
  return added;
}

}  // namespace freeloc::geometry
