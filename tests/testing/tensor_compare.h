// Fixture comparisons for the network ports: how much of an allclose budget a float32 tensor uses.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "freeloc/io/tensor.h"

namespace freeloc::testing {

// max over elements of |a − b| / (atol + rtol·|b|): ≤ 1 passes (numpy.allclose semantics, b the golden).
inline double BudgetUse(const TensorView& a, const TensorView& b, double atol = 1e-4, double rtol = 1e-3) {
  EXPECT_EQ(a.numel(), b.numel());
  if (a.numel() != b.numel()) return 1e9;
  double worst = 0;
  for (int64_t i = 0; i < a.numel(); ++i) {
    const double x = a.as<float>()[i], y = b.as<float>()[i];
    worst = std::max(worst, std::abs(x - y) / (atol + rtol * std::abs(y)));
  }
  return worst;
}

}  // namespace freeloc::testing
