#include "freeloc/geometry/five_point.h"

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <utility>

#include "freeloc/geometry/polynomial.h"

namespace freeloc::geometry {

namespace {

// Monomials in (x, y, z). Linear: [x, y, z, 1]. Quadratic: the 10 monomials of degree ≤ 2. Cubic: the 20 monomials
// of degree ≤ 3 in Nistér's column order, so that Gauss–Jordan on the first 10 columns leaves the pairs
// (x²z, x²), (y²z, y²), (xyz, xy) whose z-differences eliminate x and y.
using Lin = std::array<double, 4>;
using Quad = std::array<double, 10>;
using Cubic = std::array<double, 20>;

struct Exp {
  int a, b, c;
};
constexpr Exp kLinExp[4] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
constexpr Exp kQuadExp[10] = {{2, 0, 0}, {1, 1, 0}, {1, 0, 1}, {0, 2, 0}, {0, 1, 1},
                              {0, 0, 2}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
constexpr Exp kCubicExp[20] = {{3, 0, 0}, {0, 3, 0}, {2, 1, 0}, {1, 2, 0}, {2, 0, 1}, {2, 0, 0}, {0, 2, 1},
                               {0, 2, 0}, {1, 1, 1}, {1, 1, 0}, {1, 0, 2}, {1, 0, 1}, {1, 0, 0}, {0, 1, 2},
                               {0, 1, 1}, {0, 1, 0}, {0, 0, 3}, {0, 0, 2}, {0, 0, 1}, {0, 0, 0}};

struct Tables {
  int lin_lin[4][4] = {};    // → quad index
  int quad_lin[10][4] = {};  // → cubic index
  constexpr Tables() {
    auto find_q = [](int a, int b, int c) {
      for (int i = 0; i < 10; ++i)
        if (kQuadExp[i].a == a && kQuadExp[i].b == b && kQuadExp[i].c == c) return i;
      return -1;
    };
    auto find_c = [](int a, int b, int c) {
      for (int i = 0; i < 20; ++i)
        if (kCubicExp[i].a == a && kCubicExp[i].b == b && kCubicExp[i].c == c) return i;
      return -1;
    };
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        lin_lin[i][j] = find_q(kLinExp[i].a + kLinExp[j].a, kLinExp[i].b + kLinExp[j].b, kLinExp[i].c + kLinExp[j].c);
    for (int i = 0; i < 10; ++i)
      for (int j = 0; j < 4; ++j)
        quad_lin[i][j] =
            find_c(kQuadExp[i].a + kLinExp[j].a, kQuadExp[i].b + kLinExp[j].b, kQuadExp[i].c + kLinExp[j].c);
  }
};
// Built at compile time: the products below then index with constants the compiler can unroll.
constexpr Tables kTables{};

void MulAdd(const Lin& a, const Lin& b, double s, Quad* out) {
  constexpr const Tables& t = kTables;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) (*out)[t.lin_lin[i][j]] += s * a[i] * b[j];
}

void MulAdd(const Quad& a, const Lin& b, double s, Cubic* out) {
  constexpr const Tables& t = kTables;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 4; ++j) (*out)[t.quad_lin[i][j]] += s * a[i] * b[j];
}

// The null space of the epipolar constraints x2ᵀ·E·x1 = 0 (rows over vec(E), row-major): the last 4 columns of the
// orthogonal factor of a QR of Qᵀ (numerically the most accurate choice; Gauss–Jordan is faster but loses digits on
// near-degenerate samples). Columns X, Y, Z, W: E = x·X + y·Y + z·Z + W.
Eigen::Matrix<double, 9, 4> NullSpace(const Eigen::Vector3d x1[5], const Eigen::Vector3d x2[5]) {
  Eigen::Matrix<double, 9, 5> Qt;
  for (int i = 0; i < 5; ++i) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) Qt(3 * r + c, i) = x2[i](r) * x1[i](c);
  }
  const Eigen::HouseholderQR<Eigen::Matrix<double, 9, 5>> qr(Qt);
  Eigen::Matrix<double, 9, 4> N = Eigen::Matrix<double, 9, 4>::Zero();
  N.bottomRows<4>().setIdentity();
  N.applyOnTheLeft(qr.householderQ());
  return N;
}

