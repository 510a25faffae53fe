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

// All real roots of p (degree ≤ 20), isolated with a Sturm sequence on the Cauchy bound and refined by
// bisection/Newton to ~1e-14 relative. Multiple roots are reported once.
std::vector<double> RealRoots(Poly p);

}  // namespace freeloc::geometry
