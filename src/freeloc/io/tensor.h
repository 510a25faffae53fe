// A read-only, contiguous, row-major tensor as stored in a checkpoint file: dtype, shape and bytes.
// Torch-free on purpose: nn/ turns these into torch tensors (zero-copy, `owner` keeps the bytes alive).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace freeloc::io {

enum class DType { kF64, kF32, kF16, kBF16, kI64, kI32, kI16, kI8, kU8, kBool };

size_t DTypeSize(DType d);
// Safetensors spelling: "F32", "BF16", "BOOL", …
const char* DTypeName(DType d);
// PyTorch spelling: "float32", "bfloat16", "bool", …
const char* DTypeTorchName(DType d);
bool DTypeFromName(const std::string& safetensors_name, DType* out);

float HalfToFloat(uint16_t h);
float BFloat16ToFloat(uint16_t b);

struct TensorView {
  DType dtype = DType::kF32;
  std::vector<int64_t> shape;
  const uint8_t* data = nullptr;  // contiguous row-major bytes, nbytes long
  size_t nbytes = 0;
  std::shared_ptr<const void> owner;  // keeps `data` alive (mapped file or storage buffer)

  int64_t numel() const;
  std::string ShapeString() const;  // "[3, 4]"
  // Element i converted to double (any dtype); for tests and metadata printing.
  double ElementAsDouble(int64_t i) const;
  std::vector<float> ToFloat() const;
  std::vector<double> ToDouble() const;
  template <typename T>
  const T* as() const {
    return reinterpret_cast<const T*>(data);
  }
};

// Owns its bytes (for building tensors to write).
TensorView MakeTensor(DType dtype, std::vector<int64_t> shape, const void* bytes, size_t nbytes);

}  // namespace freeloc::io
