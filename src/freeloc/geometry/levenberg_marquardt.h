// The one non-linear least-squares loop of geometry/: Levenberg–Marquardt (K. Levenberg, "A method for the solution
// of certain non-linear problems in least squares", Q. Appl. Math. 1944; D. Marquardt, SIAM J. Appl. Math. 1963)
// with Marquardt's scaled damping, H + λ·diag(H), on the robustly reweighted normal equations. Every refiner
// (relative_pose.cc, absolute_pose.cc, hybrid_pose.cc) is a problem object handed to MinimizeLM:
//
//   struct Problem {
//     using Params = …;                     // the point being refined: a pose, a pose with scale and shifts, …
//     static constexpr int kNumParams = …;  // the tangent dimension, or Eigen::Dynamic
//     int num_params() const;
//     double Cost(const Params& x) const;   // Σ ρ(‖r_i(x)‖²) with the problem's loss object
//     // Adds Σ w_i·J_iᵀJ_i to *H and Σ w_i·J_iᵀr_i to *g at x (w_i: the loss object's weight; both start at zero).
//     void Linearize(const Params& x, Hessian* H, Gradient* g) const;
//     // The retraction x ⊞ d; false when the step leaves the domain (a rejected step: more damping).
//     bool Step(const Params& x, const Tangent& d, Params* out) const;
//   };
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>

namespace freeloc::geometry {

struct LMOptions {
  int max_iterations = 25;
  double initial_lambda = 1e-4;
  double min_relative_decrease = 1e-10;  // converged once an accepted step lowers the cost by less than this fraction
  double min_step_norm = 0;              // … or is shorter than this (0: never)
  int max_tries = 6;                     // damping increases per iteration before it gives up
};

struct LMSummary {
  double initial_cost = 0;
  double final_cost = 0;
  int iterations = 0;  // iterations with an accepted step
  bool converged = false;
};

template <class Problem>
LMSummary MinimizeLM(const Problem& problem, typename Problem::Params* x, const LMOptions& options) {
  constexpr int N = Problem::kNumParams;
  using Hessian = Eigen::Matrix<double, N, N>;
  using Vector = Eigen::Matrix<double, N, 1>;
  using Params = typename Problem::Params;
  const int n = problem.num_params();
  LMSummary summary;
  double cost = problem.Cost(*x);
  summary.initial_cost = summary.final_cost = cost;
  double lambda = options.initial_lambda;
  for (int it = 0; it < options.max_iterations; ++it) {
    Hessian H = Hessian::Zero(n, n);
    Vector g = Vector::Zero(n);
    problem.Linearize(*x, &H, &g);
    bool improved = false;
    for (int tries = 0; tries < options.max_tries && !improved; ++tries) {
      Hessian A = H;
      for (int k = 0; k < n; ++k) A(k, k) += lambda * std::max(H(k, k), 1e-12);
      const Vector d = A.ldlt().solve(-g);
      if (!d.allFinite()) break;
      Params candidate;
      if (!problem.Step(*x, d, &candidate)) {
        lambda *= 10;
        continue;
      }
      const double c = problem.Cost(candidate);
      if (c < cost) {
        const double relative_decrease = (cost - c) / std::max(cost, 1e-300);
        *x = candidate;
        cost = c;
        summary.final_cost = cost;
        ++summary.iterations;
        lambda = std::max(lambda * 0.1, 1e-10);
        improved = true;
        if (relative_decrease < options.min_relative_decrease || d.norm() < options.min_step_norm) {
          summary.converged = true;
          return summary;
        }
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  return summary;
}

}  // namespace freeloc::geometry
