// LO-RANSAC (Chum, Matas, Kittler, "Locally optimized RANSAC", DAGM 2003) with the MSAC truncated-quadratic score
// (Torr & Zisserman, CVIU 2000), a local non-linear refit whenever a hypothesis beats the best, and the stopping
// rule from the exact (hypergeometric) probability that a sample is all inliers. On dense sets each hypothesis first
// faces a sequential probability ratio test (sprt.h), and the search gives up once a model holding the minimum
// inlier share would have been found (RansacOptions). One template for every estimator:
//
//   struct Estimator {
//     using Model = …;
//     static constexpr int kSampleSize = …;
//     size_t num_data() const;
//     void MinimalSolve(const int* sample, std::vector<Model>* models) const;
//     double SquaredError(const Model&, size_t i) const;
//     // Refit `model` on the points whose squared error is below `threshold_sq` (robust, a few iterations).
//     void LocalOptimize(Model* model, double threshold_sq) const;
//     // Optional: what one minimal solve costs per model it returns, in SquaredError calls (the test's A).
//     static constexpr double kSolveCost = …;
//   };
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "freeloc/core/enum_table.h"
#include "freeloc/geometry/split_mix64.h"
#include "freeloc/geometry/sprt.h"

namespace freeloc::geometry {

// The search settings every robust estimator of geometry/ shares (relative, hybrid, PnP, Procrustes): each
// estimator's options hold one, with its own defaults, and validate it once through Validate(). The inlier
// threshold is the estimator's own (pixels, metres), handed to Ransac() in its error unit.
struct RansacOptions {
  RansacOptions() = default;
  RansacOptions(double success_prob, int min_iterations, int max_iterations, double max_seconds)
      : success_prob(success_prob),
        min_iterations(min_iterations),
        max_iterations(max_iterations),
        max_seconds(max_seconds) {}
  double success_prob = 0.9999;  // probability of drawing at least one all-inlier sample
  int min_iterations = 50;
  int max_iterations = 100000;
  uint64_t seed = 0;
  bool local_optimization = true;
  double max_seconds = 0;  // wall-clock budget (0: none); hit → RansacStop::kTimeBudget
  // Dense sets (at least `sprt_min_data` data; 0: never): each hypothesis is checked datum by datum in a random
  // order and dropped once it is clearly no better than chance (sprt.h), and while no hypothesis has passed, the
  // search gives up (RansacStop::kGaveUp) after the samples that would have found a model holding
  // `min_inlier_ratio` of the data with probability `give_up_prob`. A set with no consensus then costs a few
  // thousand samples checked on a few dozen data each, not the whole budget; once a model passes, the usual stopping
  // rule runs. A fifth at 99 % is about 14 000 five-point samples, more than a 10-second budget drew on a set of
  // 40 000 matches before; a sparse set (SIFT's few hundred matches) keeps the plain search and its full budget.
  int sprt_min_data = 2000;
  double min_inlier_ratio = 0.2;
  double give_up_prob = 0.99;
  // Throws freeloc::Error "<estimator>: …" naming the field that is out of range.
  void Validate(const char* estimator) const;
};

// Why the search stopped (EnumTable<RansacStop> below).
// kGaveUp (dense sets): no hypothesis passed the sequential test in the samples that would have found a model holding
// min_inlier_ratio of the data (with give_up_prob) — no model, like kNoModel.
enum class RansacStop { kConfidence, kMaxIterations, kTimeBudget, kTooFewData, kNoModel, kGaveUp };

struct RansacStats {
  int iterations = 0;
  int num_inliers = 0;
  int local_optimizations = 0;
  double score = std::numeric_limits<double>::infinity();  // MSAC score of the best model (lower is better)
  RansacStop stop = RansacStop::kNoModel;
  bool found() const {
    return stop != RansacStop::kNoModel && stop != RansacStop::kGaveUp && stop != RansacStop::kTooFewData;
  }
};

// Iterations needed so that an all-inlier sample is drawn with probability `p`, given `inliers` of `n` points and
// samples of size k drawn without replacement; `survives`: the chance that such a sample's model also passes the
// sequential test (1 without one).
inline double RequiredIterations(size_t inliers, size_t n, int k, double p, double survives = 1.0) {
  if (inliers < static_cast<size_t>(k) || n < static_cast<size_t>(k)) return std::numeric_limits<double>::infinity();
  double all_inlier = survives;
  for (int i = 0; i < k; ++i) all_inlier *= static_cast<double>(inliers - i) / static_cast<double>(n - i);
  if (all_inlier >= 1.0) return 0.0;
  if (all_inlier <= 0.0) return std::numeric_limits<double>::infinity();
  return std::log(1.0 - p) / std::log1p(-all_inlier);
}

// MSAC score: Σ min(e², t²); stops early once it exceeds `bail_out`. Also counts inliers (e² < t²).
template <class Estimator>
double MsacScore(const Estimator& est, const typename Estimator::Model& m, double threshold_sq, double bail_out,
                 int* num_inliers) {
  double score = 0;
  int n_in = 0;
  const size_t n = est.num_data();
  for (size_t i = 0; i < n; ++i) {
    const double e = est.SquaredError(m, i);
    if (e < threshold_sq) {
      score += e;
      ++n_in;
    } else {
      score += threshold_sq;
    }
    if (score > bail_out) {
      *num_inliers = n_in;
      return std::numeric_limits<double>::infinity();
    }
  }
  *num_inliers = n_in;
  return score;
}

// An estimator's kSolveCost, 200 when it declares none.
template <class E, class = void>
struct SolveCostOf {
  static constexpr double value = 200;
};
template <class E>
struct SolveCostOf<E, std::void_t<decltype(E::kSolveCost)>> {
  static constexpr double value = E::kSolveCost;
};

// The data count a model must hold not to give up on: ⌈min_inlier_ratio · n⌉.
inline size_t GiveUpInliers(const RansacOptions& opt, size_t n) {
  return static_cast<size_t>(std::ceil(opt.min_inlier_ratio * static_cast<double>(n)));
}
inline bool UsesSprt(const RansacOptions& opt, size_t n) {
  return opt.sprt_min_data > 0 && n >= static_cast<size_t>(opt.sprt_min_data);
}
// The give-up bound: samples of size k from n data that find a model holding GiveUpInliers with give_up_prob, when
// such a sample's model passes the test with `survives`.
inline double GiveUpIterations(const RansacOptions& opt, size_t n, int k, double survives) {
  return RequiredIterations(GiveUpInliers(opt, n), n, k, opt.give_up_prob, survives);
}

// The course of a search that runs beside another (ConcurrentSearch below): each improvement of the best model, and
// an iteration limit another thread may lower while it runs. A search's course depends only on its own samples, so
// the same search with max_iterations = k would have ended exactly as the trace says at k.
struct RansacTrace {
  std::atomic<int> limit{std::numeric_limits<int>::max()};
  std::vector<std::pair<int, int>> improvements;  // (iteration, inliers of the best model after it)
  int iterations = 0;                             // how many it ran
};

// `threshold_sq`: the squared inlier threshold in the estimator's error unit. `trace` (optional): see RansacTrace.
template <class Estimator>
RansacStats Ransac(const Estimator& est, const RansacOptions& opt, double threshold_sq,
                   typename Estimator::Model* best_model, RansacTrace* trace = nullptr) {
  using Model = typename Estimator::Model;
  constexpr int k = Estimator::kSampleSize;
  RansacStats st;
  const size_t n = est.num_data();
  if (n < static_cast<size_t>(k)) {
    st.stop = RansacStop::kTooFewData;
    return st;
  }
  SplitMix64 rng(opt.seed);
  std::vector<Model> models;
  int sample[k];
  std::optional<SprtTest> sprt;
  if (UsesSprt(opt, n)) sprt.emplace(n, opt.seed, opt.min_inlier_ratio, SolveCostOf<Estimator>::value);
  // The chance that an all-inlier sample's model also passes the test.
  const auto required = [&](size_t inliers) {
    return RequiredIterations(inliers, n, k, opt.success_prob, sprt ? sprt->SampleSuccessFactor() : 1.0);
  };
  // Before any model: the budget, or with the test what would have found a model holding the minimum share.
  double needed = static_cast<double>(opt.max_iterations);
  if (sprt) needed = std::min(needed, GiveUpIterations(opt, n, k, sprt->SampleSuccessFactor()));
  bool have = false;
  bool out_of_time = false;
  int iter = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (; iter < opt.max_iterations; ++iter) {
    if (iter >= opt.min_iterations && iter >= needed) break;
    if (trace && iter >= trace->limit.load(std::memory_order_relaxed)) break;
    if (opt.max_seconds > 0 && iter % 16 == 15 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > opt.max_seconds) {
      out_of_time = true;
      break;
    }
    // Sample k distinct indices.
    for (int i = 0; i < k; ++i) {
      bool dup;
      do {
        sample[i] = static_cast<int>(rng.Below(static_cast<uint32_t>(n)));
        dup = false;
        for (int j = 0; j < i; ++j) dup |= sample[j] == sample[i];
      } while (dup);
    }
    models.clear();
    est.MinimalSolve(sample, &models);
    for (Model& m : models) {
      if (sprt && !sprt->Accept([&](size_t i) { return est.SquaredError(m, i) < threshold_sq; })) continue;
      int n_in = 0;
      const double score = MsacScore(est, m, threshold_sq, st.score, &n_in);
      if (!(score < st.score)) continue;
      st.score = score;
      st.num_inliers = n_in;
      *best_model = m;
      have = true;
      if (opt.local_optimization) {
        Model lo = m;
        est.LocalOptimize(&lo, threshold_sq);
        ++st.local_optimizations;
        int lo_in = 0;
        const double lo_score = MsacScore(est, lo, threshold_sq, st.score, &lo_in);
        if (lo_score < st.score) {
          st.score = lo_score;
          st.num_inliers = lo_in;
          *best_model = lo;
        }
      }
      needed = std::min(static_cast<double>(opt.max_iterations), required(static_cast<size_t>(st.num_inliers)));
      if (trace) trace->improvements.emplace_back(iter, st.num_inliers);
    }
  }
  st.iterations = iter;
  if (trace) trace->iterations = iter;
  if (!have) {
    st.stop = sprt && !out_of_time && iter < opt.max_iterations ? RansacStop::kGaveUp : RansacStop::kNoModel;
  } else {
    st.stop = out_of_time                                                  ? RansacStop::kTimeBudget
              : iter >= opt.max_iterations && needed >= opt.max_iterations ? RansacStop::kMaxIterations
                                                                           : RansacStop::kConfidence;
  }
  return st;
}

// A search started now on another thread (when the machine has more than one), whose result is wanted only later
// and only for a number of iterations known later: the weak-support control (the same search on shuffled matches,
// as many iterations as the main search took) runs while the main search does. BestInliersAfter(k) is exactly what
// the same search with max_iterations = k finds: the trace is cut at k. Without a second core the search runs
// inside BestInliersAfter, limited to k. The destructor stops and joins it.
class ConcurrentSearch {
 public:
  explicit ConcurrentSearch(std::function<void(RansacTrace*)> search);
  ~ConcurrentSearch();
  ConcurrentSearch(const ConcurrentSearch&) = delete;
  ConcurrentSearch& operator=(const ConcurrentSearch&) = delete;
  // The inliers of the best model the search holds after k iterations; 0 if it has none.
  int BestInliersAfter(int k);

 private:
  std::function<void(RansacTrace*)> search_;
  RansacTrace trace_;
  std::thread thread_;
  std::exception_ptr error_;
};

}  // namespace freeloc::geometry

namespace freeloc {
template <>
struct EnumTable<geometry::RansacStop> {
  static constexpr const char* kField = "ransac stop";
  static constexpr EnumEntry<geometry::RansacStop> kEntries[] = {
      {geometry::RansacStop::kConfidence, "confidence"},  {geometry::RansacStop::kMaxIterations, "max-iterations"},
      {geometry::RansacStop::kTimeBudget, "time-budget"}, {geometry::RansacStop::kTooFewData, "too-few-data"},
      {geometry::RansacStop::kNoModel, "no-model"},       {geometry::RansacStop::kGaveUp, "gave-up"}};
};
}  // namespace freeloc
