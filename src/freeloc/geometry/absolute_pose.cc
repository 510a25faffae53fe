#include "freeloc/geometry/absolute_pose.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "freeloc/core/error.h"
#include "freeloc/geometry/levenberg_marquardt.h"
#include "freeloc/geometry/lie.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/p3p.h"
#include "freeloc/geometry/ransac.h"
#include "freeloc/geometry/robust_loss.h"

namespace freeloc::geometry {

void PnPOptions::Validate() const {
  FREELOC_CHECK(threshold_px > 0, "PnP: the reprojection threshold must be positive");
  ransac.Validate("PnP");
}

void ProcrustesOptions::Validate() const {
  FREELOC_CHECK(threshold_m > 0, "Procrustes: the inlier distance must be positive");
  ransac.Validate("Procrustes");
}

namespace {

double ReprojSq(const PoseRt& p, const Camera& cam, const Eigen::Vector3d& X, const Eigen::Vector2d& x) {
  const Eigen::Vector3d Y = p.R * X + p.t;
  if (Y.z() <= 1e-9) return std::numeric_limits<double>::infinity();
  const double u = cam.fx * Y.x() / Y.z() + cam.cx - x.x();
  const double v = cam.fy * Y.y() / Y.z() + cam.cy - x.y();
  return u * u + v * v;
}

class PnPEstimator {
 public:
  using Model = PoseRt;
  static constexpr int kSampleSize = 3;
  PnPEstimator(const std::vector<Eigen::Vector3d>& X, const std::vector<Eigen::Vector2d>& px, const Camera& cam,
               double th_px)
      : X_(X), px_(px), cam_(cam), th_(th_px) {}
  size_t num_data() const { return X_.size(); }
  void MinimalSolve(const int* s, std::vector<Model>* models) const {
    Eigen::Vector3d Xs[3], bs[3];
    for (int i = 0; i < 3; ++i) {
      Xs[i] = X_[s[i]];
      bs[i] = cam_.Unproject(px_[s[i]].x(), px_[s[i]].y());
    }
    P3P(Xs, bs, models);
  }
  double SquaredError(const Model& m, size_t i) const { return ReprojSq(m, cam_, X_[i], px_[i]); }
  void LocalOptimize(Model* m, double threshold_sq) const {
    std::vector<int> in;
    for (size_t i = 0; i < X_.size(); ++i)
      if (SquaredError(*m, i) < threshold_sq) in.push_back(static_cast<int>(i));
    if (in.size() < 4) return;
    RefineAbsolutePose(X_, px_, cam_, in, th_, 4, m);
  }

 private:
  const std::vector<Eigen::Vector3d>& X_;
  const std::vector<Eigen::Vector2d>& px_;
  const Camera& cam_;
  double th_;
};

class ProcrustesEstimator {
 public:
  using Model = PoseRt;
  static constexpr int kSampleSize = 3;
  ProcrustesEstimator(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) : a_(a), b_(b) {}
  size_t num_data() const { return a_.size(); }
  void MinimalSolve(const int* s, std::vector<Model>* models) const {
    const std::vector<Eigen::Vector3d> src = {a_[s[0]], a_[s[1]], a_[s[2]]}, dst = {b_[s[0]], b_[s[1]], b_[s[2]]};
    // Reject near-collinear samples: the rotation about their line is undetermined.
    if ((src[1] - src[0]).cross(src[2] - src[0]).norm() < 1e-9) return;
    models->push_back(RigidAlign(src, dst));
  }
  double SquaredError(const Model& m, size_t i) const { return (m.R * a_[i] + m.t - b_[i]).squaredNorm(); }
  void LocalOptimize(Model* m, double threshold_sq) const {
    std::vector<Eigen::Vector3d> src, dst;
    for (size_t i = 0; i < a_.size(); ++i)
      if (SquaredError(*m, i) < threshold_sq) {
        src.push_back(a_[i]);
        dst.push_back(b_[i]);
      }
    if (src.size() >= 3) *m = RigidAlign(src, dst);
  }

