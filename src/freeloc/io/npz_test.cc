#include "freeloc/io/npz.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "freeloc/core/error.h"
#include "freeloc/io/submission.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

// Builds a version-1 .npy: magic, header dict padded to a multiple of 64, data.
std::string Npy(const std::string& descr, const std::string& shape, bool fortran, const void* data, size_t nbytes) {
  std::string h =
      "{'descr': '" + descr + "', 'fortran_order': " + (fortran ? "True" : "False") + ", 'shape': " + shape + ", }";
  while ((10 + h.size() + 1) % 64 != 0) h += ' ';
  h += '\n';
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(h.size() & 0xff);
  out += static_cast<char>(h.size() >> 8);
  return out + h + std::string(static_cast<const char*>(data), nbytes);
}

TEST(Npz, ParsesCAndFortranOrder) {
  const float c[6] = {0, 1, 2, 3, 4, 5};  // 2×3 C order
  const std::string a = Npy("<f4", "(2, 3)", false, c, sizeof(c));
  NpyArray x = ParseNpy(reinterpret_cast<const uint8_t*>(a.data()), a.size(), "a.npy");
  EXPECT_EQ(x.shape, (std::vector<int64_t>{2, 3}));
  EXPECT_EQ(x.at({1, 2}), 5.0);
  const double f[6] = {0, 3, 1, 4, 2, 5};  // the same 2×3 matrix in Fortran order
  const std::string b = Npy("<f8", "(2, 3)", true, f, sizeof(f));
  NpyArray y = ParseNpy(reinterpret_cast<const uint8_t*>(b.data()), b.size(), "b.npy");
  EXPECT_EQ(y.data, x.data);
  const std::string s = Npy("<i8", "()", false, "\x07\0\0\0\0\0\0\0", 8);
  EXPECT_EQ(ParseNpy(reinterpret_cast<const uint8_t*>(s.data()), s.size(), "s.npy").data[0], 7.0);
}

TEST(Npz, RejectsBadArrays) {
  const float c[2] = {0, 1};
  const std::string big = Npy(">f4", "(2,)", false, c, sizeof(c));
  EXPECT_THROW(ParseNpy(reinterpret_cast<const uint8_t*>(big.data()), big.size(), "x"), Error);
  const std::string shortd = Npy("<f4", "(3,)", false, c, sizeof(c));
  EXPECT_THROW(ParseNpy(reinterpret_cast<const uint8_t*>(shortd.data()), shortd.size(), "x"), Error);
  const std::string obj = Npy("|O", "(2,)", false, c, sizeof(c));
  EXPECT_THROW(ParseNpy(reinterpret_cast<const uint8_t*>(obj.data()), obj.size(), "x"), Error);
  EXPECT_THROW(ParseNpy(reinterpret_cast<const uint8_t*>("hello world"), 11, "x"), Error);
}

TEST(Npz, ReadsZipOfNpy) {
  testing::TempDir tmp;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float corr[2 * 2 * 4] = {1, 2, 3, 4, nan, nan, nan, nan, 5, 6, 7, 8, 9, 10, 11, 12};
  WriteZipAtomic(tmp.File("c.npz"), {{"correspondences.npy", Npy("<f4", "(2, 2, 4)", false, corr, sizeof(corr))}});
  const auto arrays = ReadNpz(tmp.File("c.npz"));
  ASSERT_TRUE(arrays.count("correspondences"));
  EXPECT_TRUE(std::isnan(arrays.at("correspondences").at({0, 1, 2})));
  EXPECT_EQ(arrays.at("correspondences").at({1, 1, 3}), 12.0);
  testing::WriteText(tmp.File("bad.npz"), "not a zip");
  EXPECT_THROW(ReadNpz(tmp.File("bad.npz")), Error);
}

}  // namespace
}  // namespace freeloc::io