// The 10 cubic constraints over the 20 monomials: det(E) = 0 and 2·E·Eᵀ·E − tr(E·Eᵀ)·E = 0.
Eigen::Matrix<double, 10, 20> CubicConstraints(const Eigen::Matrix<double, 9, 4>& N) {
  Lin e[3][3];  // E entries as linear polynomials in (x, y, z)
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) e[r][c] = {N(3 * r + c, 0), N(3 * r + c, 1), N(3 * r + c, 2), N(3 * r + c, 3)};
  Eigen::Matrix<double, 10, 20> A = Eigen::Matrix<double, 10, 20>::Zero();
  Cubic det{};
  const int p[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {1, 0, 2}, {2, 1, 0}};
  const double sgn[6] = {1, 1, 1, -1, -1, -1};
  for (int k = 0; k < 6; ++k) {
    Quad q{};
    MulAdd(e[0][p[k][0]], e[1][p[k][1]], 1.0, &q);
    MulAdd(q, e[2][p[k][2]], sgn[k], &det);
  }
  for (int j = 0; j < 20; ++j) A(0, j) = det[j];
  Quad eet[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      eet[r][c] = Quad{};
      for (int k = 0; k < 3; ++k) MulAdd(e[r][k], e[c][k], 1.0, &eet[r][c]);
    }
  Quad tr{};
  for (int j = 0; j < 10; ++j) tr[j] = eet[0][0][j] + eet[1][1][j] + eet[2][2][j];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      Cubic v{};
      for (int k = 0; k < 3; ++k) MulAdd(eet[r][k], e[k][c], 2.0, &v);
      MulAdd(tr, e[r][c], -1.0, &v);
      for (int j = 0; j < 20; ++j) A(1 + 3 * r + c, j) = v[j];
    }
  return A;
}

// Gauss–Jordan elimination on the first 10 columns (partial pivoting); false for a degenerate sample.
bool Eliminate(Eigen::Matrix<double, 10, 20>* A) {
  for (int col = 0; col < 10; ++col) {
    int piv = col;
    for (int r = col + 1; r < 10; ++r)
      if (std::abs((*A)(r, col)) > std::abs((*A)(piv, col))) piv = r;
    if (std::abs((*A)(piv, col)) < 1e-12) return false;
    if (piv != col) A->row(piv).swap(A->row(col));
    A->row(col) /= (*A)(col, col);
    for (int r = 0; r < 10; ++r)
      if (r != col && (*A)(r, col) != 0) A->row(r) -= (*A)(r, col) * A->row(col);
  }
  return true;
}

// The hidden-variable 3×3 matrix in z (rows k, l, m; columns: coefficient of x, of y, constant) from the eliminated
// rows: row i = leading monomial i + Σ b_ij·rest_j, rest = [xz², xz, x, yz², yz, y, z³, z², z, 1].
void HiddenVariableMatrix(const Eigen::Matrix<double, 10, 20>& A, FixedPoly M[3][3]) {
  // Column `col` of row pair (r, s): row r's polynomial minus z times row s's, from `k` coefficients each
  // (b(first), b(first - 1), …: lowest degree first).
  const auto column = [&](int r, int s, int first, int k) {
    FixedPoly out;
    out.n = k + 1;
    std::fill(out.c, out.c + out.n, 0.0);
    for (int d = 0; d < k; ++d) {
      out.c[d] += A(r, 10 + first - d);
      out.c[d + 1] -= A(s, 10 + first - d);
    }
    return out;
  };
  const int pairs[3][2] = {{4, 5}, {6, 7}, {8, 9}};
  for (int i = 0; i < 3; ++i) {
    const int r = pairs[i][0], s = pairs[i][1];
    M[i][0] = column(r, s, 2, 3);
    M[i][1] = column(r, s, 5, 3);
    M[i][2] = column(r, s, 9, 4);
  }
}

// Gauss–Newton steps on the 10 original cubic constraints A0 at (x, y, z): the degree-10 polynomial can be
// ill-conditioned near close roots, the cubic system much less so.
void PolishRoot(const Eigen::Matrix<double, 10, 20>& A0, double* x, double* y, double* z) {
  for (int it = 0; it < 3; ++it) {
    // Powers up to 3 of x, y, z and the monomials with their partial derivatives.
    const double px[4] = {1, *x, *x * *x, *x * *x * *x}, py[4] = {1, *y, *y * *y, *y * *y * *y},
                 pz[4] = {1, *z, *z * *z, *z * *z * *z};
    Eigen::Matrix<double, 20, 1> m;
    Eigen::Matrix<double, 20, 3> dm;
    for (int j = 0; j < 20; ++j) {
      const Exp& e = kCubicExp[j];
      m(j) = px[e.a] * py[e.b] * pz[e.c];
      dm(j, 0) = e.a ? e.a * px[e.a - 1] * py[e.b] * pz[e.c] : 0.0;
      dm(j, 1) = e.b ? e.b * px[e.a] * py[e.b - 1] * pz[e.c] : 0.0;
      dm(j, 2) = e.c ? e.c * px[e.a] * py[e.b] * pz[e.c - 1] : 0.0;
    }
    // r = A0·m and J = A0·dm in one pass over A0's columns.
    Eigen::Matrix<double, 10, 1> r = Eigen::Matrix<double, 10, 1>::Zero();
    Eigen::Matrix<double, 10, 3> J = Eigen::Matrix<double, 10, 3>::Zero();
    for (int j = 0; j < 20; ++j) {
      r.noalias() += A0.col(j) * m(j);
      J.col(0).noalias() += A0.col(j) * dm(j, 0);
      J.col(1).noalias() += A0.col(j) * dm(j, 1);
      J.col(2).noalias() += A0.col(j) * dm(j, 2);
    }
    const Eigen::Vector3d step = (J.transpose() * J).ldlt().solve(-J.transpose() * r);
    if (!step.allFinite()) break;
    *x += step(0);
    *y += step(1);
    *z += step(2);
    if (step.norm() < 1e-15 * (1 + std::abs(*x) + std::abs(*y) + std::abs(*z))) break;
  }
}

}  // namespace

