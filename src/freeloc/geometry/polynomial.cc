#include "freeloc/geometry/polynomial.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace freeloc::geometry {

Poly PolyMul(const Poly& a, const Poly& b) {
  if (a.empty() || b.empty()) return {};
  Poly c(a.size() + b.size() - 1, 0.0);
  for (size_t i = 0; i < a.size(); ++i)
    for (size_t j = 0; j < b.size(); ++j) c[i + j] += a[i] * b[j];
  return c;
}

Poly PolyAdd(const Poly& a, const Poly& b) {
  Poly c(std::max(a.size(), b.size()), 0.0);
  for (size_t i = 0; i < a.size(); ++i) c[i] += a[i];
  for (size_t i = 0; i < b.size(); ++i) c[i] += b[i];
  return c;
}

Poly PolySub(const Poly& a, const Poly& b) { return PolyAdd(a, PolyScale(b, -1.0)); }

Poly PolyScale(const Poly& a, double s) {
  Poly c = a;
  for (double& v : c) v *= s;
  return c;
}

double PolyEval(const Poly& p, double x) {
  double r = 0;
  for (size_t i = p.size(); i-- > 0;) r = r * x + p[i];
  return r;
}

FixedPoly PolyMul(const FixedPoly& a, const FixedPoly& b) {
  FixedPoly r;
  r.n = std::min(a.n + b.n - 1, FixedPoly::kCapacity);
  std::fill(r.c, r.c + r.n, 0.0);
  for (int i = 0; i < a.n; ++i)
    for (int j = 0; j < b.n && i + j < r.n; ++j) r.c[i + j] += a.c[i] * b.c[j];
  return r;
}

namespace {

FixedPoly AddScaled(const FixedPoly& a, const FixedPoly& b, double sb) {
  FixedPoly r;
  r.n = std::max(a.n, b.n);
  std::fill(r.c, r.c + r.n, 0.0);
  for (int i = 0; i < a.n; ++i) r.c[i] += a.c[i];
  for (int i = 0; i < b.n; ++i) r.c[i] += sb * b.c[i];
  return r;
}

}  // namespace

FixedPoly PolyAdd(const FixedPoly& a, const FixedPoly& b) { return AddScaled(a, b, 1.0); }
FixedPoly PolySub(const FixedPoly& a, const FixedPoly& b) { return AddScaled(a, b, -1.0); }

namespace {

constexpr int kMaxCoeffs = FixedPoly::kCapacity;

void Trim(FixedPoly* p, double eps) {
  double m = 0;
  for (int i = 0; i < p->n; ++i) m = std::max(m, std::abs(p->c[i]));
  while (p->n > 1 && std::abs(p->c[p->n - 1]) <= eps * m) --p->n;
}

// Remainder of a / b (b's leading coefficient non-zero).
FixedPoly PolyRem(FixedPoly a, const FixedPoly& b) {
  const int nb = b.n;
  while (a.n >= nb) {
    const double f = a.c[a.n - 1] / b.c[nb - 1];
    const int shift = a.n - nb;
    for (int i = 0; i < nb; ++i) a.c[shift + i] -= f * b.c[i];
    --a.n;
  }
  if (a.n == 0) a.c[a.n++] = 0.0;
  return a;
}

int SignChanges(const FixedPoly* seq, int len, double x) {
  int changes = 0;
  double prev = 0;
  for (int k = 0; k < len; ++k) {
    const double v = seq[k].Eval(x);
    if (v == 0) continue;
    if (prev != 0 && ((v > 0) != (prev > 0))) ++changes;
    prev = v;
  }
  return changes;
}

// The one root of p in [lo, hi] (p(lo), p(hi) of opposite signs): Newton steps safeguarded by the bracket
// (bisection whenever a step would leave it or fails to halve the step before last, as in Numerical Recipes'
// rtsafe) until a step is below the resolution of doubles; then Newton polishing steps kept only while they
// reduce |p|.
double Refine(const FixedPoly& p, double lo, double hi) {
  const bool rising = p.Eval(lo) < 0;  // p < 0 on the `lo` side
  double x = 0.5 * (lo + hi), dx_old = hi - lo, dx = dx_old;
  double f, df;
  p.EvalWithDerivative(x, &f, &df);
  for (int it = 0; it < 200; ++it) {
    if (f == 0) return x;
    if (((x - hi) * df - f) * ((x - lo) * df - f) > 0 || std::abs(2 * f) > std::abs(dx_old * df)) {
      dx_old = dx;
      dx = 0.5 * (hi - lo);
      x = lo + dx;
      if (x == lo) break;
    } else {
      dx_old = dx;
      dx = f / df;
      const double prev = x;
      x -= dx;
      if (x == prev) break;
    }
    if (std::abs(dx) <= 2 * std::numeric_limits<double>::epsilon() * std::abs(x)) break;
    p.EvalWithDerivative(x, &f, &df);
    if ((f < 0) == rising)
      lo = x;
    else
      hi = x;
  }
  double fx = std::abs(p.Eval(x));
  for (int k = 0; k < 3; ++k) {
    double v, d;
    p.EvalWithDerivative(x, &v, &d);
    if (d == 0) break;
    const double nx = x - v / d;
    const double fn = std::abs(p.Eval(nx));
    if (!(fn < fx)) break;
    x = nx;
    fx = fn;
  }
  return x;
}

}  // namespace

