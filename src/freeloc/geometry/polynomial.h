// Univariate polynomial helpers for the minimal solvers: real roots by Sturm-sequence bisection (as in Nistér's
// 5-point solver), products, evaluation. Coefficients are stored lowest degree first.
#pragma once

#include <vector>

namespace freeloc::geometry {

using Poly = std::vector<double>;  // c[0] + c[1] x + c[2] x² + …

Poly PolyMul(const Poly& a, const Poly& b);
Poly PolyAdd(const Poly& a, const Poly& b);
Poly PolySub(const Poly& a, const Poly& b);
Poly PolyScale(const Poly& a, double s);
double PolyEval(const Poly& p, double x);

// A polynomial of degree ≤ 20 on the stack, for the solvers that run once per RANSAC sample (no allocation).
// Only c[0, n) is meaningful.
struct FixedPoly {
  static constexpr int kCapacity = 21;
  // Not an aggregate, so a braced list stays a Poly; c is left uninitialised (only c[0, n) is read).
  FixedPoly() {}
  double c[kCapacity];
  int n = 0;  // number of coefficients
  double Eval(double x) const {
    double r = 0;
    for (int i = n; i-- > 0;) r = r * x + c[i];
    return r;
  }
  // p(x) and p'(x) in one Horner pass.
  void EvalWithDerivative(double x, double* p, double* dp) const {
    double r = 0, d = 0;
    for (int i = n; i-- > 0;) {
      d = d * x + r;
      r = r * x + c[i];
    }
    *p = r;
    *dp = d;
  }
};
// The product's degree must stay ≤ 20.
FixedPoly PolyMul(const FixedPoly& a, const FixedPoly& b);
FixedPoly PolyAdd(const FixedPoly& a, const FixedPoly& b);
FixedPoly PolySub(const FixedPoly& a, const FixedPoly& b);

// All real roots of p (degree ≤ 20), isolated with a Sturm sequence on the Cauchy bound and refined by Newton steps
// safeguarded by their bracket to ~1e-14 relative. Multiple roots are reported once.
std::vector<double> RealRoots(const FixedPoly& p);
std::vector<double> RealRoots(const Poly& p);

}  // namespace freeloc::geometry