 private:
  const std::vector<Eigen::Vector3d>& a_;
  const std::vector<Eigen::Vector3d>& b_;
};

void Finish(MetricPoseResult* r, EstimatorOutcome outcome, std::chrono::steady_clock::time_point t0) {
  r->status.outcome = outcome;
  r->status.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Marks the inliers (indices into the depth-valid subset, mapped back by `orig`) and accepts the pose.
void Accept(const PoseRt& best, const std::vector<int>& in, const std::vector<int>& orig, MetricPoseResult* res,
            std::chrono::steady_clock::time_point t0) {
  for (int i : in) res->inliers[orig[i]] = 1;
  res->query_from_ref = Rigid3d(best.R, best.t);
  res->confidence = static_cast<double>(in.size());
  Finish(res, EstimatorOutcome::kOk, t0);
}

void CopyStats(const RansacStats& st, MetricPoseResult* res) {
  res->status.iterations = st.iterations;
  res->status.local_optimizations = st.local_optimizations;
  res->status.stop = st.stop;
}

}  // namespace

namespace {

// camera_from_world refined on the reprojection errors of the correspondences `idx` under a Cauchy loss: a left
// rotation increment and a translation step. A point behind the camera costs a fixed 50 loss scales².
class ReprojectionRefinement {
 public:
  using Params = PoseRt;
  static constexpr int kNumParams = 6;
  ReprojectionRefinement(const std::vector<Eigen::Vector3d>& X, const std::vector<Eigen::Vector2d>& px,
                         const Camera& cam, const std::vector<int>& idx, double loss_scale_px)
      : X_(X), px_(px), cam_(cam), idx_(idx), loss_(loss_scale_px) {}
  int num_params() const { return kNumParams; }
  double Cost(const PoseRt& p) const {
    double c = 0;
    for (int i : idx_) {
      const double e = ReprojSq(p, cam_, X_[i], px_[i]);
      c += std::isfinite(e) ? loss_.Cost(e) : loss_.c2 * 50;
    }
    return c;
  }
  void Linearize(const PoseRt& p, Eigen::Matrix<double, 6, 6>* H, Eigen::Matrix<double, 6, 1>* g) const {
    for (int i : idx_) {
      const Eigen::Vector3d RX = p.R * X_[i];
      const Eigen::Vector3d Y = RX + p.t;
      if (Y.z() <= 1e-9) continue;
      const double iz = 1.0 / Y.z();
      const Eigen::Vector2d r(cam_.fx * Y.x() * iz + cam_.cx - px_[i].x(), cam_.fy * Y.y() * iz + cam_.cy - px_[i].y());
      Eigen::Matrix<double, 2, 3> dpi;
      dpi << cam_.fx * iz, 0, -cam_.fx * Y.x() * iz * iz, 0, cam_.fy * iz, -cam_.fy * Y.y() * iz * iz;
      Eigen::Matrix<double, 3, 6> dY;
      dY.leftCols<3>() = -Skew(RX);
      dY.rightCols<3>().setIdentity();
      const Eigen::Matrix<double, 2, 6> J = dpi * dY;
      const double w = loss_.Weight(r.squaredNorm());
      H->noalias() += w * J.transpose() * J;
      g->noalias() += w * J.transpose() * r;
    }
  }
  bool Step(const PoseRt& p, const Eigen::Matrix<double, 6, 1>& d, PoseRt* out) const {
    out->R = ExpSO3(d.head<3>()) * p.R;
    out->t = p.t + d.tail<3>();
    return true;
  }

