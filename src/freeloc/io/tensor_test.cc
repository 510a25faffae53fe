#include "freeloc/io/tensor.h"

#include <gtest/gtest.h>

#include <cmath>

#include "freeloc/core/error.h"

namespace freeloc::io {
namespace {

TEST(Tensor, HalfAndBFloat16Conversion) {
  EXPECT_EQ(HalfToFloat(0x3C00), 1.0f);
  EXPECT_EQ(HalfToFloat(0xC000), -2.0f);
  EXPECT_EQ(HalfToFloat(0x3555), 0.333251953125f);
  EXPECT_EQ(HalfToFloat(0x0001), std::ldexp(1.0f, -24));  // smallest subnormal
  EXPECT_EQ(HalfToFloat(0x8000), -0.0f);
  EXPECT_TRUE(std::isinf(HalfToFloat(0x7C00)));
  EXPECT_TRUE(std::isnan(HalfToFloat(0x7E00)));
  EXPECT_EQ(BFloat16ToFloat(0x3F80), 1.0f);
  EXPECT_EQ(BFloat16ToFloat(0xC0A0), -5.0f);
}

TEST(Tensor, DTypeNamesRoundTrip) {
  for (DType d : {DType::kF64, DType::kF32, DType::kF16, DType::kBF16, DType::kI64, DType::kI32, DType::kI16,
                  DType::kI8, DType::kU8, DType::kBool}) {
    DType back;
    ASSERT_TRUE(DTypeFromName(DTypeName(d), &back));
    EXPECT_EQ(back, d);
  }
  DType x;
  EXPECT_FALSE(DTypeFromName("F8_E4M3", &x));
  EXPECT_STREQ(DTypeTorchName(DType::kBF16), "bfloat16");
}

TEST(Tensor, MakeTensorAndConvert) {
  const int32_t v[6] = {-3, 0, 1, 2, 3, 100};
  TensorView t = MakeTensor(DType::kI32, {2, 3}, v, sizeof(v));
  EXPECT_EQ(t.numel(), 6);
  EXPECT_EQ(t.ShapeString(), "[2, 3]");
  const auto f = t.ToFloat();
  EXPECT_EQ(f[0], -3.0f);
  EXPECT_EQ(f[5], 100.0f);
  EXPECT_THROW(MakeTensor(DType::kI32, {2, 2}, v, sizeof(v)), Error);
  EXPECT_THROW(t.ElementAsDouble(6), Error);
}

}  // namespace
}  // namespace freeloc::io
