// Regression tests for hostile and odd inputs (first classes): each is the minimal input of a crash, hang,
// bomb or wrongly refused file, and must now give a clear freeloc::Error (or be accepted, when valid).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstring>
#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/io/checkpoint.h"
#include "freeloc/io/correspondence_file.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/io/npz.h"
#include "freeloc/io/pth.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/io/submission.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

using testing::ErrorOf;

std::string Le(uint64_t v, int n) {
  std::string s;
  for (int i = 0; i < n; ++i) s += static_cast<char>((v >> (8 * i)) & 0xff);
  return s;
}

// A zip-format torch.save checkpoint holding one FloatStorage of `storage_numel` elements and one tensor view
// (offset 0, `shape`, `stride`), written with the pickle opcodes torch uses.
void WritePth(const std::string& path, int storage_numel, const std::vector<uint64_t>& shape,
              const std::vector<uint64_t>& stride) {
  auto str = [](const std::string& s) { return "X" + Le(s.size(), 4) + s; };
  auto ints = [](const std::vector<uint64_t>& v) {
    std::string t = "(";
    for (uint64_t x : v) t += "\x8a\x08" + Le(x, 8);  // LONG1, 8 bytes
    return t + "t";
  };
  const std::string pkl = std::string("\x80\x02") + "ctorch._utils\n_rebuild_tensor_v2\n" + "((" + str("storage") +
                          "ctorch\nFloatStorage\n" + str("0") + str("cpu") + "K" + static_cast<char>(storage_numel) +
                          "tQ" + std::string("K\x00", 2) + ints(shape) + ints(stride) + "tR.";
  WriteZipAtomic(path, {{"archive/data.pkl", pkl},
                        {"archive/byteorder", "little"},
                        {"archive/data/0", std::string(static_cast<size_t>(storage_numel) * 4, '\0')}});
}

TEST(HostileInput, PthViewsCannotOverflowOrExpand) {
  testing::TempDir tmp;
  WritePth(tmp.File("ok.pth"), 4, {2, 2}, {2, 1});
  EXPECT_EQ(PthFile::Open(tmp.File("ok.pth")).tensors.at(0).numel(), 4);
  // (shape − 1)·stride overflows int64: once a wild memcpy.
  WritePth(tmp.File("wrap.pth"), 4, {uint64_t{1} << 62, 4}, {uint64_t{1} << 62, 1});
  EXPECT_NE(ErrorOf([&] { PthFile::Open(tmp.File("wrap.pth")); }).find("damaged"), std::string::npos);
  // A stride-0 view of one element as 10^5 × 10^5: once a 40 GB allocation.
  WritePth(tmp.File("bomb.pth"), 1, {100000, 100000}, {0, 0});
  EXPECT_NE(ErrorOf([&] { PthFile::Open(tmp.File("bomb.pth")); }).find("limit: its storage's size, or 64 MiB"),
            std::string::npos);
  // 2^24 floats broadcast from one (64 MiB) is still read; one more row is not.
  WritePth(tmp.File("b64.pth"), 1, {4096, 4096}, {0, 0});
  EXPECT_EQ(PthFile::Open(tmp.File("b64.pth")).tensors.at(0).numel(), 4096 * 4096);
  WritePth(tmp.File("b65.pth"), 1, {4097, 4096}, {0, 0});
  EXPECT_FALSE(ErrorOf([&] { PthFile::Open(tmp.File("b65.pth")); }).empty());
}

TEST(HostileInput, NpyShapeCannotWrapTheSizeCheck) {
  std::string h = "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 4611686018427387904, 4), }";
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  const std::string npy =
      std::string("\x93NUMPY\x01\x00", 8) + static_cast<char>(h.size()) + '\0' + h + std::string(64, '\0');
  const std::string e = ErrorOf([&] { ParseNpy(reinterpret_cast<const uint8_t*>(npy.data()), npy.size(), "c.npy"); });
  EXPECT_NE(e.find("c.npy"), std::string::npos) << e;
  const std::string big = std::string("\x93NUMPY\x01\x00", 8);
  std::string h2 = "{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999999999999999,), }";
  while ((10 + h2.size() + 1) % 64) h2 += ' ';
  h2 += '\n';
  const std::string npy2 = big + static_cast<char>(h2.size()) + '\0' + h2;
  EXPECT_NE(ErrorOf([&] {
              ParseNpy(reinterpret_cast<const uint8_t*>(npy2.data()), npy2.size(), "d.npy");
            }).find("absurdly large"),
            std::string::npos);
}

