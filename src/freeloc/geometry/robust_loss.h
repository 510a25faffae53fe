// Loss objects for robust least squares (PoseLib's pattern): ρ applied to a squared residual norm s, and the weight
// ρ'(s) that iteratively reweighted Gauss–Newton/Levenberg–Marquardt puts on that residual's normal equations
// (Triggs, McLauchlan, Hartley, Fitzgibbon, "Bundle Adjustment — A Modern Synthesis", 2000, §4.3).
#pragma once

#include <cmath>

namespace freeloc::geometry {

// ρ(s) = s: plain least squares.
struct TrivialLoss {
  double Cost(double s) const { return s; }
  double Weight(double) const { return 1.0; }
};

// ρ(s) = c²·log(1 + s/c²), ρ'(s) = 1 / (1 + s/c²): quadratic near zero, logarithmic beyond the scale c.
struct CauchyLoss {
  explicit CauchyLoss(double scale) : c2(scale * scale) {}
  double Cost(double s) const { return c2 * std::log1p(s / c2); }
  double Weight(double s) const { return 1.0 / (1.0 + s / c2); }
  double c2;
};

}  // namespace freeloc::geometry
