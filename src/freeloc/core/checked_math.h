// Overflow-checked size arithmetic for sizes read from files (docs/architecture.md §2: "size arithmetic on anything
// read from a file is overflow-checked"). Each throws freeloc::Error naming `what` instead of wrapping around.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "freeloc/core/error.h"

namespace freeloc {

inline int64_t CheckedMul(int64_t a, int64_t b, const std::string& what) {
  int64_t r = 0;
  FREELOC_CHECK(a >= 0 && b >= 0 && !__builtin_mul_overflow(a, b, &r),
                what << ": size " << a << " x " << b << " overflows; the file is damaged");
  return r;
}

inline int64_t CheckedAdd(int64_t a, int64_t b, const std::string& what) {
  int64_t r = 0;
  FREELOC_CHECK(a >= 0 && b >= 0 && !__builtin_add_overflow(a, b, &r),
                what << ": size " << a << " + " << b << " overflows; the file is damaged");
  return r;
}

// The element count of `shape` (every dimension ≥ 0), checked.
inline int64_t CheckedNumel(const std::vector<int64_t>& shape, const std::string& what) {
  int64_t n = 1;
  for (int64_t d : shape) {
    FREELOC_CHECK(d >= 0, what << ": negative dimension " << d << "; the file is damaged");
    n = CheckedMul(n, d, what);
  }
  return n;
}

}  // namespace freeloc
