// Fixture comparisons for the network ports: how much of an allclose budget a float32 tensor uses.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <string>

#include "freeloc/io/safetensors.h"
#include "freeloc/io/tensor.h"

namespace freeloc::testing {

// max over elements of |a − b| / (atol + rtol·|b|): ≤ 1 passes (numpy.allclose semantics, b the golden).
inline double BudgetUse(const io::TensorView& a, const io::TensorView& b, double atol = 1e-4, double rtol = 1e-3) {
  EXPECT_EQ(a.numel(), b.numel());
  if (a.numel() != b.numel()) return 1e9;
  double worst = 0;
  for (int64_t i = 0; i < a.numel(); ++i) {
    const double x = a.as<float>()[i], y = b.as<float>()[i];
    worst = std::max(worst, std::abs(x - y) / (atol + rtol * std::abs(y)));
  }
  return worst;
}

// True when both tensors hold the same bytes (a failure names the sizes when they differ).
inline bool SameBytes(const io::TensorView& a, const io::TensorView& b) {
  EXPECT_EQ(a.nbytes, b.nbytes);
  return a.nbytes == b.nbytes && std::memcmp(a.data, b.data, a.nbytes) == 0;
}

struct TapComparison {
  int compared = 0;
  double worst = 0;  // the largest budget use over the compared taps
};

// Each tensor of the fixture `f` that `wanted` selects against the model's tap of the same name: a missing tap and a
// tap over its budget are test failures.
inline TapComparison CompareTaps(const std::map<std::string, io::TensorView>& taps, const io::SafetensorsFile& f,
                                 const std::function<bool(const std::string&)>& wanted, double atol = 1e-4,
                                 double rtol = 1e-3) {
  TapComparison r;
  for (const auto& n : f.names) {
    if (!wanted(n)) continue;
    const auto it = taps.find(n);
    if (it == taps.end()) {
      ADD_FAILURE() << "no tap for " << n;
      continue;
    }
    const double b = BudgetUse(it->second, f.Get(n), atol, rtol);
    r.worst = std::max(r.worst, b);
    EXPECT_LE(b, 1.0) << n;
    ++r.compared;
  }
  return r;
}

}  // namespace freeloc::testing
