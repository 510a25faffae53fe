// Wald's sequential probability ratio test for RANSAC hypotheses: J. Matas and O. Chum, "Randomized RANSAC with
// sequential probability ratio test", ICCV 2005, and O. Chum and J. Matas, "Optimal randomized RANSAC", PAMI 2008.
//
// A hypothesis is checked datum by datum in a random order; each consistent datum multiplies the likelihood ratio by
// δ/ε, each inconsistent one by (1 − δ)/(1 − ε), where ε is the share of data a model worth scoring explains and δ
// the share a wrong model explains by chance. Once the ratio exceeds A the hypothesis is dropped: a model that
// explains chance only costs a few dozen evaluations instead of all n. A model holding ε is dropped with probability
// about 1/A, which the stopping rule pays for (SampleSuccessFactor). ε is the minimum inlier share the search looks
// for, fixed — not the best model's share as in the papers: the test only separates models from chance, and which
// model wins stays the MSAC score's choice (a model that fits fewer data more tightly can still win, as without the
// test). δ is estimated from the dropped hypotheses; A follows from both and from what a minimal solve costs, as
// Chum and Matas derive it.
#pragma once

#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include "freeloc/geometry/split_mix64.h"

namespace freeloc::geometry {

class SprtTest {
 public:
  // `n` data; `min_inlier_ratio` is ε; `solve_cost` what a minimal solve costs per model it gives, in datum
  // evaluations.
  SprtTest(size_t n, uint64_t seed, double min_inlier_ratio, double solve_cost);

  // The test on one hypothesis: `consistent(i)` says whether datum i fits it. Returns true when the hypothesis
  // survives every datum (then it is worth scoring); `evaluated`, when given, counts the data looked at. Each call
  // starts at a random place of one fixed random order of the data.
  template <class Consistent>
  bool Accept(Consistent&& consistent, size_t* evaluated = nullptr) {
    const size_t n = order_.size();
    const size_t start = rng_.Below(static_cast<uint32_t>(n));
    double log_lambda = 0;
    size_t in = 0;
    for (size_t j = 0; j < n; ++j) {
      size_t k = start + j;
      if (k >= n) k -= n;
      if (consistent(order_[k])) {
        ++in;
        log_lambda += log_in_;
      } else {
        log_lambda += log_out_;
        if (log_lambda > log_a_) {
          if (evaluated) *evaluated = j + 1;
          Rejected(in, j + 1);
          return false;
        }
      }
    }
    if (evaluated) *evaluated = n;
    return true;
  }

  // The factor on the probability that a sample is all inliers: a good model survives the test with 1 − 1/A.
  double SampleSuccessFactor() const { return 1.0 - std::exp(-log_a_); }
  double epsilon() const { return eps_; }
  double delta() const { return delta_; }
  double threshold() const { return std::exp(log_a_); }

 private:
  void Rejected(size_t in, size_t seen);
  void Update();  // A, and the two log steps, from ε and δ

  std::vector<uint32_t> order_;
  SplitMix64 rng_;
  double solve_cost_;
  double eps_, delta_;
  double seen_in_ = 0, seen_ = 0;  // consistent / evaluated data of the dropped hypotheses (δ's estimate)
  double log_in_ = 0, log_out_ = 0, log_a_ = 0;
};

}  // namespace freeloc::geometry
