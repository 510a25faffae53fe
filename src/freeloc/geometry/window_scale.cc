#include "freeloc/geometry/window_scale.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <initializer_list>

#include "freeloc/geometry/levenberg_marquardt.h"

namespace freeloc::geometry {
namespace {

constexpr double kMinSe = 0.005;  // an anchored length is never taken as better than 0.5 %

// The window's state: P, then each frame's centre, then one log error per map (reference, evaluated camera, frames).
struct WindowScaleProblem {
  using Params = Eigen::VectorXd;
  static constexpr int kNumParams = Eigen::Dynamic;

  const WindowScaleInput& in;
  double map_sigma = 0.5;

  int frames() const { return static_cast<int>(in.frames.size()); }
  int num_params() const { return 3 + 3 * frames() + 2 + frames(); }
  int map_index(int m) const { return 3 + 3 * frames() + m; }

  static void AddDirection(const Eigen::Vector3d& v, const Eigen::Vector3d& want, double sigma,
                           std::vector<double>* r) {
    const Eigen::Vector3d e = (v.normalized() - want) / sigma;
    for (int i = 0; i < 3; ++i) r->push_back(e[i]);
  }
  static void AddLength(double length, double e_map, const AnchoredLength& a, std::vector<double>* r) {
    if (a.has) r->push_back((std::log(length) - e_map - a.log_length) / std::max(a.se, kMinSe));
  }

  std::vector<double> Residuals(const Params& x) const {
    std::vector<double> r;
    const Eigen::Vector3d P = x.head<3>();
    const double e_ref = x[map_index(0)], e_q = x[map_index(1)];
    AddDirection(P, in.ray, in.ray_sigma_rad, &r);
    AddLength(P.norm(), e_ref, in.to_ref_by_ref, &r);
    AddLength(P.norm(), e_q, in.to_ref_by_own, &r);
    for (int j = 0; j < frames(); ++j) {
      const WindowFrameGeometry& f = in.frames[static_cast<size_t>(j)];
      const Eigen::Vector3d c = x.segment<3>(3 + 3 * j);
      const double e_j = x[map_index(2 + j)];
      AddDirection(P - c, f.ray, f.ray_sigma_rad, &r);
      AddDirection(c, f.baseline.normalized(), f.baseline_sigma_rad, &r);
      AddLength((P - c).norm(), e_ref, f.to_ref_by_ref, &r);
      AddLength((P - c).norm(), e_j, f.to_ref_by_own, &r);
      AddLength(c.norm(), e_q, f.relation_by_q, &r);
      AddLength(c.norm(), e_j, f.relation_by_own, &r);
    }
    for (int m = 0; m < 2 + frames(); ++m) r.push_back(x[map_index(m)] / map_sigma);
    return r;
  }

  double Cost(const Params& x) const {
    double s = 0;
    for (double v : Residuals(x)) s += v * v;
    return s;
  }

  Eigen::MatrixXd Jacobian(const Params& x, Eigen::VectorXd* r0) const {
    const std::vector<double> base = Residuals(x);
    *r0 = Eigen::Map<const Eigen::VectorXd>(base.data(), static_cast<Eigen::Index>(base.size()));
    Eigen::MatrixXd J(r0->size(), x.size());
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      const double h = 1e-7 * std::max(1.0, std::abs(x[k]));
      Params xp = x;
      xp[k] += h;
      const std::vector<double> rp = Residuals(xp);
      for (Eigen::Index i = 0; i < r0->size(); ++i)
        J(i, k) = (rp[static_cast<size_t>(i)] - base[static_cast<size_t>(i)]) / h;
    }
    return J;
  }

  void Linearize(const Params& x, Eigen::MatrixXd* H, Eigen::VectorXd* g) const {
    Eigen::VectorXd r;
    const Eigen::MatrixXd J = Jacobian(x, &r);
    *H += J.transpose() * J;
    *g += J.transpose() * r;
  }

