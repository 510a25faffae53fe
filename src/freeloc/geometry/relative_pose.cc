#include "freeloc/geometry/relative_pose.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "freeloc/core/error.h"
#include "freeloc/geometry/five_point.h"
#include "freeloc/geometry/refine_relative_pose.h"

namespace freeloc::geometry {

void RelativePoseOptions::Validate() const {
  FREELOC_CHECK(threshold_px > 0 && std::isfinite(threshold_px),
                "relative pose: threshold_px must be a positive number of pixels");
  ransac.Validate("relative pose");
  FREELOC_CHECK(min_inliers >= 5, "relative pose: min_inliers must be at least 5 (the minimal sample)");
  FREELOC_CHECK(competitor_samples >= 0 && competitor_samples <= 100000,
                "relative pose: competitor_samples must be in [0, 100000]");
}

void CheckFinite(const std::vector<Eigen::Vector2d>& pts, const std::string& what) {
  for (size_t i = 0; i < pts.size(); ++i) {
    FREELOC_CHECK(pts[i].allFinite(), what << ": correspondence " << i << " has a non-finite coordinate (" << pts[i].x()
                                           << ", " << pts[i].y() << "); remove NaN/inf rows");
  }
}

namespace {

// A hypothesis carries its essential matrix so scoring never recomputes it.
struct RelModel {
  PoseRt pose;
  Eigen::Matrix3d E;
};

class RelPoseEstimator {
 public:
  using Model = RelModel;
  static constexpr int kSampleSize = 5;
  static constexpr double kSolveCost = 500;  // a 5-point solve per model it gives, in Sampson errors (bench/solver)
  RelPoseEstimator(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2, double th)
      : x1_(x1), x2_(x2), loss_scale_(th) {}
  size_t num_data() const { return x1_.size(); }
  void MinimalSolve(const int* s, std::vector<Model>* models) const {
    FivePointRelativePose(x1_, x2_, s, &poses_);
    for (const auto& p : poses_) models->push_back({p, EssentialFromPose(p)});
  }
  double SquaredError(const Model& m, size_t i) const { return SampsonSquared(m.E, x1_[i], x2_[i]); }
  void LocalOptimize(Model* m, double threshold_sq) const {
    std::vector<int> in;
    for (size_t i = 0; i < x1_.size(); ++i)
      if (SampsonSquared(m->E, x1_[i], x2_[i]) < threshold_sq) in.push_back(static_cast<int>(i));
    if (in.size() < 6) return;
    RefineRelativePose(x1_, x2_, in, loss_scale_, 4, &m->pose);
    m->E = EssentialFromPose(m->pose);
  }

 private:
  const std::vector<Eigen::Vector3d>& x1_;
  const std::vector<Eigen::Vector3d>& x2_;
  double loss_scale_;
  mutable std::vector<PoseRt> poses_;
};

}  // namespace

// The smaller principal spread (standard deviation, pixels) of the inlier points of one image.
namespace {
double MinorSpread(const std::vector<Eigen::Vector2d>& px, const std::vector<char>& inliers) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  int n = 0;
  for (size_t i = 0; i < px.size(); ++i)
    if (inliers[i]) {
      mean += px[i];
      ++n;
    }
  if (n == 0) return 0;
  mean /= n;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (size_t i = 0; i < px.size(); ++i)
    if (inliers[i]) cov += (px[i] - mean) * (px[i] - mean).transpose();
  cov /= n;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  return std::sqrt(std::max(0.0, eig.eigenvalues()(0)));
}
}  // namespace

// Degenerate support: the inliers lie on (almost) a line or a single pixel in either image — the essential
// matrix is not determined by them (a 2-pixel band: collinear points, one edge, one blob).
bool InliersDegenerate(const std::vector<Eigen::Vector2d>& px_ref, const std::vector<Eigen::Vector2d>& px_query,
                       const std::vector<char>& inliers) {
  return MinorSpread(px_ref, inliers) < 1.0 || MinorSpread(px_query, inliers) < 1.0;
}