 private:
  const std::vector<Eigen::Vector3d>& X_;
  const std::vector<Eigen::Vector2d>& px_;
  const Camera& cam_;
  const std::vector<int>& idx_;
  CauchyLoss loss_;
};

}  // namespace

void RefineAbsolutePose(const std::vector<Eigen::Vector3d>& X, const std::vector<Eigen::Vector2d>& px,
                        const Camera& cam, const std::vector<int>& idx, double loss_scale_px, int iterations,
                        PoseRt* pose) {
  LMOptions lm;
  lm.max_iterations = iterations;
  MinimizeLM(ReprojectionRefinement(X, px, cam, idx, loss_scale_px), pose, lm);
}

MetricPoseResult EstimatePnP(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                             const DepthMap& depth_ref, const Camera& ref, const Camera& query, const PnPOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  o.Validate();
  FREELOC_CHECK(px_ref.size() == px_query.size(), "PnP: point lists differ in length");
  CheckFinite(px_ref, "PnP (reference points)");
  CheckFinite(px_query, "PnP (query points)");
  FREELOC_CHECK(!depth_ref.empty(), "PnP needs the reference depth map; give the reference frame's depth");
  MetricPoseResult res;
  res.status.num_matches = static_cast<int>(px_ref.size());
  res.inliers.assign(px_ref.size(), 0);
  std::vector<Eigen::Vector3d> X;
  std::vector<Eigen::Vector2d> x;
  std::vector<int> orig;
  for (size_t i = 0; i < px_ref.size(); ++i) {
    const double d = BilinearDepth(depth_ref, px_ref[i].x(), px_ref[i].y());
    if (!(d > 0)) continue;
    X.push_back(d * ref.Unproject(px_ref[i].x(), px_ref[i].y()));
    x.push_back(px_query[i]);
    orig.push_back(static_cast<int>(i));
  }
  if (X.size() < 4) {
    Finish(&res, EstimatorOutcome::kTooFewMatches, t0);
    return res;
  }
  PnPEstimator est(X, x, query, o.threshold_px);
  const double threshold_sq = o.threshold_px * o.threshold_px;
  PoseRt best;
  const RansacStats st = Ransac(est, o.ransac, threshold_sq, &best);
  CopyStats(st, &res);
  std::vector<int> in;
  auto collect = [&] {
    in.clear();
    for (size_t i = 0; i < X.size(); ++i)
      if (est.SquaredError(best, i) < threshold_sq) in.push_back(static_cast<int>(i));
  };
  if (!st.found()) {
    Finish(&res, EstimatorOutcome::kNoConsensus, t0);
    return res;
  }
  collect();
  if (static_cast<int>(in.size()) >= o.min_inliers) {
    RefineAbsolutePose(X, x, query, in, o.threshold_px, 20, &best);
    collect();
  }
  res.status.num_inliers = static_cast<int>(in.size());
  if (static_cast<int>(in.size()) < o.min_inliers) {
    Finish(&res, EstimatorOutcome::kNoConsensus, t0);
    return res;
  }
  // Never a confident wrong answer: with a low inlier ratio the support may be what the search finds in any set of
  // pairs (a 3-point model fitted to 10 000 samples finds a dozen chance inliers among a few hundred random pairs).
  // The same search on the pairs shuffled (at most 2000 of them, the count scaled back) says what chance gives; a
  // support not clearly beyond it is no consensus.
  if (in.size() * 4 < X.size()) {
    std::vector<int> pick(X.size());
    for (size_t i = 0; i < pick.size(); ++i) pick[i] = static_cast<int>(i);
    std::mt19937 rng(static_cast<uint32_t>(o.ransac.seed) + 0x5eed);
    std::shuffle(pick.begin(), pick.end(), rng);
    const size_t m = std::min<size_t>(X.size(), 2000);
    std::vector<Eigen::Vector3d> Xs(m);
    std::vector<Eigen::Vector2d> xs(m);
    for (size_t i = 0; i < m; ++i) {
      Xs[i] = X[pick[i]];
      xs[i] = x[pick[(i + 1) % m]];  // each 3-D point with another point's pixel
    }
    PnPEstimator shuffled(Xs, xs, query, o.threshold_px);
    PoseRt chance_model;
    const RansacStats sst = Ransac(shuffled, o.ransac, threshold_sq, &chance_model);
    int chance = 0;
    if (sst.found())
      for (size_t i = 0; i < m; ++i) chance += shuffled.SquaredError(chance_model, i) < threshold_sq;
    const double scaled = chance * static_cast<double>(X.size()) / static_cast<double>(m);
    res.status.shuffled_best = static_cast<int>(std::lround(scaled));
    if (static_cast<double>(in.size()) < 1.5 * scaled + 3) {
      Finish(&res, EstimatorOutcome::kNoConsensus, t0);
      return res;
    }
  }
  if (best.t.norm() > o.max_translation) {
    Finish(&res, EstimatorOutcome::kDegenerate, t0);
    return res;
  }
  Accept(best, in, orig, &res, t0);
  return res;
}

MetricPoseResult EstimateProcrustes(const std::vector<Eigen::Vector2d>& px_ref,
                                    const std::vector<Eigen::Vector2d>& px_query, const DepthMap& depth_ref,
                                    const DepthMap& depth_query, const Camera& ref, const Camera& query,
                                    const ProcrustesOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  o.Validate();
  FREELOC_CHECK(px_ref.size() == px_query.size(), "Procrustes: point lists differ in length");
  CheckFinite(px_ref, "Procrustes (reference points)");
  CheckFinite(px_query, "Procrustes (query points)");
  FREELOC_CHECK(!depth_ref.empty() && !depth_query.empty(),
                "Procrustes needs both depth maps; give the reference and query frames' depth");
  MetricPoseResult res;
  res.status.num_matches = static_cast<int>(px_ref.size());
  res.inliers.assign(px_ref.size(), 0);
  std::vector<Eigen::Vector3d> a, b;
  std::vector<int> orig;
  for (size_t i = 0; i < px_ref.size(); ++i) {
    const double dr = BilinearDepth(depth_ref, px_ref[i].x(), px_ref[i].y());
    const double dq = BilinearDepth(depth_query, px_query[i].x(), px_query[i].y());
    if (!(dr > 0 && dq > 0)) continue;
    a.push_back(dr * ref.Unproject(px_ref[i].x(), px_ref[i].y()));
    b.push_back(dq * query.Unproject(px_query[i].x(), px_query[i].y()));
    orig.push_back(static_cast<int>(i));
  }
  if (a.size() < 3) {
    Finish(&res, EstimatorOutcome::kTooFewMatches, t0);
    return res;
  }
  ProcrustesEstimator est(a, b);
  const double threshold_sq = o.threshold_m * o.threshold_m;
  PoseRt best;
  const RansacStats st = Ransac(est, o.ransac, threshold_sq, &best);
  CopyStats(st, &res);
  if (!st.found()) {
    Finish(&res, EstimatorOutcome::kNoConsensus, t0);
    return res;
  }
  est.LocalOptimize(&best, threshold_sq);  // final refit on all inliers
  std::vector<int> in;
  for (size_t i = 0; i < a.size(); ++i)
    if (est.SquaredError(best, i) < threshold_sq) in.push_back(static_cast<int>(i));
  res.status.num_inliers = static_cast<int>(in.size());
  if (static_cast<int>(in.size()) < o.min_inliers) {
    Finish(&res, EstimatorOutcome::kNoConsensus, t0);
    return res;
  }
  Accept(best, in, orig, &res, t0);
  return res;
}

}  // namespace freeloc::geometry