  bool Step(const Params& x, const Eigen::VectorXd& d, Params* out) const {
    *out = x + d;
    const Eigen::Vector3d P = out->head<3>();
    if (!(P.norm() > 1e-9) || !out->allFinite()) return false;
    for (int j = 0; j < frames(); ++j) {
      const Eigen::Vector3d c = out->segment<3>(3 + 3 * j);
      if (!(c.norm() > 1e-9) || !((P - c).norm() > 1e-9)) return false;
    }
    return true;
  }
};

double MeanLog(std::initializer_list<const AnchoredLength*> as, double fallback) {
  double s = 0;
  int n = 0;
  for (const AnchoredLength* a : as)
    if (a->has) s += a->log_length, ++n;
  return n ? s / n : fallback;
}

}  // namespace

WindowScaleResult EstimateWindowScale(const WindowScaleInput& input) {
  WindowScaleResult res;
  const int J = static_cast<int>(input.frames.size());
  std::vector<char> used(static_cast<size_t>(2 + J), 0);
  used[0] = input.to_ref_by_ref.has;
  used[1] = input.to_ref_by_own.has;
  for (int j = 0; j < J; ++j) {
    const WindowFrameGeometry& f = input.frames[static_cast<size_t>(j)];
    used[0] |= f.to_ref_by_ref.has;
    used[1] |= f.relation_by_q.has;
    used[static_cast<size_t>(2 + j)] = f.to_ref_by_own.has || f.relation_by_own.has;
  }
  res.maps = static_cast<int>(std::count(used.begin(), used.end(), 1));
  if (res.maps < 3 || !(input.ray.norm() > 0)) return res;

  // Start: the reference centre on the evaluated camera's ray at its anchored distance, each frame at its direction
  // with its anchored (or given) length, every map error zero.
  WindowScaleProblem problem{input};
  Eigen::VectorXd x = Eigen::VectorXd::Zero(problem.num_params());
  const double rho0 = std::exp(MeanLog({&input.to_ref_by_ref, &input.to_ref_by_own}, 0.0));
  x.head<3>() = rho0 * input.ray.normalized();
  for (int j = 0; j < J; ++j) {
    const WindowFrameGeometry& f = input.frames[static_cast<size_t>(j)];
    const double len = std::exp(MeanLog({&f.relation_by_q, &f.relation_by_own}, std::log(f.baseline.norm())));
    x.segment<3>(3 + 3 * j) = len * f.baseline.normalized();
  }
  LMOptions lm;
  lm.max_iterations = 50;
  // Pass 1 with a weak prior on the maps: their errors as the data say; σ_map from their spread (the maps that
  // anchored something; a robust spread, so that one wild map does not set it). Pass 2 with that σ_map.
  problem.map_sigma = 0.5;
  MinimizeLM(problem, &x, lm);
  std::vector<double> abs_err;
  for (int m = 0; m < 2 + J; ++m)
    if (used[static_cast<size_t>(m)]) abs_err.push_back(std::abs(x[problem.map_index(m)]));
  std::nth_element(abs_err.begin(), abs_err.begin() + static_cast<long>(abs_err.size() / 2), abs_err.end());
  problem.map_sigma = std::max(input.min_map_sigma, 1.4826 * abs_err[abs_err.size() / 2]);
  MinimizeLM(problem, &x, lm);

  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(problem.num_params(), problem.num_params());
  Eigen::VectorXd g = Eigen::VectorXd::Zero(problem.num_params());
  problem.Linearize(x, &H, &g);
  const Eigen::Vector3d P = x.head<3>();
  Eigen::VectorXd dlog = Eigen::VectorXd::Zero(problem.num_params());
  dlog.head<3>() = P / P.squaredNorm();
  const Eigen::VectorXd s = H.ldlt().solve(dlog);
  if (!s.allFinite() || !P.allFinite()) return res;
  res.ok = true;
  res.reference = P;
  res.distance = P.norm();
  res.log_sigma = std::sqrt(std::max(0.0, dlog.dot(s)));
  res.map_sigma = problem.map_sigma;
  for (int m = 0; m < 2 + J; ++m) res.map_errors.push_back(x[problem.map_index(m)]);
  return res;
}

}  // namespace freeloc::geometry
