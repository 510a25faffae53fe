#include "freeloc/geometry/hybrid_pose.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "freeloc/core/error.h"
#include "freeloc/geometry/essential.h"
#include "freeloc/geometry/five_point.h"
#include "freeloc/geometry/levenberg_marquardt.h"
#include "freeloc/geometry/lie.h"
#include "freeloc/geometry/metric_scale.h"
#include "freeloc/geometry/ransac.h"
#include "freeloc/geometry/relpose_depth_shift_3pt.h"
#include "freeloc/geometry/robust_loss.h"

namespace freeloc::geometry {

void HybridPoseOptions::Validate() const {
  FREELOC_CHECK(threshold_px > 0 && std::isfinite(threshold_px),
                "hybrid pose: threshold_px must be a positive number of pixels");
  FREELOC_CHECK(reprojection_px > 0 && std::isfinite(reprojection_px),
                "hybrid pose: the reprojection threshold must be positive pixels");
  ransac.Validate("hybrid pose");
  FREELOC_CHECK(min_inliers >= 5, "hybrid pose: min_inliers must be at least 5");
  FREELOC_CHECK(refinement_iterations >= 0, "hybrid pose: refinement_iterations must be >= 0");
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// A minimal solve (5-point, or 3-point with depths) per model it gives, in Sampson errors: the sequential test's cost.
constexpr double kSolveCost = 500;

struct Model {
  DepthRelPose p;
  Eigen::Matrix3d E = Eigen::Matrix3d::Zero();  // [t̂]×R (zero for a pure rotation)
};

Model Complete(const DepthRelPose& p) {
  Model m;
  m.p = p;
  const double n = p.t.norm();
  if (n > 0) m.E = Skew(p.t / n) * p.R;
  return m;
}

// Squared reprojection error (normalised units) of the camera-frame point X against the ray `obs` (z = 1); a point
// at or behind the camera costs infinity.
inline double ReprojSq(const Eigen::Vector3d& X, const Eigen::Vector3d& obs) {
  if (!(X.z() > 1e-9)) return kInf;
  const double ex = X.x() / X.z() - obs.x(), ey = X.y() / X.z() - obs.y();
  return ex * ex + ey * ey;
}

class Problem {
 public:
  Problem(std::vector<Eigen::Vector3d> x, std::vector<Eigen::Vector3d> y, std::vector<double> dr,
          std::vector<double> dq, double th_e, double th_r)
      : x_(std::move(x)),
        y_(std::move(y)),
        dr_(std::move(dr)),
        dq_(std::move(dq)),
        the2_(th_e * th_e),
        thr2_(th_r * th_r),
        th_e_(th_e),
        th_r_(th_r) {
    for (size_t i = 0; i < x_.size(); ++i)
      if (dr_[i] > 0 && dq_[i] > 0) both_.push_back(static_cast<int>(i));
  }
  size_t size() const { return x_.size(); }
  const std::vector<int>& both() const { return both_; }

  double Sampson(const Model& m, size_t i) const { return SampsonSquared(m.E, x_[i], y_[i]); }
  // Reference point into the query (∞ without depth or behind), and the query point into the reference.
  double RefToQuery(const Model& m, size_t i) const {
    if (!(dr_[i] > 0)) return kInf;
    return ReprojSq(m.p.R * ((dr_[i] + m.p.shift_ref) * x_[i]) + m.p.t, y_[i]);
  }
  double QueryToRef(const Model& m, size_t i) const {
    if (!(dq_[i] > 0)) return kInf;
    return ReprojSq(m.p.R.transpose() * (m.p.scale * (dq_[i] + m.p.shift_query) * y_[i] - m.p.t), x_[i]);
  }
  bool SampsonInlier(const Model& m, size_t i) const { return Sampson(m, i) < the2_; }
  bool DepthInlier(const Model& m, size_t i) const { return RefToQuery(m, i) < thr2_ && QueryToRef(m, i) < thr2_; }

  // Hybrid MSAC cost: each term truncated at its threshold and normalised by it (missing depth: the maximum).
  double Score(const Model& m, double bail, int* n_sampson, int* n_depth) const {
    double s = 0;
    int ns = 0, nd = 0;
    for (size_t i = 0; i < x_.size(); ++i) {
      const double es = Sampson(m, i);
      if (es < the2_) {
        s += es / the2_;
        ++ns;
      } else {
        s += 1;
      }
      const double a = RefToQuery(m, i), b = QueryToRef(m, i);
      s += a < thr2_ ? a / thr2_ : 1.0;
      s += b < thr2_ ? b / thr2_ : 1.0;
      nd += (a < thr2_ && b < thr2_);
      if (s > bail) return kInf;
    }
    *n_sampson = ns;
    *n_depth = nd;
    return s;
  }

  // A 5-point model (R, unit t) completed with its metric length and query scale: medians over its Sampson inliers
  // of what their depths say (reference depth ÷ triangulated depth at unit baseline; then the query's).
  bool CompleteFivePoint(const PoseRt& rt, Model* out) const {
    Model unit = Complete({rt.R, rt.t, 1, 0, 0});
    std::vector<double> len, qs;
    std::vector<std::pair<double, double>> tri;
    for (int i : both_) {
      if (!(SampsonSquared(unit.E, x_[i], y_[i]) < the2_)) continue;
      double l1, l2;
      if (!TriangulateDepths(rt, x_[i], y_[i], &l1, &l2) || !(l1 > 0) || !(l2 > 0)) continue;
      len.push_back(dr_[i] / l1);
      tri.emplace_back(l2, dq_[i]);
    }
    if (len.empty()) return false;
    const double L = Median(&len);
    for (const auto& [l2, d] : tri) qs.push_back(L * l2 / d);
    DepthRelPose p{rt.R, L * rt.t, Median(&qs), 0, 0};
    *out = Complete(p);
    return std::isfinite(L) && L > 0 && std::isfinite(p.scale) && p.scale > 0;
  }

  // Robust (Cauchy on each residual block, in threshold units) Levenberg–Marquardt on (R, t, log s [, shifts]):
  // the Sampson residual of the Sampson inliers and the two reprojections of the depth inliers of `m`.
  // Returns the ratio of the reprojection residuals' variance to the Sampson residuals' at the start (how much
  // noisier the depths are than the matches; −1: no refinement, too few inliers).
  double Refine(Model* m, bool shifts, int iterations) const;
  // (R, t̂) refined on the Sampson inliers alone; |t| = the trimmed mean of what the depth inliers' reference depths
  // say (depth ÷ triangulated depth at unit baseline, in logs), the query scale likewise.
  void Polish(Model* m) const {
    std::vector<int> S, D;
    for (size_t i = 0; i < x_.size(); ++i) {
      if (SampsonInlier(*m, i)) S.push_back(static_cast<int>(i));
      if (dr_[i] > 0 && dq_[i] > 0 && DepthInlier(*m, i)) D.push_back(static_cast<int>(i));
    }
    if (S.size() < 6 || D.size() < 3) return;
    PoseRt rt{m->p.R, m->p.t.normalized()};
    // Two rounds, re-selecting the Sampson inliers with the refined pose (as the essential estimator does).
    for (int round = 0; round < 2; ++round) {
      RefineRelativePose(x_, y_, S, th_e_, 25, &rt);
      const Eigen::Matrix3d E = EssentialFromPose(rt);
      S.clear();
      for (size_t i = 0; i < x_.size(); ++i)
        if (SampsonSquared(E, x_[i], y_[i]) < the2_) S.push_back(static_cast<int>(i));
      if (S.size() < 6) return;
    }
    std::vector<double> lr, lq;
    std::vector<std::pair<double, double>> tri;
    for (int i : D) {
      double l1, l2;
      if (!TriangulateDepths(rt, x_[i], y_[i], &l1, &l2) || !(l1 > 0) || !(l2 > 0)) continue;
      lr.push_back(std::log((dr_[i] + m->p.shift_ref) / l1));
      tri.emplace_back(l2, dq_[i] + m->p.shift_query);
    }
    if (lr.size() < 3) return;
    const double log_len = TrimmedMean(lr, 1e-3).mean;
    for (const auto& [l2, d] : tri) lq.push_back(log_len + std::log(l2 / d));
    DepthRelPose p = m->p;
    p.R = rt.R;
    p.t = std::exp(log_len) * rt.t;
    p.scale = std::exp(TrimmedMean(lq, 1e-3).mean);
    *m = Complete(p);
  }

  void Sample3(const int* s, bool shifts, std::vector<Model>* models) const {
    Eigen::Vector3d a[3], b[3];
    double da[3], db[3];
    for (int k = 0; k < 3; ++k) {
      a[k] = x_[s[k]];
      b[k] = y_[s[k]];
      da[k] = dr_[s[k]];
      db[k] = dq_[s[k]];
    }
    sols_.clear();
    if (shifts)
      RelPoseDepthShift3pt(a, da, b, db, &sols_);
    else
      RelPoseDepthScale3pt(a, da, b, db, &sols_);
    for (const auto& p : sols_) models->push_back(Complete(p));
  }
  // With `test`: each pose faces the sequential test on its epipolar fit before its depths complete it (that pass
  // over the data costs as much as scoring).
  void Sample5(const int* s, SprtTest* test, std::vector<Model>* models) const {
    FivePointRelativePose(x_, y_, s, &rts_);
    for (const auto& rt : rts_) {
      if (test && !EpipolarPlausible(Complete({rt.R, rt.t, 1, 0, 0}), test)) continue;
      Model m;
      if (CompleteFivePoint(rt, &m)) models->push_back(m);
    }
  }
  // The sequential test (sprt.h) on a pose's epipolar fit alone (a 5-point pose before its depths complete it) …
  bool EpipolarPlausible(const Model& m, SprtTest* test) const {
    return test->Accept([&](size_t i) { return Sampson(m, i) < the2_; });
  }
  // … and on a complete model, where a match counts when either of its terms fits: a depth model may beat the best
  // through its reprojections while fitting fewer matches epipolarly.
  bool HybridPlausible(const Model& m, SprtTest* test) const {
    return test->Accept([&](size_t i) { return Sampson(m, i) < the2_ || DepthInlier(m, i); });
  }

  const std::vector<Eigen::Vector3d>& x() const { return x_; }
  const std::vector<Eigen::Vector3d>& y() const { return y_; }
  double dr(size_t i) const { return dr_[i]; }
  double dq(size_t i) const { return dq_[i]; }
  // The same problem with the query side (rays and depths) paired with other reference points: i → i + offset.
  Problem Shuffled(size_t offset) const {
    std::vector<Eigen::Vector3d> ys(y_.size());
    std::vector<double> dqs(dq_.size());
    for (size_t i = 0; i < y_.size(); ++i) {
      ys[i] = y_[(i + offset) % y_.size()];
      dqs[i] = dq_[(i + offset) % y_.size()];
    }
    return Problem(x_, ys, dr_, dqs, th_e_, th_r_);
  }
  double the2() const { return the2_; }
  double th_e() const { return th_e_; }

 private:
  static double Median(std::vector<double>* v) {
    auto mid = v->begin() + static_cast<long>(v->size() / 2);
    std::nth_element(v->begin(), mid, v->end());
    return *mid;
  }
  std::vector<Eigen::Vector3d> x_, y_;
  std::vector<double> dr_, dq_;
  std::vector<int> both_;
  double the2_, thr2_, th_e_, th_r_;
  mutable std::vector<DepthRelPose> sols_;
  mutable std::vector<PoseRt> rts_;
};

// (R, t, log s [, shifts]) refined on the Sampson residuals of `S` (one block each) and the two-way reprojections of
// `D` (one block of 2 + 2 each) under a unit Cauchy loss per block, residuals in threshold units; the Jacobian by
// forward differences. A step to a non-positive scale or a non-finite rotation is rejected.
class HybridRefinement {
 public:
  using Params = Model;
  static constexpr int kNumParams = Eigen::Dynamic;
  HybridRefinement(const Problem& pb, const std::vector<int>& S, const std::vector<int>& D, bool shifts, double inv_thr)
      : pb_(pb), S_(S), D_(D), shifts_(shifts), inv_thr_(inv_thr), rows_(static_cast<int>(S.size() + 4 * D.size())) {}
  int num_params() const { return shifts_ ? 9 : 7; }
  double Cost(const Model& m) const {
    Eigen::VectorXd r, w;
    Residuals(m, &r);
    return CostAndWeights(r, &w);
  }
  void Linearize(const Model& m, Eigen::MatrixXd* H, Eigen::VectorXd* g) const {
    const int P = num_params();
    Eigen::VectorXd r, w, r2;
    Residuals(m, &r);
    CostAndWeights(r, &w);
    Eigen::MatrixXd J(rows_, P);
    for (int k = 0; k < P; ++k) {
      Eigen::VectorXd d = Eigen::VectorXd::Zero(P);
      const double h = 1e-7;
      d(k) = h;
      Residuals(Apply(m, d), &r2);
      J.col(k) = (r2 - r) / h;
    }
    const Eigen::MatrixXd Jw = w.asDiagonal() * J;
    *H = J.transpose() * Jw;
    *g = Jw.transpose() * r;
  }
  bool Step(const Model& m, const Eigen::VectorXd& d, Model* out) const {
    *out = Apply(m, d);
    return out->p.scale > 0 && out->p.R.allFinite();
  }

 private:
  Model Apply(const Model& base, const Eigen::VectorXd& d) const {
    DepthRelPose p = base.p;
    p.R = ExpSO3(d.head<3>()) * p.R;
    p.t += d.segment<3>(3);
    p.scale *= std::exp(d(6));
    if (shifts_) {
      p.shift_ref += d(7);
      p.shift_query += d(8);
    }
    return Complete(p);
  }
  void Residuals(const Model& mm, Eigen::VectorXd* r) const {
    r->resize(rows_);
    int k = 0;
    for (int i : S_) {
      const Eigen::Vector3d Ea = mm.E * pb_.x()[i], Etb = mm.E.transpose() * pb_.y()[i];
      const double C = pb_.y()[i].dot(Ea);
      const double Sd = Ea(0) * Ea(0) + Ea(1) * Ea(1) + Etb(0) * Etb(0) + Etb(1) * Etb(1);
      (*r)(k++) = Sd > 1e-30 ? C / std::sqrt(Sd) / pb_.th_e() : 0.0;
    }
    for (int i : D_) {
      const Eigen::Vector3d& x = pb_.x()[i];
      const Eigen::Vector3d& y = pb_.y()[i];
      Eigen::Vector3d X = mm.p.R * ((pb_.dr(i) + mm.p.shift_ref) * x) + mm.p.t;
      double z = std::max(X.z(), 1e-6);
      (*r)(k++) = (X.x() / z - y.x()) * inv_thr_;
      (*r)(k++) = (X.y() / z - y.y()) * inv_thr_;
      X = mm.p.R.transpose() * (mm.p.scale * (pb_.dq(i) + mm.p.shift_query) * y - mm.p.t);
      z = std::max(X.z(), 1e-6);
      (*r)(k++) = (X.x() / z - x.x()) * inv_thr_;
      (*r)(k++) = (X.y() / z - x.y()) * inv_thr_;
    }
  }
  // Blocks are [1 Sampson residual]… then [2 + 2 reprojection residuals]…, each under the loss with its own weight.
  double CostAndWeights(const Eigen::VectorXd& r, Eigen::VectorXd* w) const {
    double c = 0;
    w->resize(rows_);
    const int ns = static_cast<int>(S_.size());
    for (int k = 0; k < ns; ++k) {
      const double e2 = r(k) * r(k);
      c += loss_.Cost(e2);
      (*w)(k) = loss_.Weight(e2);
    }
    for (int k = ns; k < rows_; k += 2) {
      const double e2 = r(k) * r(k) + r(k + 1) * r(k + 1);
      c += loss_.Cost(e2);
      (*w)(k) = (*w)(k + 1) = loss_.Weight(e2);
    }
    return c;
  }
  const Problem& pb_;
  const std::vector<int>& S_;
  const std::vector<int>& D_;
  bool shifts_;
  double inv_thr_;
  int rows_;
  CauchyLoss loss_{1.0};
};

double Problem::Refine(Model* m, bool shifts, int iterations) const {
  std::vector<int> S, D;
  for (size_t i = 0; i < x_.size(); ++i) {
    if (SampsonInlier(*m, i)) S.push_back(static_cast<int>(i));
    if (dr_[i] > 0 && dq_[i] > 0 && DepthInlier(*m, i)) D.push_back(static_cast<int>(i));
  }
  if (D.size() < 3 || S.size() + D.size() < 8) return -1;
  // Weigh the two kinds of residual by their observed noise: depth maps that are a few % off give reprojection
  // errors of many pixels, which would otherwise bend the rotation the matches fix to a fraction of a pixel. With
  // exact depth the reprojection noise is the matches' own and both count fully (the factor is capped at 1).
  double ss = 0, sr = 0;
  for (int i : S) ss += Sampson(*m, i);
  for (int i : D) sr += 0.25 * (RefToQuery(*m, i) + QueryToRef(*m, i));  // per coordinate
  const double var_s = std::max(ss / S.size(), 1e-4 * the2_), var_r = std::max(sr / D.size(), 1e-12);
  const double rw = std::sqrt(std::min(1.0, (var_s / var_r) * (thr2_ / the2_)));
  const double noise_ratio = var_r / var_s;
  LMOptions lm;
  lm.max_iterations = iterations;
  lm.initial_lambda = 1e-3;
  lm.min_relative_decrease = 1e-9;
  MinimizeLM(HybridRefinement(*this, S, D, shifts, rw / th_r_), m, lm);
  return noise_ratio;
}

// Draws k distinct entries of `pool` into `out`.
void DrawDistinct(SplitMix64* rng, const std::vector<int>& pool, int k, int* out) {
  for (int i = 0; i < k; ++i) {
    bool dup;
    do {
      out[i] = pool[rng->Below(static_cast<uint32_t>(pool.size()))];
      dup = false;
      for (int j = 0; j < i; ++j) dup |= out[j] == out[i];
    } while (dup);
  }
}

struct SearchResult {
  Model best;
  double score = kInf;
  int num_sampson = 0, num_depth = 0;
  int iterations = 0, local_optimizations = 0, samples_3pt = 0, samples_5pt = 0;
  RansacStop stop = RansacStop::kNoModel;  // kNoModel until the search ends
};

// The hybrid LO-RANSAC search: adaptive mix of 5-point and 3-point samples, hybrid MSAC score, local refinement of
// every new best; stops when the two families' sample counts together meet the success probability.
SearchResult Search(const Problem& pb, const HybridPoseOptions& opt, int max_iterations,
                    std::chrono::steady_clock::time_point t0) {
  SearchResult res;
  const size_t n = pb.size();
  std::vector<int> all(n);
  for (size_t i = 0; i < n; ++i) all[i] = static_cast<int>(i);
  const bool can3 = pb.both().size() >= 3;
  SplitMix64 rng(opt.ransac.seed);
  // Dense sets: the sequential test on every hypothesis and the give-up share for both families (ransac.h).
  // Two tests, each learning its own δ: 5-point poses on their epipolar fit, complete depth models on either fit.
  std::optional<SprtTest> sprt, sprt_hybrid;
  if (UsesSprt(opt.ransac, n)) {
    sprt.emplace(n, opt.ransac.seed, opt.ransac.min_inlier_ratio, kSolveCost);
    sprt_hybrid.emplace(n, opt.ransac.seed + 1, opt.ransac.min_inlier_ratio, kSolveCost);
  }
  // The chance that an all-inlier sample's model also passes its test.
  const double pass5 = sprt ? sprt->SampleSuccessFactor() : 1.0,
               pass3 = sprt ? sprt_hybrid->SampleSuccessFactor() : 1.0;
  const auto required5 = [&](size_t inliers) {
    return RequiredIterations(inliers, n, 5, opt.ransac.success_prob, pass5);
  };
  const auto required3 = [&](size_t inliers) {
    return can3 ? RequiredIterations(inliers, pb.both().size(), 3, opt.ransac.success_prob, pass3) : kInf;
  };
  double used5 = 0, used3 = 0;  // Σ over iterations of 1 / required(·) for each family (stop when ≥ 1)
  // Without the test no requirement stands before a model; with it, what would have found one holding the minimum
  // share (the give-up bound, ransac.h).
  double need5 = sprt ? GiveUpIterations(opt.ransac, n, 5, pass5) : kInf;
  double need3 = sprt && can3 ? GiveUpIterations(opt.ransac, pb.both().size(), 3, pass3) : kInf;
  std::vector<Model> models;
  int sample[5];
  int iter = 0;
  for (; iter < max_iterations; ++iter) {
    if (iter >= opt.ransac.min_iterations && used5 + used3 >= 1.0) break;
    if (opt.ransac.max_seconds > 0 && iter % 16 == 15 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > opt.ransac.max_seconds) {
      res.stop = RansacStop::kTimeBudget;
      break;
    }
    // Adaptive mix: the family expected to need fewer samples is drawn more often (even odds before any model, the
    // give-up bounds included).
    double p3 = 0.5;
    if (std::isfinite(res.score) && (std::isfinite(need3) || std::isfinite(need5))) {
      const double a = std::isfinite(need3) ? 1.0 / std::max(need3, 1.0) : 0.0;
      const double b = std::isfinite(need5) ? 1.0 / std::max(need5, 1.0) : 0.0;
      p3 = std::clamp(a / (a + b), 0.1, 0.9);
    }
    if (!can3) p3 = 0;
    const bool three = (rng.Next() >> 11) * 0x1.0p-53 < p3;
    models.clear();
    if (three) {
      DrawDistinct(&rng, pb.both(), 3, sample);
      pb.Sample3(sample, opt.shifts, &models);
      ++res.samples_3pt;
      if (std::isfinite(need3)) used3 += 1.0 / std::max(need3, 1.0);
    } else {
      DrawDistinct(&rng, all, 5, sample);
      pb.Sample5(sample, sprt ? &*sprt : nullptr, &models);
      ++res.samples_5pt;
      if (std::isfinite(need5)) used5 += 1.0 / std::max(need5, 1.0);
    }
    for (Model& m : models) {
      if (three && sprt_hybrid && !pb.HybridPlausible(m, &*sprt_hybrid)) continue;
      int ns = 0, nd = 0;
      const double sc = pb.Score(m, res.score, &ns, &nd);
      if (!(sc < res.score)) continue;
      res.best = m;
      res.score = sc;
      res.num_sampson = ns;
      res.num_depth = nd;
      Model lo = m;
      pb.Refine(&lo, opt.shifts, 4);
      ++res.local_optimizations;
      int ls = 0, ld = 0;
      const double lsc = pb.Score(lo, res.score, &ls, &ld);
      if (lsc < res.score) {
        res.best = lo;
        res.score = lsc;
        res.num_sampson = ls;
        res.num_depth = ld;
      }
      need5 = required5(static_cast<size_t>(res.num_sampson));
      need3 = required3(static_cast<size_t>(res.num_depth));
      // What has been drawn so far counts against the new requirements.
      used5 = std::isfinite(need5) ? res.samples_5pt / std::max(need5, 1.0) : 0.0;
      used3 = std::isfinite(need3) ? res.samples_3pt / std::max(need3, 1.0) : 0.0;
    }
  }
  res.iterations = iter;
  if (res.stop != RansacStop::kTimeBudget)
    res.stop = iter >= max_iterations      ? RansacStop::kMaxIterations
               : !std::isfinite(res.score) ? (sprt ? RansacStop::kGaveUp : RansacStop::kNoModel)
                                           : RansacStop::kConfidence;
  return res;
}

}  // namespace

HybridPoseResult EstimateHybridPose(const std::vector<Eigen::Vector2d>& px_ref,
                                    const std::vector<Eigen::Vector2d>& px_query, const std::vector<double>& depth_ref,
                                    const std::vector<double>& depth_query, const Camera& ref, const Camera& query,
                                    const HybridPoseOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  opt.Validate();
  const size_t n = px_ref.size();
  FREELOC_CHECK(px_query.size() == n && depth_ref.size() == n && depth_query.size() == n,
                "hybrid pose: " << n << " reference points but " << px_query.size() << " query points, "
                                << depth_ref.size() << " and " << depth_query.size() << " depths");
  CheckFinite(px_ref, "hybrid pose (reference points)");
  CheckFinite(px_query, "hybrid pose (query points)");
  ref.Validate("reference intrinsics");
  query.Validate("query intrinsics");
  HybridPoseResult res;
  res.status.num_matches = static_cast<int>(n);
  res.inliers.assign(n, 0);
  auto finish = [&](EstimatorOutcome outcome) {
    res.status.outcome = outcome;
    res.status.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return res;
  };
  if (n < static_cast<size_t>(opt.min_inliers)) return finish(EstimatorOutcome::kTooFewMatches);
  std::vector<Eigen::Vector3d> x(n), y(n);
  std::vector<double> dr(n), dq(n);
  for (size_t i = 0; i < n; ++i) {
    x[i] = ref.Unproject(px_ref[i].x(), px_ref[i].y());
    y[i] = query.Unproject(px_query[i].x(), px_query[i].y());
    dr[i] = std::isfinite(depth_ref[i]) && depth_ref[i] > 0 ? depth_ref[i] : 0.0;
    dq[i] = std::isfinite(depth_query[i]) && depth_query[i] > 0 ? depth_query[i] : 0.0;
  }
  const double focal = 0.25 * (ref.fx + ref.fy + query.fx + query.fy);
  const Problem pb(std::move(x), std::move(y), std::move(dr), std::move(dq), opt.threshold_px / focal,
                   opt.reprojection_px / focal);
  SearchResult found = Search(pb, opt, opt.ransac.max_iterations, t0);
  Model best = found.best;
  res.samples_3pt = found.samples_3pt;
  res.samples_5pt = found.samples_5pt;
  res.status.iterations = found.iterations;
  res.status.local_optimizations = found.local_optimizations;
  res.status.stop = found.stop;
  const double best_score = found.score;
  const int best_ns = found.num_sampson;
  if (!std::isfinite(best_score) || best_ns < 5) return finish(EstimatorOutcome::kNoConsensus);
  // Final refinement: twice, re-selecting the inliers in between.
  double noise_ratio = -1;
  for (int round = 0; round < 2; ++round) noise_ratio = pb.Refine(&best, opt.shifts, opt.refinement_iterations);
  // Depth clearly noisier than the matches — σ more than 3.5 × theirs (bench/baseline rooms, 10th–90th percentiles:
  // exact depth 1.9–3.2 ×, depth with 5–8 % errors 2.9–5.2 ×, monocular-like 4.8–7.9 ×): the rotation and direction
  // from the matches alone (Sampson refinement on the hybrid's inliers), the metric length and query scale then
  // anchored on the depths. Depth as good as the matches (sensor depth, exact) keeps the joint estimate.
  if (noise_ratio > 12) pb.Polish(&best);
  res.model = best.p;
  const PoseRt unit{best.p.R, best.p.t.norm() > 0 ? Eigen::Vector3d(best.p.t.normalized()) : Eigen::Vector3d::Zero()};
  int n_in = 0;
  double sampson_sum = 0, reproj_sum = 0, depth_sum = 0;
  std::vector<double> log_len;
  for (size_t i = 0; i < n; ++i) {
    const double es = pb.Sampson(best, i);
    if (es < pb.the2() && InFront(unit, pb.x()[i], pb.y()[i])) {
      res.inliers[i] = 1;
      ++n_in;
      sampson_sum += es;
    }
    if (!res.inliers[i] || !(pb.dr(i) > 0) || !(pb.dq(i) > 0)) continue;
    ++res.depth_candidates;
    if (pb.DepthInlier(best, i)) {
      ++res.depth_inliers;
      reproj_sum += 0.5 * (pb.RefToQuery(best, i) + pb.QueryToRef(best, i));
      const double d = pb.dr(i) + best.p.shift_ref;
      depth_sum += d;
      double l1, l2;
      if (TriangulateDepths(unit, pb.x()[i], pb.y()[i], &l1, &l2) && l1 > 0)
        log_len.push_back(std::log(d / l1));  // what this point says of log |t|
    }
  }
  res.status.num_inliers = n_in;
  res.residual_px = focal * std::sqrt(sampson_sum / std::max(1, n_in));
  res.reprojection_rms_px = focal * std::sqrt(reproj_sum / std::max(1, res.depth_inliers));
  res.mean_depth = res.depth_inliers > 0 ? depth_sum / res.depth_inliers : 0.0;
  if (log_len.size() >= 2) {
    double mean = 0, var = 0;
    for (double v : log_len) mean += v;
    mean /= static_cast<double>(log_len.size());
    for (double v : log_len) var += (v - mean) * (v - mean);
    var /= static_cast<double>(log_len.size() - 1);
    res.scale_std_error = std::sqrt(var / static_cast<double>(log_len.size()));
  } else {
    res.scale_std_error = 1.0;
  }
  // Never a confident wrong answer (as EstimateRelativePose): support must clearly beat what chance gives.
  res.status.chance_inliers = ChanceInliers(pb.x(), pb.y(), unit, pb.the2());
  const double chance = res.status.chance_inliers;
  if (n_in < opt.min_inliers || n_in < 2 * chance + 8 * std::sqrt(chance) || !best.p.R.allFinite() ||
      !best.p.t.allFinite()) {
    res.inliers.assign(n, 0);
    return finish(EstimatorOutcome::kNoConsensus);
  }
  // A metric model needs correspondences whose depths agree with it (else the depth-free estimators answer).
  if (res.depth_inliers < 3) {
    res.inliers.assign(n, 0);
    return finish(EstimatorOutcome::kNoConsensus);
  }
  // Weak support: the same search on the matches with the query side shuffled must find clearly fewer inliers —
  // RANSAC's search over thousands of hypotheses finds a dozen chance inliers in unrelated matches.
  if (n_in < std::max(3 * opt.min_inliers, static_cast<int>(0.25 * static_cast<double>(n)))) {
    HybridPoseOptions so = opt;
    if (opt.ransac.max_seconds > 0)
      so.ransac.max_seconds = std::max(
          0.1, opt.ransac.max_seconds - std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    const SearchResult ss = Search(pb.Shuffled(n / 2 + 1), so, std::max(found.iterations, opt.ransac.min_iterations),
                                   std::chrono::steady_clock::now());
    res.status.shuffled_best = std::isfinite(ss.score) ? ss.num_sampson : 0;
    if (n_in < 1.5 * res.status.shuffled_best + 4) {
      res.inliers.assign(n, 0);
      return finish(EstimatorOutcome::kNoConsensus);
    }
  }
  if (InliersDegenerate(px_ref, px_query, res.inliers)) {
    res.inliers.assign(n, 0);
    res.status.num_inliers = 0;
    return finish(EstimatorOutcome::kDegenerate);
  }
  return finish(EstimatorOutcome::kOk);
}

}  // namespace freeloc::geometry