std::vector<double> RealRoots(const Poly& in) {
  size_t size = in.size();
  // Beyond the solvers' degrees: leading coefficients that are exactly zero are dropped, else no roots are claimed.
  while (size > static_cast<size_t>(kMaxCoeffs) && in[size - 1] == 0) --size;
  if (size > static_cast<size_t>(kMaxCoeffs)) return {};
  FixedPoly p;
  p.n = static_cast<int>(size);
  std::copy(in.begin(), in.begin() + static_cast<std::ptrdiff_t>(size), p.c);
  return RealRoots(p);
}

std::vector<double> RealRoots(const FixedPoly& in) {
  std::vector<double> roots;
  FixedPoly p = in;
  Trim(&p, 1e-14);
  if (p.n <= 1) return roots;
  if (p.n == 2) return {-p.c[0] / p.c[1]};
  // Normalise to a monic polynomial.
  const double lead = p.c[p.n - 1];
  for (int i = 0; i < p.n; ++i) p.c[i] /= lead;
  // Cauchy bound.
  double bound = 0;
  for (int i = 0; i + 1 < p.n; ++i) bound = std::max(bound, std::abs(p.c[i]));
  bound += 1.0;
  // Sturm sequence.
  FixedPoly seq[kMaxCoeffs];
  int len = 0;
  seq[len++] = p;
  FixedPoly& dp = seq[len++];
  dp.n = p.n - 1;
  for (int i = 1; i < p.n; ++i) dp.c[i - 1] = p.c[i] * static_cast<double>(i);
  while (seq[len - 1].n > 1 && len < kMaxCoeffs) {
    FixedPoly r = PolyRem(seq[len - 2], seq[len - 1]);
    Trim(&r, 1e-13);
    for (int i = 0; i < r.n; ++i) r.c[i] = -r.c[i];
    if (r.n == 1 && std::abs(r.c[0]) < 1e-300) break;
    seq[len++] = r;
  }
  // Isolate roots by recursive bisection on the number of sign changes.
  struct Interval {
    double lo, hi;
    int clo, chi;
  };
  Interval stack[2 * 64 * kMaxCoeffs];
  int top = 0;
  stack[top++] = {-bound, bound, SignChanges(seq, len, -bound), SignChanges(seq, len, bound)};
  while (top > 0) {
    const Interval iv = stack[--top];
    const int n = iv.clo - iv.chi;
    if (n <= 0) continue;
    if (n == 1) {
      const double flo = p.Eval(iv.lo), fhi = p.Eval(iv.hi);
      if ((flo > 0) != (fhi > 0) || flo == 0 || fhi == 0) {
        roots.push_back(flo == 0 ? iv.lo : fhi == 0 ? iv.hi : Refine(p, iv.lo, iv.hi));
        continue;
      }
    }
    if (iv.hi - iv.lo < 1e-13 * std::max(1.0, std::abs(iv.lo)) ||
        top + 2 > static_cast<int>(sizeof(stack) / sizeof(stack[0]))) {
      roots.push_back(0.5 * (iv.lo + iv.hi));  // a multiple root (or a cluster)
      continue;
    }
    const double mid = 0.5 * (iv.lo + iv.hi);
    const int cm = SignChanges(seq, len, mid);
    stack[top++] = {iv.lo, mid, iv.clo, cm};
    stack[top++] = {mid, iv.hi, cm, iv.chi};
  }
  std::sort(roots.begin(), roots.end());
  return roots;
}

}  // namespace freeloc::geometry
