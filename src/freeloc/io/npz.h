// NumPy .npy / .npz reader (npz = zip of .npy, stored or deflated): float32/float64/float16, int8–64, uint8, bool;
// C or Fortran order (returned in C order); format versions 1–3.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace freeloc::io {

struct NpyArray {
  std::string descr;  // e.g. "<f4"
  std::vector<int64_t> shape;
  bool fortran_order = false;  // as stored; `data` is always C order
  std::vector<double> data;    // values converted to double, C (row-major) order

  int64_t numel() const;
  double at(std::initializer_list<int64_t> index) const;
};

NpyArray ParseNpy(const uint8_t* bytes, size_t size, const std::string& what);
// Reads every array of an .npz, keyed by name without the ".npy" suffix.
std::map<std::string, NpyArray> ReadNpz(const std::string& path);

}  // namespace freeloc::io