// About 1 valid safetensors file in 32 has a header length whose low byte is 0x80, a legacy pickle's first byte.
TEST(HostileInput, SafetensorsWithHeaderLength0x80IsAccepted) {
  testing::TempDir tmp;
  const float v[2] = {1.5f, -2.f};
  const TensorView t = MakeTensor(DType::kF32, {2}, v, sizeof(v));
  for (int pad = 0; pad < 300; ++pad) {
    const std::vector<uint8_t> bytes = SerializeSafetensors({{"w", t}}, {{"pad", std::string(pad, 'x')}});
    if (bytes[0] != 0x80) continue;
    WriteFileAtomic(tmp.File("m.safetensors"), bytes.data(), bytes.size());
    const Checkpoint c = Checkpoint::Open(tmp.File("m.safetensors"));
    EXPECT_EQ(c.format(), Checkpoint::Format::kSafetensors);
    EXPECT_EQ(c.names().size(), 1u);
    return;
  }
  FAIL() << "no padding gave a header length with low byte 0x80";
}

TEST(HostileInput, FifosAndFoldersAreRefusedNotWaitedOn) {
  testing::TempDir tmp;
  ASSERT_EQ(::mkfifo(tmp.File("fifo").c_str(), 0600), 0);
  EXPECT_NE(ErrorOf([&] { Checkpoint::Open(tmp.File("fifo")); }).find("not a regular file"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { ReadFileBytes(tmp.File("fifo")); }).find("not a regular file"), std::string::npos);
  std::filesystem::create_directories(tmp.File("dir"));
  EXPECT_NE(ErrorOf([&] { ReadCorrespondenceFile(tmp.File("dir")); }).find("folder"), std::string::npos);
}

// A "regular" file that cannot tell its size (/proc/self/mem): refused naming it (it became a vector of 2^64 − 1
// bytes).
TEST(HostileInput, FilesWithoutASizeAreRefused) {
  if (!std::filesystem::exists("/proc/self/mem")) GTEST_SKIP() << "no /proc";
  EXPECT_NE(ErrorOf([&] { ReadFileBytes("/proc/self/mem"); }).find("/proc/self/mem: cannot tell its size"),
            std::string::npos);
}

// A ZIP whose headers declare gigabytes for a small member (a bomb: it was allocated at the declared size first).
TEST(HostileInput, ZipMembersCannotDeclareMoreThanTheyHold) {
  testing::TempDir tmp;
  WriteZipAtomic(tmp.File("s.zip"), {{"pose_s00001.txt", std::string(1000, '\n')}});
  ASSERT_EQ(ZipContents::Read(tmp.File("s.zip")).files.at("pose_s00001.txt").size(), 1000u);
  std::string z = testing::ReadText(tmp.File("s.zip"));
  const uint32_t huge = 3u << 30;  // 3 GiB
  int patched = 0;
  for (size_t i = 0; i + 46 < z.size(); ++i) {
    const bool local = z.compare(i, 4, "PK\x03\x04") == 0, central = z.compare(i, 4, "PK\x01\x02") == 0;
    if (!local && !central) continue;
    std::memcpy(&z[i + (local ? 22 : 24)], &huge, 4);  // uncompressed size (little-endian)
    ++patched;
  }
  ASSERT_EQ(patched, 2);
  testing::WriteBytes(tmp.File("bomb.zip"), z);
  const std::string e = ErrorOf([&] { ZipContents::Read(tmp.File("bomb.zip")); });
  EXPECT_NE(e.find("more than any real archive holds"), std::string::npos) << e;
}

TEST(HostileInput, AnEightBitPngIsNotADepthMap) {
  testing::TempDir tmp;
  WritePng8(tmp.File("d8.png"), 4, 3, std::vector<uint8_t>(12, 200));
  EXPECT_NE(ErrorOf([&] { ReadDepthPng(tmp.File("d8.png")); }).find("8-bit PNG is not a depth map"), std::string::npos);
  WritePng16(tmp.File("d16.png"), 4, 3, std::vector<uint16_t>(12, 1500));
  EXPECT_FLOAT_EQ(ReadDepthPng(tmp.File("d16.png")).at(1, 1), 1.5f);
}

}  // namespace
}  // namespace freeloc::io
