#include "freeloc/geometry/refine_relative_pose.h"

#include <Eigen/Dense>

#include "freeloc/geometry/levenberg_marquardt.h"
#include "freeloc/geometry/lie.h"
#include "freeloc/geometry/robust_loss.h"

namespace freeloc::geometry {

namespace {

// (R, unit t) refined on the Sampson error of the correspondences `idx` under a Cauchy loss: 5 parameters, a left
// rotation increment and a step in the tangent plane of t.
class SampsonRefinement {
 public:
  using Params = PoseRt;
  static constexpr int kNumParams = 5;
  SampsonRefinement(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                    const std::vector<int>& idx, double loss_scale)
      : x1_(x1), x2_(x2), idx_(idx), loss_(loss_scale) {}
  int num_params() const { return kNumParams; }
  double Cost(const PoseRt& p) const {
    const Eigen::Matrix3d E = EssentialFromPose(p);
    double cost = 0;
    for (int i : idx_) cost += loss_.Cost(SampsonSquared(E, x1_[i], x2_[i]));
    return cost;
  }
  void Linearize(const PoseRt& p, Eigen::Matrix<double, 5, 5>* H, Eigen::Matrix<double, 5, 1>* g) const {
    const Eigen::Matrix3d& R = p.R;
    const Eigen::Vector3d& t = p.t;
    Eigen::Vector3d b1, b2;
    TangentBasis(t, &b1, &b2);
    const Eigen::Matrix3d E = Skew(t) * R;
    // dE for the 5 parameters: rotation (left increment) and translation along the tangent basis.
    Eigen::Matrix3d dE[5];
    const Eigen::Matrix3d tx = Skew(t);
    for (int k = 0; k < 3; ++k) dE[k] = tx * Skew(Eigen::Vector3d::Unit(k)) * R;
    dE[3] = Skew(b1) * R;
    dE[4] = Skew(b2) * R;
    for (int i : idx_) {
      const Eigen::Vector3d& a = x1_[i];
      const Eigen::Vector3d& b = x2_[i];
      const Eigen::Vector3d Ea = E * a, Etb = E.transpose() * b;
      const double C = b.dot(Ea);
      const double S = Ea(0) * Ea(0) + Ea(1) * Ea(1) + Etb(0) * Etb(0) + Etb(1) * Etb(1);
      if (S <= 1e-30) continue;
      const double inv_sqrt_s = 1.0 / std::sqrt(S);
      const double r = C * inv_sqrt_s;
      Eigen::Matrix<double, 5, 1> J;
      for (int k = 0; k < 5; ++k) {
        const Eigen::Vector3d dEa = dE[k] * a, dEtb = dE[k].transpose() * b;
        const double dC = b.dot(dEa);
        const double dS = 2 * (Ea(0) * dEa(0) + Ea(1) * dEa(1) + Etb(0) * dEtb(0) + Etb(1) * dEtb(1));
        J(k) = (dC - 0.5 * C * dS / S) * inv_sqrt_s;
      }
      const double w = loss_.Weight(r * r);
      H->noalias() += w * J * J.transpose();
      g->noalias() += w * r * J;
    }
  }
  bool Step(const PoseRt& p, const Eigen::Matrix<double, 5, 1>& d, PoseRt* out) const {
    Eigen::Vector3d b1, b2;
    TangentBasis(p.t, &b1, &b2);
    out->R = ExpSO3(d.head<3>()) * p.R;
    out->t = (p.t + d(3) * b1 + d(4) * b2).normalized();
    return true;
  }

 private:
  const std::vector<Eigen::Vector3d>& x1_;
  const std::vector<Eigen::Vector3d>& x2_;
  const std::vector<int>& idx_;
  CauchyLoss loss_;
};

}  // namespace

double RefineRelativePose(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                          const std::vector<int>& idx, double loss_scale, int max_iterations, PoseRt* pose) {
  LMOptions lm;
  lm.max_iterations = max_iterations;
  lm.min_step_norm = 1e-12;
  return MinimizeLM(SampsonRefinement(x1, x2, idx, loss_scale), pose, lm).final_cost;
}

}  // namespace freeloc::geometry