// Nistér's 5-point solver (D. Nistér, "An efficient solution to the five-point relative pose problem", PAMI 2004),
// in the hidden-variable form: null space, 10 cubic constraints, elimination, a degree-10 polynomial in z, roots
// polished on the cubic system.
int FivePointEssential(const Eigen::Vector3d x1[5], const Eigen::Vector3d x2[5], std::vector<Eigen::Matrix3d>* out) {
  const Eigen::Matrix<double, 9, 4> N = NullSpace(x1, x2);
  Eigen::Matrix<double, 10, 20> A = CubicConstraints(N);
  const Eigen::Matrix<double, 10, 20> A0 = A;  // the constraints before elimination, for polishing roots
  if (!Eliminate(&A)) return 0;                // degenerate sample
  FixedPoly M[3][3];
  HiddenVariableMatrix(A, M);
  const FixedPoly det =
      PolyAdd(PolySub(PolyMul(M[0][0], PolySub(PolyMul(M[1][1], M[2][2]), PolyMul(M[1][2], M[2][1]))),
                      PolyMul(M[0][1], PolySub(PolyMul(M[1][0], M[2][2]), PolyMul(M[1][2], M[2][0])))),
              PolyMul(M[0][2], PolySub(PolyMul(M[1][0], M[2][1]), PolyMul(M[1][1], M[2][0]))));
  int found = 0;
  for (double z : RealRoots(det)) {
    Eigen::Vector3d rows[3];
    for (int i = 0; i < 3; ++i) rows[i] = {M[i][0].Eval(z), M[i][1].Eval(z), M[i][2].Eval(z)};
    // (x, y, 1) is the null vector of the 3×3 matrix: the best-conditioned cross product of two rows.
    Eigen::Vector3d best = rows[0].cross(rows[1]);
    for (const auto& v : {rows[0].cross(rows[2]), rows[1].cross(rows[2])})
      if (std::abs(v(2)) > std::abs(best(2))) best = v;
    if (std::abs(best(2)) < 1e-300) continue;
    double x = best(0) / best(2), y = best(1) / best(2), zz = z;
    PolishRoot(A0, &x, &y, &zz);
    const Eigen::Matrix<double, 9, 1> ev = x * N.col(0) + y * N.col(1) + zz * N.col(2) + N.col(3);
    Eigen::Matrix3d E;
    E << ev(0), ev(1), ev(2), ev(3), ev(4), ev(5), ev(6), ev(7), ev(8);
    if (!E.allFinite()) continue;
    out->push_back(E / E.norm());
    ++found;
  }
  return found;
}

int FivePointRelativePose(const Eigen::Vector3d x1[5], const Eigen::Vector3d x2[5], std::vector<PoseRt>* poses) {
  std::vector<Eigen::Matrix3d> es;
  FivePointEssential(x1, x2, &es);
  int n = 0;
  for (const auto& E : es) {
    PoseRt cand[4];
    DecomposeEssential(E, cand);
    for (const auto& c : cand) {
      bool ok = true;
      for (int i = 0; i < 5 && ok; ++i) ok = InFront(c, x1[i], x2[i]);
      if (ok) {
        poses->push_back(c);
        ++n;
      }
    }
  }
  return n;
}

int FivePointRelativePose(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                          const int* sample, std::vector<PoseRt>* poses) {
  Eigen::Vector3d a[5], b[5];
  for (int i = 0; i < 5; ++i) {
    a[i] = x1[sample[i]];
    b[i] = x2[sample[i]];
  }
  poses->clear();
  return FivePointRelativePose(a, b, poses);
}

}  // namespace freeloc::geometry
