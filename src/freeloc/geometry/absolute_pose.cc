#include "freeloc/geometry/absolute_pose.h"

#include <Eigen/Dense>
#include <chrono>
#include <algorithm>
#include <cmath>
#include <random>

#include "freeloc/core/error.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/p3p.h"
#include "freeloc/geometry/ransac.h"

namespace freeloc::geometry {

void PnPOptions::Validate() const {
  FREELOC_CHECK(threshold_px > 0, "PnP: the reprojection threshold must be positive");
  FREELOC_CHECK(min_iterations >= 0 && max_iterations >= 1 && success_prob > 0 && success_prob < 1,
                "PnP: invalid RANSAC settings");
}

void ProcrustesOptions::Validate() const {
  FREELOC_CHECK(threshold_m > 0, "Procrustes: the inlier distance must be positive");
  FREELOC_CHECK(min_iterations >= 0 && max_iterations >= 1 && success_prob > 0 && success_prob < 1,
                "Procrustes: invalid RANSAC settings");
}

namespace {

Eigen::Matrix3d Exp(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-12) return Eigen::Matrix3d::Identity() + Skew(w);
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

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

RansacOptions MakeRansac(double threshold_sq, double p, int min_it, int max_it, uint64_t seed) {
  RansacOptions r;
  r.threshold_sq = threshold_sq;
  r.success_prob = p;
  r.min_iterations = min_it;
  r.max_iterations = max_it;
  r.seed = seed;
  return r;
}

void Finish(MetricPoseResult* r, const char* reason, std::chrono::steady_clock::time_point t0) {
  r->status.reason = reason;
  r->status.success = std::string(reason) == "ok";
  r->status.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Marks the inliers (indices into the depth-valid subset, mapped back by `orig`) and accepts the pose.
void Accept(const PoseRt& best, const std::vector<int>& in, const std::vector<int>& orig, MetricPoseResult* res,
            std::chrono::steady_clock::time_point t0) {
  for (int i : in) res->inliers[orig[i]] = 1;
  res->query_from_ref = Rigid3d(best.R, best.t);
  res->confidence = static_cast<double>(in.size());
  Finish(res, "ok", t0);
}

void CopyStats(const RansacStats& st, MetricPoseResult* res) {
  res->status.iterations = st.iterations;
  res->status.local_optimizations = st.local_optimizations;
  res->status.stop_reason = st.stop_reason;
}

}  // namespace

void RefineAbsolutePose(const std::vector<Eigen::Vector3d>& X, const std::vector<Eigen::Vector2d>& px,
                        const Camera& cam, const std::vector<int>& idx, double loss_scale_px, int iterations,
                        PoseRt* pose) {
  const double c2 = loss_scale_px * loss_scale_px;
  auto cost = [&](const PoseRt& p) {
    double c = 0;
    for (int i : idx) {
      const double e = ReprojSq(p, cam, X[i], px[i]);
      c += std::isfinite(e) ? c2 * std::log1p(e / c2) : c2 * 50;
    }
    return c;
  };
  double cur = cost(*pose);
  double lambda = 1e-4;
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    for (int i : idx) {
      const Eigen::Vector3d RX = pose->R * X[i];
      const Eigen::Vector3d Y = RX + pose->t;
      if (Y.z() <= 1e-9) continue;
      const double iz = 1.0 / Y.z();
      const Eigen::Vector2d r(cam.fx * Y.x() * iz + cam.cx - px[i].x(), cam.fy * Y.y() * iz + cam.cy - px[i].y());
      Eigen::Matrix<double, 2, 3> dpi;
      dpi << cam.fx * iz, 0, -cam.fx * Y.x() * iz * iz, 0, cam.fy * iz, -cam.fy * Y.y() * iz * iz;
      Eigen::Matrix<double, 3, 6> dY;
      dY.leftCols<3>() = -Skew(RX);
      dY.rightCols<3>().setIdentity();
      const Eigen::Matrix<double, 2, 6> J = dpi * dY;
      const double w = 1.0 / (1.0 + r.squaredNorm() / c2);
      H.noalias() += w * J.transpose() * J;
      g.noalias() += w * J.transpose() * r;
    }
    bool improved = false;
    for (int tries = 0; tries < 6 && !improved; ++tries) {
      Eigen::Matrix<double, 6, 6> A = H;
      for (int k = 0; k < 6; ++k) A(k, k) += lambda * std::max(H(k, k), 1e-12);
      const Eigen::Matrix<double, 6, 1> d = A.ldlt().solve(-g);
      if (!d.allFinite()) break;
      PoseRt cand;
      cand.R = Exp(d.head<3>()) * pose->R;
      cand.t = pose->t + d.tail<3>();
      const double c = cost(cand);
      if (c < cur) {
        const double rel = (cur - c) / std::max(cur, 1e-300);
        *pose = cand;
        cur = c;
        lambda = std::max(lambda * 0.1, 1e-10);
        improved = true;
        if (rel < 1e-10) return;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) return;
  }
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
    Finish(&res, "too-few-matches", t0);
    return res;
  }
  PnPEstimator est(X, x, query, o.threshold_px);
  const RansacOptions ro =
      MakeRansac(o.threshold_px * o.threshold_px, o.success_prob, o.min_iterations, o.max_iterations, o.seed);
  PoseRt best;
  const RansacStats st = Ransac(est, ro, &best);
  CopyStats(st, &res);
  std::vector<int> in;
  auto collect = [&] {
    in.clear();
    for (size_t i = 0; i < X.size(); ++i)
      if (est.SquaredError(best, i) < ro.threshold_sq) in.push_back(static_cast<int>(i));
  };
  if (st.stop_reason == "no-model") {
    Finish(&res, "no-consensus", t0);
    return res;
  }
  collect();
  if (static_cast<int>(in.size()) >= o.min_inliers) {
    RefineAbsolutePose(X, x, query, in, o.threshold_px, 20, &best);
    collect();
  }
  res.status.num_inliers = static_cast<int>(in.size());
  if (static_cast<int>(in.size()) < o.min_inliers) {
    Finish(&res, "no-consensus", t0);
    return res;
  }
  // Never a confident wrong answer: with a low inlier ratio the support may be what the search finds in any set of
  // pairs (a 3-point model fitted to 10 000 samples finds a dozen chance inliers among a few hundred random pairs).
  // The same search on the pairs shuffled (at most 2000 of them, the count scaled back) says what chance gives; a
  // support not clearly beyond it is no consensus.
  if (in.size() * 4 < X.size()) {
    std::vector<int> pick(X.size());
    for (size_t i = 0; i < pick.size(); ++i) pick[i] = static_cast<int>(i);
    std::mt19937 rng(static_cast<uint32_t>(o.seed) + 0x5eed);
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
    const RansacStats sst = Ransac(shuffled, ro, &chance_model);
    int chance = 0;
    if (sst.stop_reason != "no-model")
      for (size_t i = 0; i < m; ++i) chance += shuffled.SquaredError(chance_model, i) < ro.threshold_sq;
    const double scaled = chance * static_cast<double>(X.size()) / static_cast<double>(m);
    res.status.shuffled_best = static_cast<int>(std::lround(scaled));
    if (static_cast<double>(in.size()) < 1.5 * scaled + 3) {
      Finish(&res, "no-consensus", t0);
      return res;
    }
  }
  if (best.t.norm() > o.max_translation) {
    Finish(&res, "degenerate", t0);
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
    Finish(&res, "too-few-matches", t0);
    return res;
  }
  ProcrustesEstimator est(a, b);
  const RansacOptions ro =
      MakeRansac(o.threshold_m * o.threshold_m, o.success_prob, o.min_iterations, o.max_iterations, o.seed);
  PoseRt best;
  const RansacStats st = Ransac(est, ro, &best);
  CopyStats(st, &res);
  if (st.stop_reason == "no-model") {
    Finish(&res, "no-consensus", t0);
    return res;
  }
  est.LocalOptimize(&best, ro.threshold_sq);  // final refit on all inliers
  std::vector<int> in;
  for (size_t i = 0; i < a.size(); ++i)
    if (est.SquaredError(best, i) < ro.threshold_sq) in.push_back(static_cast<int>(i));
  res.status.num_inliers = static_cast<int>(in.size());
  if (static_cast<int>(in.size()) < o.min_inliers) {
    Finish(&res, "no-consensus", t0);
    return res;
  }
  Accept(best, in, orig, &res, t0);
  return res;
}

}  // namespace freeloc::geometry
