#include "freeloc/io/safetensors.h"

#include <gtest/gtest.h>

#include <cstring>

#include "freeloc/core/error.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

using testing::TempDir;

std::string Raw(const std::string& header, const std::string& data) {
  std::string out(8, '\0');
  const uint64_t n = header.size();
  for (int i = 0; i < 8; ++i) out[i] = static_cast<char>(n >> (8 * i));
  return out + header + data;
}

void ExpectError(const std::string& bytes, const std::string& fragment) {
  TempDir tmp;
  const std::string path = tmp.File("bad.safetensors");
  testing::WriteBytes(path, bytes);
  try {
    SafetensorsFile::Open(path);
    FAIL() << "no error for " << fragment;
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(fragment), std::string::npos) << m;
    EXPECT_NE(m.find("bad.safetensors"), std::string::npos) << m;
  }
}

TEST(Safetensors, RoundTripAllDTypes) {
  TempDir tmp;
  const float f32[3] = {1.5f, -2.f, 3.25f};
  const uint16_t f16[2] = {0x3C00, 0xC000};
  const uint16_t bf16[2] = {0x3F80, 0xC0A0};
  const int64_t i64[2] = {-(1ll << 40), 7};
  const int32_t i32[1] = {-9};
  const uint8_t u8[4] = {0, 1, 254, 255};
  const uint8_t b[2] = {1, 0};
  std::vector<std::pair<std::string, TensorView>> ts = {
      {"f32", MakeTensor(DType::kF32, {3}, f32, sizeof(f32))},
      {"f16", MakeTensor(DType::kF16, {2, 1}, f16, sizeof(f16))},
      {"bf16", MakeTensor(DType::kBF16, {1, 2}, bf16, sizeof(bf16))},
      {"i64", MakeTensor(DType::kI64, {2}, i64, sizeof(i64))},
      {"i32", MakeTensor(DType::kI32, {}, i32, sizeof(i32))},
      {"u8", MakeTensor(DType::kU8, {2, 2}, u8, sizeof(u8))},
      {"bool", MakeTensor(DType::kBool, {2}, b, sizeof(b))},
      {"empty", MakeTensor(DType::kF32, {0, 4}, nullptr, 0)},
  };
  WriteSafetensors(tmp.File("t.safetensors"), ts, {{"format", "pt"}, {"note", "héllo"}});
  const SafetensorsFile f = SafetensorsFile::Open(tmp.File("t.safetensors"));
  ASSERT_EQ(f.names.size(), ts.size());
  for (size_t i = 0; i < ts.size(); ++i) {
    EXPECT_EQ(f.names[i], ts[i].first);  // header order preserved
    const TensorView& t = f.Get(ts[i].first);
    EXPECT_EQ(t.dtype, ts[i].second.dtype);
    EXPECT_EQ(t.shape, ts[i].second.shape);
    ASSERT_EQ(t.nbytes, ts[i].second.nbytes);
    if (t.nbytes > 0) {  // no memcmp on a null pointer (UBSan)
      EXPECT_EQ(std::memcmp(t.data, ts[i].second.data, t.nbytes), 0);
    }
  }
  EXPECT_EQ(f.metadata.at("note"), "héllo");
  EXPECT_EQ(f.Get("bf16").ToFloat()[1], -5.0f);
  EXPECT_THROW(f.Get("nope"), Error);
}

// A model file as a network's loader meets it: freeloc's own tiny SegGPT (written by the build).
TEST(Safetensors, ReadsAModelFile) {
  const SafetensorsFile f = SafetensorsFile::Open(testing::TinyModelPath("seggpt/model.safetensors"));
  EXPECT_EQ(f.names.size(), 354u);
  const TensorView& t = f.Get("patch_embed.proj.weight");
  EXPECT_EQ(t.dtype, DType::kF32);
  EXPECT_EQ(t.shape, (std::vector<int64_t>{64, 3, 16, 16}));
  EXPECT_EQ(t.nbytes, 64u * 3 * 16 * 16 * 4);
}

TEST(Safetensors, RejectsShortFile) { ExpectError("abc", "too short"); }

TEST(Safetensors, RejectsHeaderLengthBeyondFile) {
  std::string b = Raw("{}", "");
  b[0] = static_cast<char>(200);  // claims 200 header bytes, has 2
  ExpectError(b, "runs past the end of the file");
}

TEST(Safetensors, RejectsBadJson) { ExpectError(Raw("{\"a\": [1, 2", ""), "not valid JSON"); }

TEST(Safetensors, RejectsNonObjectHeader) { ExpectError(Raw("[1,2,3]", ""), "not a JSON object"); }

TEST(Safetensors, RejectsOffsetsOutOfRange) {
  ExpectError(Raw(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,8]}})", std::string(4, '\0')),
              "run past the end of the data");
}

TEST(Safetensors, RejectsOverlap) {
  ExpectError(Raw(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,8]},)"
                  R"("b":{"dtype":"F32","shape":[2],"data_offsets":[4,12]}})",
                  std::string(12, '\0')),
              "overlaps");
}

TEST(Safetensors, RejectsSizeShapeMismatch) {
  ExpectError(Raw(R"({"a":{"dtype":"F32","shape":[3],"data_offsets":[0,8]}})", std::string(8, '\0')), "needs 12");
}

TEST(Safetensors, RejectsHolesAndTrailingBytes) {
  ExpectError(Raw(R"({"a":{"dtype":"U8","shape":[2],"data_offsets":[2,4]}})", std::string(4, '\0')), "gap of 2");
  ExpectError(Raw(R"({"a":{"dtype":"U8","shape":[2],"data_offsets":[0,2]}})", std::string(5, '\0')),
              "3 bytes after the last tensor");
}

TEST(Safetensors, RejectsUnknownDTypeAndBadFields) {
  ExpectError(Raw(R"({"a":{"dtype":"Q4","shape":[1],"data_offsets":[0,1]}})", std::string(1, '\0')),
              "dtype 'Q4' is not supported");
  ExpectError(Raw(R"({"a":{"dtype":"U8","shape":[-1],"data_offsets":[0,1]}})", std::string(1, '\0')), "non-negative");
  ExpectError(Raw(R"({"a":{"dtype":"U8","shape":[1]}})", std::string(1, '\0')), "data_offsets");
  ExpectError(Raw(R"({"a":{"dtype":"U8","shape":[1],"data_offsets":[1,0]}})", std::string(1, '\0')), "reversed");
  ExpectError(Raw(R"({"__metadata__":{"k":1}})", ""), "not a string");
}

TEST(Safetensors, RejectsAbsurdShape) {
  ExpectError(
      Raw(R"({"a":{"dtype":"F32","shape":[4294967296,4294967296,16],"data_offsets":[0,4]}})", std::string(4, '\0')),
      "absurdly large");
}

}  // namespace
}  // namespace freeloc::io