// Inliers of `pose` when the query points are paired with other reference points (fixed shuffles, averaged):
// what chance alone gives this model with these point distributions.
int ChanceInliers(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2, const PoseRt& pose,
                  double threshold_sq) {
  const size_t n = x1.size();
  if (n < 2) return 0;
  const Eigen::Matrix3d E = EssentialFromPose(pose);
  SplitMix64 rng(12345);
  int total = 0;
  constexpr int kShuffles = 3;
  for (int s = 0; s < kShuffles; ++s) {
    const size_t offset = 1 + rng.Below(static_cast<uint32_t>(n - 1));  // a derangement: i → i + offset (mod n)
    for (size_t i = 0; i < n; ++i)
      if (SampsonSquared(E, x1[i], x2[(i + offset) % n]) < threshold_sq) ++total;
  }
  return total / kShuffles;
}

namespace {

// The inliers of `p`: the correspondences within the Sampson threshold.
void CollectInliers(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2, const PoseRt& p,
                    double threshold_sq, std::vector<int>* in) {
  in->clear();
  const Eigen::Matrix3d E = EssentialFromPose(p);
  for (size_t i = 0; i < x1.size(); ++i)
    if (SampsonSquared(E, x1[i], x2[i]) < threshold_sq) in->push_back(static_cast<int>(i));
}

// Competing models: a distinct model with nearly the same support (a planar view's twin) is examined with the
// evidence beyond the Sampson count — cheirality, and the depths' consistency when given — and the confidence
// learns how plausible the loser stayed.
// The winner may change (`best`, its inliers `in` collected again); the runner-up and the decision go into `res`.
void DecideCompetingModels(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                           const RelativePoseOptions& opt, const DepthSamples& depth, double th, double threshold_sq,
                           double focal, PoseRt* best_model, std::vector<int>* in_out, RelativePoseResult* res_out) {
  PoseRt& best = *best_model;
  std::vector<int>& in = *in_out;
  RelativePoseResult& res = *res_out;
  const auto collect = [&](const PoseRt& p) { CollectInliers(x1, x2, p, threshold_sq, &in); };
  std::vector<CompetingModel> near;
  const bool use_depth = !depth.ref.empty() || !depth.query.empty();
  const auto rivals = FindCompetingRelativeModels(x1, x2, best, in, threshold_sq, th, opt.ransac.seed,
                                                  opt.competitor_samples, 0.7, 3, use_depth ? &near : nullptr);
  const double sigma = 1.0 / focal;
  // The evidence of every model on the same even subsample of ≤ 4000 correspondences (dense sets).
  const size_t stride = std::max<size_t>(1, x1.size() / 2000);
  std::vector<Eigen::Vector3d> e1, e2;
  DepthSamples ed;
  for (size_t i = 0; i < x1.size(); i += stride) {
    e1.push_back(x1[i]);
    e2.push_back(x2[i]);
    if (!depth.ref.empty()) ed.ref.push_back(i < depth.ref.size() ? depth.ref[i] : 0.0);
    if (!depth.query.empty()) ed.query.push_back(i < depth.query.size() ? depth.query[i] : 0.0);
  }
  auto evaluate = [&](const PoseRt& p) { return EvaluateRelativeModel(e1, e2, p, threshold_sq, ed, sigma); };
  std::vector<PoseRt> models = {best};
  std::vector<ModelEvidence> ev = {evaluate(best)};
  for (const auto& r : rivals) {
    models.push_back(r.pose);
    ev.push_back(evaluate(r.pose));
  }
  // Depth: every model must have enough depth samples; the near-winner minimal-sample models join (a flat
  // valley of near-equal Sampson support, where the depths pick the point the matches cannot).
  bool by_depth = use_depth;
  for (const auto& e : ev) by_depth &= e.depth_samples >= 10;
  if (by_depth)
    for (const auto& m : near)
      if (m.inliers >= 0.9 * static_cast<double>(in.size())) {
        models.push_back(m.pose);
        ev.push_back(evaluate(m.pose));
      }
  if (models.size() > 1) {
    const size_t n_rivals = rivals.size() + 1;  // models [0, n_rivals): RANSAC's winner and the refined rivals
    auto evidence = [&](const ModelEvidence& e) {
      return by_depth ? static_cast<double>(e.depth_reprojection_inliers) : static_cast<double>(e.in_front);
    };
    // RANSAC's winner stands unless the evidence beyond its score is clearly better elsewhere. (Not the lowest
    // Sampson score among the refined rivals: a refinement can slide into a model that explains more matches
    // with many of them behind a camera.)
    size_t win = 0;
    // The evidence beyond support overrules it when clearly better (10 % and 2 points), among the refined models
    // — and, with depth, the near-winner ones.
    const size_t pool = by_depth ? models.size() : n_rivals;
    size_t best_ev = win;
    for (size_t k = 0; k < pool; ++k)
      if (evidence(ev[k]) > evidence(ev[best_ev])) best_ev = k;
    const bool overruled = evidence(ev[best_ev]) > 1.1 * evidence(ev[win]) + 2;
    if (overruled) win = best_ev;
    // The runner-up: the most plausible refined model that is a different answer, and how plausible it stayed —
    // exp(−Δ/√e): its evidence deficit in (Poisson) standard deviations of the winner's.
    size_t runner = models.size();
    for (size_t k = 0; k < n_rivals; ++k)
      if (k != win && DistinctModels(models[k], models[win]) &&
          (runner == models.size() || evidence(ev[k]) > evidence(ev[runner])))
        runner = k;
    const double e_win = std::max(evidence(ev[win]), 1.0);
    res.status.competitors = static_cast<int>(rivals.size());
    if (runner < models.size()) {
      const double deficit = std::max(0.0, e_win - evidence(ev[runner]));
      res.status.runner_up_plausibility = std::exp(-deficit / std::sqrt(e_win));
      res.status.runner_up_inliers = ev[runner].inliers * static_cast<int>(stride);
      res.runner_up = Rigid3d(models[runner].R, models[runner].t.normalized());
    }
    res.status.decided_by = overruled ? (by_depth ? CompetitorDecision::kDepth : CompetitorDecision::kCheirality)
                                      : CompetitorDecision::kSupport;
    if (win != 0) {
      best = models[win];
      collect(best);
      // A refined rival was refined on a subsample of a dense set: once more on all its inliers. (A near-winner
      // model picked by the depths stays as it is: the Sampson cost would slide it back along the valley.)
      if (win <= rivals.size() && stride > 1 && in.size() >= 6 && opt.final_refinement) {
        RefineRelativePose(x1, x2, in, th, opt.refinement_iterations, &best);
        collect(best);
      }
    }
  }
}

}  // namespace

