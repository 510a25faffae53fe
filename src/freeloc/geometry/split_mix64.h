// splitmix64 (S. Vigna's seeding generator for xoshiro): small, fast and seedable; RANSAC's sampling needs no more.
#pragma once

#include <cstdint>

namespace freeloc::geometry {

class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : s_(seed + 0x9E3779B97F4A7C15ull) {}
  uint64_t Next() {
    uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, n).
  uint32_t Below(uint32_t n) { return static_cast<uint32_t>((static_cast<unsigned __int128>(Next() >> 32) * n) >> 32); }

 private:
  uint64_t s_;
};

}  // namespace freeloc::geometry
