#include "freeloc/geometry/polynomial.h"

#include <algorithm>
#include <cmath>

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

namespace {

void Trim(Poly* p, double eps) {
  double m = 0;
  for (double v : *p) m = std::max(m, std::abs(v));
  while (p->size() > 1 && std::abs(p->back()) <= eps * m) p->pop_back();
}

// Remainder of a / b (b's leading coefficient non-zero).
Poly PolyRem(Poly a, const Poly& b) {
  const size_t nb = b.size();
  while (a.size() >= nb) {
    const double f = a.back() / b.back();
    const size_t shift = a.size() - nb;
    for (size_t i = 0; i < nb; ++i) a[shift + i] -= f * b[i];
    a.pop_back();
  }
  if (a.empty()) a.push_back(0.0);
  return a;
}

int SignChanges(const std::vector<Poly>& seq, double x) {
  int changes = 0;
  double prev = 0;
  for (const Poly& p : seq) {
    const double v = PolyEval(p, x);
    if (v == 0) continue;
    if (prev != 0 && ((v > 0) != (prev > 0))) ++changes;
    prev = v;
  }
  return changes;
}

double Refine(const Poly& p, const Poly& dp, double lo, double hi) {
  // Bisection to the resolution of doubles, then Newton polishing steps kept only while they reduce |p|.
  double flo = PolyEval(p, lo);
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    const double fm = PolyEval(p, mid);
    if (fm == 0) return mid;
    if ((fm > 0) == (flo > 0)) {
      lo = mid;
      flo = fm;
    } else {
      hi = mid;
    }
  }
  double x = 0.5 * (lo + hi);
  double fx = std::abs(PolyEval(p, x));
  for (int k = 0; k < 3; ++k) {
    const double d = PolyEval(dp, x);
    if (d == 0) break;
    const double nx = x - PolyEval(p, x) / d;
    const double fn = std::abs(PolyEval(p, nx));
    if (!(fn < fx)) break;
    x = nx;
    fx = fn;
  }
  return x;
}

}  // namespace

std::vector<double> RealRoots(Poly p) {
  Trim(&p, 1e-14);
  std::vector<double> roots;
  if (p.size() <= 1) return roots;
  if (p.size() == 2) return {-p[0] / p[1]};
  // Normalise to a monic polynomial.
  const double lead = p.back();
  for (double& v : p) v /= lead;
  // Cauchy bound.
  double bound = 0;
  for (size_t i = 0; i + 1 < p.size(); ++i) bound = std::max(bound, std::abs(p[i]));
  bound += 1.0;
  // Sturm sequence.
  Poly dp(p.size() - 1);
  for (size_t i = 1; i < p.size(); ++i) dp[i - 1] = p[i] * static_cast<double>(i);
  std::vector<Poly> seq = {p, dp};
  while (seq.back().size() > 1) {
    Poly r = PolyRem(seq[seq.size() - 2], seq.back());
    Trim(&r, 1e-13);
    for (double& v : r) v = -v;
    if (r.size() == 1 && std::abs(r[0]) < 1e-300) break;
    seq.push_back(r);
  }
  // Isolate roots by recursive bisection on the number of sign changes.
  struct Interval {
    double lo, hi;
    int clo, chi;
  };
  std::vector<Interval> stack = {{-bound, bound, SignChanges(seq, -bound), SignChanges(seq, bound)}};
  while (!stack.empty()) {
    Interval iv = stack.back();
    stack.pop_back();
    const int n = iv.clo - iv.chi;
    if (n <= 0) continue;
    if (n == 1) {
      const double flo = PolyEval(p, iv.lo), fhi = PolyEval(p, iv.hi);
      if ((flo > 0) != (fhi > 0) || flo == 0 || fhi == 0) {
        roots.push_back(flo == 0 ? iv.lo : fhi == 0 ? iv.hi : Refine(p, dp, iv.lo, iv.hi));
        continue;
      }
    }
    if (iv.hi - iv.lo < 1e-13 * std::max(1.0, std::abs(iv.lo))) {
      roots.push_back(0.5 * (iv.lo + iv.hi));  // a multiple root (or a cluster)
      continue;
    }
    const double mid = 0.5 * (iv.lo + iv.hi);
    const int cm = SignChanges(seq, mid);
    stack.push_back({iv.lo, mid, iv.clo, cm});
    stack.push_back({mid, iv.hi, cm, iv.chi});
  }
  std::sort(roots.begin(), roots.end());
  return roots;
}

}  // namespace freeloc::geometry