RelativePoseResult EstimateRelativePose(const std::vector<Eigen::Vector2d>& px_ref,
                                        const std::vector<Eigen::Vector2d>& px_query, const Camera& ref,
                                        const Camera& query, const RelativePoseOptions& opt,
                                        const DepthSamples& depth) {
  const auto t0 = std::chrono::steady_clock::now();
  opt.Validate();
  FREELOC_CHECK(px_ref.size() == px_query.size(),
                "relative pose: " << px_ref.size() << " reference points but " << px_query.size() << " query points");
  CheckFinite(px_ref, "relative pose (reference points)");
  CheckFinite(px_query, "relative pose (query points)");
  ref.Validate("reference intrinsics");
  query.Validate("query intrinsics");
  RelativePoseResult res;
  res.status.num_matches = static_cast<int>(px_ref.size());
  res.inliers.assign(px_ref.size(), 0);
  auto finish = [&](EstimatorOutcome outcome) {
    res.status.outcome = outcome;
    res.status.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return res;
  };
  if (px_ref.size() < static_cast<size_t>(opt.min_inliers)) return finish(EstimatorOutcome::kTooFewMatches);
  std::vector<Eigen::Vector3d> x1(px_ref.size()), x2(px_ref.size());
  for (size_t i = 0; i < px_ref.size(); ++i) {
    x1[i] = ref.Unproject(px_ref[i].x(), px_ref[i].y());
    x2[i] = query.Unproject(px_query[i].x(), px_query[i].y());
  }
  const double focal = 0.25 * (ref.fx + ref.fy + query.fx + query.fy);
  const double th = opt.threshold_px / focal;
  RelPoseEstimator est(x1, x2, th);
  const double threshold_sq = th * th;
  // The weak-support control (below): the same search on the matches with the query points shuffled (a fixed
  // derangement), for as many iterations as the main search takes. It starts now, beside the main search, and is
  // cut at that count (or stopped, when the answer does not need it); its time budget is the whole search's.
  std::vector<Eigen::Vector3d> x2s(x2.size());
  const size_t offset = x2.size() / 2 + 1;
  for (size_t i = 0; i < x2.size(); ++i) x2s[i] = x2[(i + offset) % x2.size()];
  const RelPoseEstimator shuffled(x1, x2s, th);
  ConcurrentSearch control([&](RansacTrace* trace) {
    RelModel m;
    Ransac(shuffled, opt.ransac, threshold_sq, &m, trace);
  });
  RelModel best_model;
  const RansacStats st = Ransac(est, opt.ransac, threshold_sq, &best_model);
  PoseRt best = best_model.pose;
  res.status.iterations = st.iterations;
  res.status.local_optimizations = st.local_optimizations;
  res.status.stop = st.stop;
  if (!st.found() || st.num_inliers < 5) return finish(EstimatorOutcome::kNoConsensus);
  std::vector<int> in;
  const auto collect = [&](const PoseRt& p) { CollectInliers(x1, x2, p, threshold_sq, &in); };
  collect(best);
  if (opt.final_refinement && in.size() >= 6) {
    // Two rounds: refine on the inliers, re-select them with the refined model, refine again.
    for (int round = 0; round < 2; ++round) {
      res.status.refinement_cost = RefineRelativePose(x1, x2, in, th, opt.refinement_iterations, &best);
      collect(best);
      if (in.size() < 6) break;
    }
  }
  if (opt.competitor_samples > 0 && in.size() >= static_cast<size_t>(opt.min_inliers))
    DecideCompetingModels(x1, x2, opt, depth, th, threshold_sq, focal, &best, &in, &res);
  // Keep the inliers in front of both cameras (cheirality on the refined pose).
  int n_in = 0;
  for (int i : in) {
    if (InFront(best, x1[i], x2[i])) {
      res.inliers[i] = 1;
      ++n_in;
    }
  }
  res.status.num_inliers = n_in;
  if (n_in < opt.min_inliers) {
    res.inliers.assign(px_ref.size(), 0);
    return finish(EstimatorOutcome::kNoConsensus);
  }
  res.status.chance_inliers = ChanceInliers(x1, x2, best, threshold_sq);
  // Support must beat chance clearly: RANSAC maximises over thousands of hypotheses, so a random set's best model
  // exceeds its shuffled support by several standard deviations; real geometry exceeds it many times over. A model
  // that does not is still an answer — a weak one: "weak-support", the pose returned, never "ok".
  // Below the weak bar it is no model at all: what chance gives (random matches select that much), no answer.
  const double chance = res.status.chance_inliers;
  bool weak = n_in < 2 * chance + 8 * std::sqrt(chance);
  bool trivial = n_in < chance + 4 * std::sqrt(chance) + 2;
  // Weak support (few inliers, low ratio): is it more than what RANSAC's search finds in unrelated pairs? The same
  // search on the matches with the query points shuffled (a fixed derangement) must find clearly fewer — random
  // matches select a 5-point model with a dozen chance inliers, which the fixed-model test above cannot see.
  if (!weak && n_in < std::max(3 * opt.min_inliers, static_cast<int>(0.25 * static_cast<double>(x1.size())))) {
    res.status.shuffled_best = control.BestInliersAfter(std::max(st.iterations, opt.ransac.min_iterations));
    weak = n_in < 1.5 * res.status.shuffled_best + 4;
    trivial = n_in < 1.2 * res.status.shuffled_best + 3;
  }
  if (weak && trivial) {
    res.inliers.assign(px_ref.size(), 0);
    return finish(EstimatorOutcome::kNoConsensus);
  }
  if (InliersDegenerate(px_ref, px_query, res.inliers)) {
    res.inliers.assign(px_ref.size(), 0);
    res.status.num_inliers = 0;
    return finish(EstimatorOutcome::kDegenerate);
  }
  res.query_from_ref = Rigid3d(best.R, best.t.normalized());
  return finish(weak ? EstimatorOutcome::kWeakSupport : EstimatorOutcome::kOk);
}

}  // namespace freeloc::geometry
