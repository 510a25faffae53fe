#include "freeloc/geometry/metric_scale.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "freeloc/core/error.h"
#include "freeloc/geometry/essential.h"

namespace freeloc::geometry {

void ScaleOptions::Validate() const {
  FREELOC_CHECK(official_threshold_m > 0 && relative_threshold > 0 && min_threshold_m >= 0,
                "metric scale: thresholds must be positive");
  FREELOC_CHECK(refit_iterations >= 0, "metric scale: refit_iterations must be >= 0");
}

float BilinearDepth(const DepthMap& d, double x, double y) {
  if (!(x >= 0 && y >= 0 && x <= d.width - 1 && y <= d.height - 1)) return 0.f;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const int x1 = std::min(x0 + 1, d.width - 1), y1 = std::min(y0 + 1, d.height - 1);
  const float a = d.at(x0, y0), b = d.at(x1, y0), c = d.at(x0, y1), e = d.at(x1, y1);
  if (!(a > 0 && b > 0 && c > 0 && e > 0)) return 0.f;
  const double fx = x - x0, fy = y - y0;
  return static_cast<float>((1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * e));
}

namespace {

// One candidate per correspondence with depth in both frames: s = t̂·(X_query − R·X_ref), its window τ and the mean
// distance of its two points.
struct Candidates {
  std::vector<double> s, tau, dist;
};

Candidates ScaleCandidates(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                           const Rigid3d& query_from_ref, const DepthMap& depth_ref, const DepthMap& depth_query,
                           const Camera& ref, const Camera& query, const ScaleOptions& opt) {
  const Eigen::Matrix3d R = query_from_ref.R();
  const Eigen::Vector3d t = query_from_ref.translation.normalized();
  Candidates c;
  c.s.reserve(px_ref.size());
  for (size_t i = 0; i < px_ref.size(); ++i) {
    double ur = px_ref[i].x(), vr = px_ref[i].y(), uq = px_query[i].x(), vq = px_query[i].y();
    double dr, dq;
    if (opt.method == ScaleMethod::kOfficial) {
      // np.int32: truncation toward zero; the truncated pixel is also what gets back-projected.
      ur = std::trunc(ur);
      vr = std::trunc(vr);
      uq = std::trunc(uq);
      vq = std::trunc(vq);
      const bool in_r = ur >= 0 && vr >= 0 && ur < depth_ref.width && vr < depth_ref.height;
      const bool in_q = uq >= 0 && vq >= 0 && uq < depth_query.width && vq < depth_query.height;
      dr = in_r ? depth_ref.at(static_cast<int>(ur), static_cast<int>(vr)) : 0.0;
      dq = in_q ? depth_query.at(static_cast<int>(uq), static_cast<int>(vq)) : 0.0;
    } else {
      dr = BilinearDepth(depth_ref, ur, vr);
      dq = BilinearDepth(depth_query, uq, vq);
    }
    if (!(dr > 0 && dq > 0)) continue;
    const Eigen::Vector3d pr = dr * ref.Unproject(ur, vr);
    const Eigen::Vector3d pq = dq * query.Unproject(uq, vq);
    c.s.push_back((pq - R * pr).dot(t));
    c.dist.push_back(0.5 * (pr.norm() + pq.norm()));
    c.tau.push_back(std::max(opt.min_threshold_m, opt.relative_threshold * c.dist.back()));
  }
  return c;
}

// The benchmark's vote: the candidate with the most others within 0.1 m; its support is the confidence.
void OfficialVote(const std::vector<double>& s, const ScaleOptions& opt, ScaleResult* res) {
  int best = 0;
  double best_s = 0;
  for (double h : s) {
    int n = 0;
    for (double v : s) n += std::abs(v - h) < opt.official_threshold_m;
    if (n > best) {
      best = n;
      best_s = h;
    }
  }
  res->outcome = ScaleOutcome::kOk;
  res->scale = best_s;
  res->num_inliers = best;
  res->confidence = best;
}

// Robust: hypotheses = candidates (a subset when there are many); support = Σ [|s_j − h| < τ_j] / τ_j, a
// variable-bandwidth kernel density: each candidate has the same mass, so the wide windows of far (less precise)
// points do not outvote the near ones (bench/scale, bench/baseline: lower p90 error than a plain count).
double BestHypothesis(const Candidates& c) {
  const size_t n = c.s.size();
  const size_t stride = std::max<size_t>(1, n / 2000);
  double best = -1, best_h = 0;
  for (size_t i = 0; i < n; i += stride) {
    double sup = 0;
    for (size_t j = 0; j < n; ++j) sup += std::abs(c.s[j] - c.s[i]) < c.tau[j] ? 1.0 / c.tau[j] : 0.0;
    if (sup > best || (sup == best && c.s[i] < best_h)) {
      best = sup;
      best_h = c.s[i];
    }
  }
  return best_h;
}

void RobustVote(const Candidates& c, const ScaleOptions& opt, ScaleResult* res) {
  const size_t n = c.s.size();
  // Inverse-variance weighted refit on the consensus, iterated with the window re-centred.
  double est = BestHypothesis(c), sw = 0;
  int in = 0;
  for (int it = 0; it <= opt.refit_iterations; ++it) {
    double swx = 0;
    sw = 0;
    in = 0;
    for (size_t j = 0; j < n; ++j) {
      if (std::abs(c.s[j] - est) >= c.tau[j]) continue;
      const double w = 1.0 / (c.tau[j] * c.tau[j]);
      swx += w * c.s[j];
      sw += w;
      ++in;
    }
    if (in == 0) break;
    est = swx / sw;
  }
  if (in < std::max(1, opt.min_inliers)) {
    res->outcome = ScaleOutcome::kNoConsensus;
    return;
  }
  // Standard error of the weighted mean from the residual scatter (in units of the windows).
  double chi2 = 0, dist_sum = 0;
  for (size_t j = 0; j < n; ++j) {
    if (std::abs(c.s[j] - est) >= c.tau[j]) continue;
    const double r = (c.s[j] - est) / c.tau[j];
    chi2 += r * r;
    dist_sum += c.dist[j];
  }
  const double dof = std::max(1, in - 1);
  const double se = std::sqrt(std::max(chi2 / dof, 1.0 / 12.0) / sw);  // ≥ the uniform-window floor
  const double inlier_ratio = static_cast<double>(in) / static_cast<double>(n);
  res->outcome = ScaleOutcome::kOk;
  res->scale = est;
  res->num_inliers = in;
  res->relative_std_error = se / std::max(std::abs(est), 1e-9);
  res->std_error_m = se;
  res->mean_distance_m = dist_sum / in;
  // Higher = more accurate: small relative standard error, large agreeing fraction.
  res->confidence = inlier_ratio / (res->relative_std_error + 1e-3);
}

// Per inlier, the log ratio of each map's depth to the unit-baseline triangulation's (lr: the reference map's, with
// its parallax window; lq: the query map's), for the points whose triangulation is in front of both cameras.
struct AnchorSamples {
  std::vector<double> lr, lq, window;
  double depth_sum = 0;
};

AnchorSamples CollectAnchors(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                             const Rigid3d& query_from_ref, const DepthMap& depth_ref, const DepthMap& depth_query,
                             const Camera& ref, const Camera& query) {
  const PoseRt unit{query_from_ref.R(), query_from_ref.translation.normalized()};
  // What one point's log ratio may differ by on a right pose: the depth map's own error (10 %) plus the
  // triangulation's, ~ angular noise ÷ parallax (1 px of noise).
  const double sigma = 2.0 / (ref.fx + ref.fy + query.fx + query.fy) * 2.0;  // 1 px in radians
  AnchorSamples a;
  for (size_t i = 0; i < px_ref.size(); ++i) {
    const Eigen::Vector3d x1 = ref.Unproject(px_ref[i].x(), px_ref[i].y());
    const Eigen::Vector3d x2 = query.Unproject(px_query[i].x(), px_query[i].y());
    double l1, l2;
    if (!TriangulateDepths(unit, x1, x2, &l1, &l2) || !(l1 > 0) || !(l2 > 0)) continue;
    const double dr = depth_ref.empty() ? 0.0 : BilinearDepth(depth_ref, px_ref[i].x(), px_ref[i].y());
    const double dq = depth_query.empty() ? 0.0 : BilinearDepth(depth_query, px_query[i].x(), px_query[i].y());
    if (dr > 0) {
      a.lr.push_back(std::log(dr / l1));
      a.depth_sum += dr;
      const double parallax =
          std::max(1e-6, std::abs(std::asin(std::min(1.0, (unit.R * x1).normalized().cross(x2.normalized()).norm()))));
      a.window.push_back(0.1 + 3 * sigma / parallax);
    }
    if (dq > 0) a.lq.push_back(std::log(dq / l2));
  }
  return a;
}

void AnchoredScale(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                   const Rigid3d& query_from_ref, const DepthMap& depth_ref, const DepthMap& depth_query,
                   const Camera& ref, const Camera& query, const ScaleOptions& opt, ScaleResult* res) {
  const AnchorSamples a = CollectAnchors(px_ref, px_query, query_from_ref, depth_ref, depth_query, ref, query);
  const std::vector<double>& lr = a.lr;
  const std::vector<double>& lq = a.lq;
  const std::vector<double>& window = a.window;
  const double depth_sum = a.depth_sum;
  res->num_candidates = static_cast<int>(lr.size());
  if (lr.empty()) {
    res->outcome = ScaleOutcome::kNoValidDepth;
    return;
  }
  const TrimmedMeanResult tr = TrimmedMean(lr, 0.01);
  const double mr = tr.mean;
  double ser = tr.std_error;
  const int kr = tr.kept;
  if (kr < std::max(1, opt.min_inliers)) {
    res->outcome = ScaleOutcome::kNoConsensus;
    return;
  }
  double log_scale = mr, anchor = 0;
  // The maps' common scale error cannot show in their disagreement, but two maps whose anchorings agree closely
  // make a large one less likely: the prior shrinks from kCommonDepthScaleError towards 1 % as they agree (with
  // exact depth the 5 % prior alone would rank the answers by |t|, not by their error).
  double common = kCommonDepthScaleError;
  if (lq.size() >= static_cast<size_t>(std::max(1, opt.min_inliers))) {
    const TrimmedMeanResult tq = TrimmedMean(lq, 0.01);
    const double mq = tq.mean, seq = tq.std_error;
    if (tq.kept >= opt.min_inliers && std::abs(mr - mq) <= std::log(2.0)) {
      log_scale = 0.5 * (mr + mq);
      ser = 0.5 * std::sqrt(ser * ser + seq * seq);
      anchor = 0.5 * std::abs(mr - mq);
      common = std::clamp(2 * anchor, 0.01, kCommonDepthScaleError);
    }
  }
  res->outcome = ScaleOutcome::kOk;
  res->scale = std::exp(log_scale);
  // The consensus: points whose depth agrees with the pose's triangulation within what their parallax allows — a
  // wrong pose (a wrong rotation's triangulation) leaves many outside, a right one few (the confidence uses it).
  int agree = 0;
  for (size_t i = 0; i < lr.size(); ++i) agree += std::abs(lr[i] - mr) < window[i];
  res->num_inliers = std::max(agree, std::min(kr, opt.min_inliers));
  res->relative_std_error = std::sqrt(ser * ser + anchor * anchor + common * common);
  res->std_error_m = res->scale * res->relative_std_error;
  res->mean_distance_m = depth_sum / static_cast<double>(lr.size());
  res->confidence = (static_cast<double>(kr) / lr.size()) / (res->relative_std_error + 1e-3);
}

}  // namespace

ScaleAnchors AnchorScales(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                          const Rigid3d& query_from_ref, const DepthMap& depth_ref, const DepthMap& depth_query,
                          const Camera& ref, const Camera& query) {
  FREELOC_CHECK(px_ref.size() == px_query.size(), "metric scale: point lists differ in length");
  const AnchorSamples a = CollectAnchors(px_ref, px_query, query_from_ref, depth_ref, depth_query, ref, query);
  ScaleAnchors out;
  if (!a.lr.empty()) {
    const TrimmedMeanResult t = TrimmedMean(a.lr, 0.01);
    out.log_ref = t.mean, out.se_ref = t.std_error, out.kept_ref = t.kept;
  }
  if (!a.lq.empty()) {
    const TrimmedMeanResult t = TrimmedMean(a.lq, 0.01);
    out.log_query = t.mean, out.se_query = t.std_error, out.kept_query = t.kept;
  }
  return out;
}

TrimmedMeanResult TrimmedMean(const std::vector<double>& v, double min_window) {
  std::vector<double> w = v;
  std::nth_element(w.begin(), w.begin() + static_cast<long>(w.size() / 2), w.end());
  const double med = w[w.size() / 2];
  for (size_t i = 0; i < v.size(); ++i) w[i] = std::abs(v[i] - med);
  std::nth_element(w.begin(), w.begin() + static_cast<long>(w.size() / 2), w.end());
  const double window = std::max(min_window, 3 * 1.4826 * w[w.size() / 2]);
  double s = 0, s2 = 0;
  int n = 0;
  for (double x : v)
    if (std::abs(x - med) <= window) {
      s += x;
      s2 += x * x;
      ++n;
    }
  TrimmedMeanResult r;
  r.kept = n;
  r.mean = n > 0 ? s / n : med;
  const double var = n > 1 ? std::max(0.0, (s2 - s * s / n) / (n - 1)) : 1.0;
  r.std_error = std::sqrt(var / std::max(1, n));
  return r;
}

ScaleResult EstimateMetricScale(const std::vector<Eigen::Vector2d>& px_ref,
                                const std::vector<Eigen::Vector2d>& px_query, const Rigid3d& query_from_ref,
                                const DepthMap& depth_ref, const DepthMap& depth_query, const Camera& ref,
                                const Camera& query, const ScaleOptions& opt) {
  opt.Validate();
  FREELOC_CHECK(px_ref.size() == px_query.size(), "metric scale: point lists differ in length");
  FREELOC_CHECK(!depth_ref.empty() && !depth_query.empty(), "metric scale: both depth maps are needed");
  ScaleResult res;
  if (opt.method == ScaleMethod::kAnchored) {
    AnchoredScale(px_ref, px_query, query_from_ref, depth_ref, depth_query, ref, query, opt, &res);
    return res;
  }
  const Candidates c = ScaleCandidates(px_ref, px_query, query_from_ref, depth_ref, depth_query, ref, query, opt);
  res.num_candidates = static_cast<int>(c.s.size());
  if (c.s.empty()) {
    res.outcome = ScaleOutcome::kNoValidDepth;
  } else if (opt.method == ScaleMethod::kOfficial) {
    OfficialVote(c.s, opt, &res);
  } else {
    RobustVote(c, opt, &res);
  }
  return res;
}

}  // namespace freeloc::geometry
