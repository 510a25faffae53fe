// Checkpoints whose tensor metadata lies (a well-formed zip and pickle around it): the storage's declared element
// count, the record's real length, a view's offset, size and stride. Each case is refused with a clear error before
// any pointer is formed, or — when valid — read back value for value.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "freeloc/core/error.h"
#include "freeloc/io/checkpoint.h"
#include "freeloc/io/pth.h"
#include "testing/pth_builder.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

using testing::ErrorOf;
using testing::PthSpec;

std::string Refusal(const PthSpec& spec) {
  testing::TempDir tmp;
  testing::WritePthSpec(tmp.File("x.pth"), spec);
  return ErrorOf([&] {
    const Checkpoint c = Checkpoint::Open(tmp.File("x.pth"));
    for (const auto& n : c.names()) c.Get(n);
  });
}

bool Mentions(const std::string& error, const char* what) { return error.find(what) != std::string::npos; }

TEST(HostileMetadata, ValidViewsOfOneStorageReadBackExactly) {
  testing::TempDir tmp;
  PthSpec spec;
  spec.storages = {{"0", "FloatStorage", 12, 48}};
  spec.tensors = {{"a", "0", 0, {3, 4}, {4, 1}}, {"b", "0", 4, {4}, {1}}, {"t", "0", 0, {4, 3}, {1, 4}}};
  testing::WritePthSpec(tmp.File("ok.pth"), spec);
  const Checkpoint c = Checkpoint::Open(tmp.File("ok.pth"));
  ASSERT_EQ(c.size(), 3u);
  float all[12];
  std::memcpy(all, c.Get("a").data, sizeof(all));
  float b[4];
  std::memcpy(b, c.Get("b").data, sizeof(b));
  for (int i = 0; i < 4; ++i) EXPECT_EQ(std::memcmp(&b[i], &all[4 + i], 4), 0) << i;
  float t[12];  // the transposed view, copied out
  std::memcpy(t, c.Get("t").data, sizeof(t));
  for (int r = 0; r < 4; ++r)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(std::memcmp(&t[r * 3 + k], &all[k * 4 + r], 4), 0) << r << "," << k;
}

// The count × item size wraps 64 bits: 2^62 floats "need" 0 bytes, which a 16-byte record once satisfied; a view far
// into that storage then read outside the record (SIGSEGV in inspect and pointmap).
TEST(HostileMetadata, DeclaredCountWhoseByteSizeWrapsIsRefused) {
  PthSpec spec;
  spec.storages = {{"0", "FloatStorage", int64_t{1} << 62, 16}};
  spec.tensors = {{"w", "0", int64_t{1} << 40, {4}, {1}}};
  const std::string e = Refusal(spec);
  EXPECT_TRUE(Mentions(e, "overflow") || Mentions(e, "need")) << e;
  spec.storages[0].cls = "DoubleStorage";
  spec.storages[0].declared_numel = int64_t{1} << 61;  // × 8 = 2^64
  EXPECT_FALSE(Refusal(spec).empty());
  spec.storages[0].cls = "LongStorage";
  spec.storages[0].declared_numel = std::numeric_limits<int64_t>::max();
  EXPECT_FALSE(Refusal(spec).empty());
}

TEST(HostileMetadata, NegativeCountsOffsetsSizesAndStridesAreRefused) {
  PthSpec spec;
  spec.storages = {{"0", "FloatStorage", -1, 16}};
  spec.tensors = {{"w", "0", 0, {0}, {1}}};
  EXPECT_TRUE(Mentions(Refusal(spec), "declares -1 elements")) << Refusal(spec);
  spec.storages = {{"0", "FloatStorage", 4, 16}};
  spec.tensors = {{"w", "0", -1, {1}, {1}}};
  EXPECT_TRUE(Mentions(Refusal(spec), "outside its storage")) << Refusal(spec);
  spec.tensors = {{"w", "0", 0, {-2}, {1}}};
  EXPECT_FALSE(Refusal(spec).empty());
  spec.tensors = {{"w", "0", 0, {2}, {-1}}};
  EXPECT_FALSE(Refusal(spec).empty());
}

// An empty view (size 0) still may not name an offset beyond its storage: no pointer is formed outside the record.
TEST(HostileMetadata, OffsetBeyondTheStorageIsRefusedEvenForAnEmptyView) {
  PthSpec spec;
  spec.storages = {{"0", "FloatStorage", 4, 16}};
  spec.tensors = {{"w", "0", int64_t{1} << 50, {0}, {1}}};
  EXPECT_TRUE(Mentions(Refusal(spec), "outside its storage")) << Refusal(spec);
  spec.tensors = {{"w", "0", 4, {0}, {1}}};  // one past the end, empty: valid (torch writes these)
  EXPECT_TRUE(Refusal(spec).empty()) << Refusal(spec);
}

TEST(HostileMetadata, ViewsReachingPastTheStorageAreRefused) {
  PthSpec spec;
  spec.storages = {{"0", "FloatStorage", 4, 16}};
  spec.tensors = {{"w", "0", 1, {4}, {1}}};
  EXPECT_TRUE(Mentions(Refusal(spec), "reaches past its storage")) << Refusal(spec);
  spec.tensors = {{"w", "0", 0, {2, 2}, {3, 1}}};
  EXPECT_TRUE(Mentions(Refusal(spec), "reaches past its storage")) << Refusal(spec);
  spec.tensors = {{"w", "0", 0, {int64_t{1} << 62, 2}, {int64_t{1} << 62, 1}}};
  EXPECT_FALSE(Refusal(spec).empty());
}

TEST(HostileMetadata, RecordShorterThanTheDeclaredCountIsRefused) {
  PthSpec spec;
  spec.storages = {{"0", "FloatStorage", 100, 16}};
  spec.tensors = {{"w", "0", 0, {4}, {1}}};
  EXPECT_TRUE(Mentions(Refusal(spec), "holds 16 bytes")) << Refusal(spec);
}

// The same storage declared twice with different sizes: the second view must not be checked against the first's
// count while pretending another.
TEST(HostileMetadata, OneStorageDeclaredWithTwoSizesIsRefused) {
  testing::TempDir tmp;
  PthSpec spec;
  spec.storages = {{"0", "FloatStorage", 4, 16}};
  spec.tensors = {{"a", "0", 0, {4}, {1}}, {"b", "0", 0, {4}, {1}}};
  std::string pkl = testing::PthPickle(spec);
  // Rewrite the second storage declaration's count (… 'cpu', LONG1 4 → LONG1 8).
  const std::string decl = "cpu" + std::string("\x8a\x08\x04", 3) + std::string(7, '\0');
  const size_t second = pkl.find(decl, pkl.find(decl) + 1);
  ASSERT_NE(second, std::string::npos);
  pkl[second + 5] = 8;
  auto members = testing::PthMembers(spec);
  members["archive/data.pkl"] = pkl;
  WriteZipAtomic(tmp.File("twice.pth"), members);
  const std::string e = ErrorOf([&] { Checkpoint::Open(tmp.File("twice.pth")); });
  EXPECT_TRUE(Mentions(e, "declared twice")) << e;
}

}  // namespace
}  // namespace freeloc::io
