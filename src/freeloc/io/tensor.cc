#include "freeloc/io/tensor.h"

#include <cstring>
#include <sstream>

#include "freeloc/core/error.h"

namespace freeloc::io {

size_t DTypeSize(DType d) {
  switch (d) {
    case DType::kF64:
    case DType::kI64: return 8;
    case DType::kF32:
    case DType::kI32: return 4;
    case DType::kF16:
    case DType::kBF16:
    case DType::kI16: return 2;
    case DType::kI8:
    case DType::kU8:
    case DType::kBool: return 1;
  }
  return 0;
}

namespace {
struct DTypeNames {
  DType d;
  const char* st;
  const char* torch;
};
constexpr DTypeNames kNames[] = {
    {DType::kF64, "F64", "float64"},    {DType::kF32, "F32", "float32"}, {DType::kF16, "F16", "float16"},
    {DType::kBF16, "BF16", "bfloat16"}, {DType::kI64, "I64", "int64"},   {DType::kI32, "I32", "int32"},
    {DType::kI16, "I16", "int16"},      {DType::kI8, "I8", "int8"},      {DType::kU8, "U8", "uint8"},
    {DType::kBool, "BOOL", "bool"},
};
}  // namespace

const char* DTypeName(DType d) {
  for (const auto& n : kNames)
    if (n.d == d) return n.st;
  return "?";
}
const char* DTypeTorchName(DType d) {
  for (const auto& n : kNames)
    if (n.d == d) return n.torch;
  return "?";
}
bool DTypeFromName(const std::string& name, DType* out) {
  for (const auto& n : kNames) {
    if (name == n.st) {
      *out = n.d;
      return true;
    }
  }
  return false;
}

float HalfToFloat(uint16_t h) {
  const uint32_t sign = static_cast<uint32_t>(h & 0x8000) << 16;
  uint32_t exp = (h >> 10) & 0x1f;
  uint32_t mant = h & 0x3ff;
  uint32_t bits;
  if (exp == 0) {
    if (mant == 0) {
      bits = sign;
    } else {  // subnormal: normalise
      exp = 127 - 15 + 1;
      while ((mant & 0x400) == 0) {
        mant <<= 1;
        --exp;
      }
      mant &= 0x3ff;
      bits = sign | (exp << 23) | (mant << 13);
    }
  } else if (exp == 31) {
    bits = sign | 0x7f800000u | (mant << 13);
  } else {
    bits = sign | ((exp + 127 - 15) << 23) | (mant << 13);
  }
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

float BFloat16ToFloat(uint16_t b) {
  const uint32_t bits = static_cast<uint32_t>(b) << 16;
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

int64_t TensorView::numel() const {
  int64_t n = 1;
  for (int64_t s : shape) n *= s;
  return n;
}

std::string TensorView::ShapeString() const {
  std::ostringstream os;
  os << "[";
  for (size_t i = 0; i < shape.size(); ++i) os << (i ? ", " : "") << shape[i];
  os << "]";
  return os.str();
}

double TensorView::ElementAsDouble(int64_t i) const {
  FREELOC_CHECK(i >= 0 && i < numel(), "tensor element " << i << " out of range " << ShapeString());
  const uint8_t* p = data + static_cast<size_t>(i) * DTypeSize(dtype);
  switch (dtype) {
    case DType::kF64: {
      double v;
      std::memcpy(&v, p, 8);
      return v;
    }
    case DType::kF32: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case DType::kF16: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return HalfToFloat(v);
    }
    case DType::kBF16: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return BFloat16ToFloat(v);
    }
    case DType::kI64: {
      int64_t v;
      std::memcpy(&v, p, 8);
      return static_cast<double>(v);
    }
    case DType::kI32: {
      int32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case DType::kI16: {
      int16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case DType::kI8: return static_cast<int8_t>(*p);
    case DType::kU8: return *p;
    case DType::kBool: return *p ? 1.0 : 0.0;
  }
  return 0;
}

std::vector<float> TensorView::ToFloat() const {
  std::vector<float> out(static_cast<size_t>(numel()));
  if (dtype == DType::kF32) {
    std::memcpy(out.data(), data, out.size() * 4);
  } else {
    for (size_t i = 0; i < out.size(); ++i) out[i] = static_cast<float>(ElementAsDouble(static_cast<int64_t>(i)));
  }
  return out;
}

std::vector<double> TensorView::ToDouble() const {
  std::vector<double> out(static_cast<size_t>(numel()));
  for (size_t i = 0; i < out.size(); ++i) out[i] = ElementAsDouble(static_cast<int64_t>(i));
  return out;
}

TensorView MakeTensor(DType dtype, std::vector<int64_t> shape, const void* bytes, size_t nbytes) {
  TensorView t;
  t.dtype = dtype;
  t.shape = std::move(shape);
  FREELOC_CHECK(
      static_cast<size_t>(t.numel()) * DTypeSize(dtype) == nbytes,
      "MakeTensor: " << nbytes << " bytes do not fit shape " << t.ShapeString() << " of " << DTypeName(dtype));
  auto buf = std::make_shared<std::vector<uint8_t>>(static_cast<const uint8_t*>(bytes),
                                                    static_cast<const uint8_t*>(bytes) + nbytes);
  t.data = buf->data();
  t.nbytes = nbytes;
  t.owner = buf;
  return t;
}

}  // namespace freeloc::io
