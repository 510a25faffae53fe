// Regression tests for hostile inputs, second part: pickle bombs (deep nesting, cycles, shared-reference
// DAGs, huge integers, foreign globals), the input limits (image pixels, tensors, submission size), and text from
// files made safe to print. Each input is the minimal one of its class.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "freeloc/core/camera.h"
#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/io/pickle.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/io/submission.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

using testing::ErrorOf;

std::string ParseError(const std::string& pkl) {
  return ErrorOf([&] { ParsePickle(reinterpret_cast<const uint8_t*>(pkl.data()), pkl.size(), "t.pkl", nullptr); });
}

// Restores a limit after a test lowers it.
struct ScopedLimit {
  ScopedLimit(const std::string& name, int64_t value, int64_t old) : name_(name), old_(old) {
    SetLimit(name, std::to_string(value));
  }
  ~ScopedLimit() { SetLimit(name_, std::to_string(old_)); }
  std::string name_;
  int64_t old_;
};

TEST(HostilePickle, DeepNestingIsRefusedAndFreedWithoutRecursion) {
  // 200 000 lists, each appended into the one before: once a stack overflow in the recursive destructor.
  const int n = 200000;
  std::string pkl = "\x80\x02";
  for (int k = 0; k < n; ++k) pkl += "]";
  for (int k = 0; k < n - 1; ++k) pkl += "a";
  pkl += ".";
  EXPECT_NE(ParseError(pkl).find("nest more than 1000 deep"), std::string::npos);
  // Within the limit the same shape parses, and a 5 000-deep value built directly is freed without recursion.
  std::string ok = "\x80\x02";
  for (int k = 0; k < 50; ++k) ok += "]";
  for (int k = 0; k < 49; ++k) ok += "a";
  ok += ".";
  PyRef r = ParsePickle(reinterpret_cast<const uint8_t*>(ok.data()), ok.size(), "ok.pkl", nullptr);
  int depth = 0;
  for (PyRef v = r; v && !v->items.empty(); v = v->items[0]) ++depth;
  EXPECT_EQ(depth, 49);
  PyRef chain = std::make_shared<PyObject>();
  for (int k = 0; k < 500000; ++k) {
    auto parent = std::make_shared<PyObject>();
    parent->kind = PyObject::Kind::kList;
    parent->items.push_back(chain);
    chain = parent;
  }
  chain.reset();  // must not overflow the stack
}

TEST(HostilePickle, CyclesAreRefusedWithoutLeaking) {
  // EMPTY_LIST, MEMOIZE, BINGET 0, APPEND: a list inside itself (once an endless repr).
  const std::string self = std::string("\x80\x04]\x94h\x00", 6) + "a.";
  EXPECT_NE(ParseError(self).find("reference cycle"), std::string::npos);
  // The same cycle in a stream that then fails for another reason: nothing may leak (checked under ASan/LSan).
  const std::string broken = std::string("\x80\x04]\x94h\x00", 6) + "a";
  EXPECT_NE(ParseError(broken).find("without STOP"), std::string::npos);
}

TEST(HostilePickle, SharedReferenceBombIsRefused) {
  // L0 = []; L(k+1) = [Lk, Lk]: 64 levels stand for 2^64 objects in a few hundred bytes.
  std::string pkl = std::string("\x80\x04]\x94", 4);
  for (int k = 0; k < 64; ++k) pkl += std::string("(h") + static_cast<char>(k) + "h" + static_cast<char>(k) + "l\x94";
  pkl += ".";
  EXPECT_NE(ParseError(pkl).find("shared references"), std::string::npos);
}

TEST(HostilePickle, HugeIntegersAndForeignGlobalsAreRefused) {
  std::string long4 = "\x80\x02\x8b";
  const uint32_t n = 200000;
  for (int k = 0; k < 4; ++k) long4 += static_cast<char>((n >> (8 * k)) & 0xff);
  long4 += std::string(n, '\x7f') + ".";
  EXPECT_NE(ParseError(long4).find("integer of 200000 bytes"), std::string::npos);
  EXPECT_NE(ParseError("\x80\x02"
                       "cos\nsystem\n(S'echo hi'\ntR.")
                .find("global os.system"),
            std::string::npos);
  EXPECT_NE(ParseError("\x80\x02"
                       "cbuiltins\neval\n.")
                .find("builtins.eval"),
            std::string::npos);
  // An escape code in a global's name is printed escaped, never raw.
  const std::string e = ParseError(
      "\x80\x02"
      "cx\x1b[2J\ny\n.");
  EXPECT_EQ(e.find('\x1b'), std::string::npos);
  EXPECT_NE(e.find("\\x1b[2J"), std::string::npos);
  // What real checkpoints name stays accepted.
  EXPECT_TRUE(IsAllowedPickleGlobal("torch._utils", "_rebuild_tensor_v2"));
  EXPECT_TRUE(IsAllowedPickleGlobal("torch", "BFloat16Storage"));
  EXPECT_TRUE(IsAllowedPickleGlobal("argparse", "Namespace"));
  EXPECT_TRUE(IsAllowedPickleGlobal("collections", "OrderedDict"));
  EXPECT_FALSE(IsAllowedPickleGlobal("subprocess", "Popen"));
  EXPECT_FALSE(IsAllowedPickleGlobal("torch", "load"));
}

TEST(HostilePickle, ValueCountLimitStopsMemoryBombs) {
  PickleLimits l;
  l.max_objects = 1000;
  std::string pkl = "\x80\x02";
  for (int k = 0; k < 2000; ++k) pkl += "N";
  pkl += ".";
  EXPECT_NE(ErrorOf([&] {
              ParsePickle(reinterpret_cast<const uint8_t*>(pkl.data()), pkl.size(), "t.pkl", nullptr, nullptr, l);
            }).find("more than 1000 values"),
            std::string::npos);
}

// A PNG signature + IHDR declaring w x h, and an IEND: no pixel data at all.
std::vector<uint8_t> PngHeader(uint32_t w, uint32_t h) {
  std::string s = "\x89PNG\r\n\x1a\n";
  s += std::string("\x00\x00\x00\x0dIHDR", 8);
  for (uint32_t v : {w, h})
    for (int k = 3; k >= 0; --k) s += static_cast<char>((v >> (8 * k)) & 0xff);
  s += std::string("\x08\x02\x00\x00\x00", 5) + std::string(4, '\0');
  s += std::string("\x00\x00\x00\x00IEND\xae\x42\x60\x82", 12);
  return std::vector<uint8_t>(s.begin(), s.end());
}

TEST(HostileLimits, ImagePixelsAreRefusedBeforeDecoding) {
  const std::string e = ErrorOf([&] { DecodeImage(PngHeader(30000, 30000), "big.png"); });
  EXPECT_NE(e.find("big.png: PNG declares 30000 x 30000 pixels"), std::string::npos) << e;
  EXPECT_NE(e.find("raise the limit max_image_pixels (FREELOC_LIMIT_MAX_IMAGE_PIXELS=N"), std::string::npos) << e;
  // A small image is only refused by the decoder (no pixel data), not by the limit.
  EXPECT_EQ(ErrorOf([&] { DecodeImage(PngHeader(64, 48), "small.png"); }).find("declares"), std::string::npos);
  // The limit is the user's: lowered, a real image is refused.
  Image img(32, 24);
  testing::TempDir tmp;
  WriteImagePng(tmp.File("a.png"), img);
  EXPECT_EQ(ReadImage(tmp.File("a.png")).width, 32);
  ScopedLimit lower("max_image_pixels", 100, Limits().max_image_pixels);
  EXPECT_NE(ErrorOf([&] { ReadImage(tmp.File("a.png")); }).find("32 x 24"), std::string::npos);
}

TEST(HostileLimits, TensorCountAndSubmissionSize) {
  std::vector<std::pair<std::string, TensorView>> ts;
  static const float v = 1.0f;
  for (int k = 0; k < 50; ++k) {
    TensorView t;
    t.dtype = DType::kF32;
    t.shape = {1};
    t.data = reinterpret_cast<const uint8_t*>(&v);
    t.nbytes = 4;
    ts.emplace_back("t" + std::to_string(k), t);
  }
  const auto bytes = SerializeSafetensors(ts, {});
  EXPECT_EQ(SafetensorsFile::Parse(bytes.data(), bytes.size(), nullptr, "a.safetensors").names.size(), 50u);
  {
    ScopedLimit lower("max_tensors", 10, Limits().max_tensors);
    EXPECT_NE(ErrorOf([&] {
                SafetensorsFile::Parse(bytes.data(), bytes.size(), nullptr, "a.safetensors");
              }).find("max_tensors"),
              std::string::npos);
  }
  // 10 million newlines: counted, the first 1000 kept, no vector of ten million strings.
  const OfficialPoses p = ParseOfficialPoses(std::string(10'000'000, '\n'), true);
  EXPECT_EQ(p.dropped_count, 10'000'000u);
  EXPECT_EQ(p.dropped.size(), 1000u);
  // A submission past the size limit is refused before its members are read.
  testing::TempDir tmp;
  WriteZipAtomic(tmp.File("s.zip"), {{"pose_s00000.txt", std::string(4096, '\n')}});
  ScopedLimit lower("max_submission_bytes", 1000, Limits().max_submission_bytes);
  EXPECT_NE(ErrorOf([&] { ZipContents::Read(tmp.File("s.zip")); }).find("max_submission_bytes"), std::string::npos);
}

TEST(HostileLimits, LimitsAreNamedAndValidated) {
  EXPECT_NE(ErrorOf([] { SetLimit("max_pixels", "5"); }).find("max_image_pixels"), std::string::npos);
  EXPECT_NE(ErrorOf([] { SetLimit("max_tensors", "-1"); }).find("positive integer"), std::string::npos);
  EXPECT_NE(ErrorOf([] { SetLimit("max_tensors", "1e3"); }).find("positive integer"), std::string::npos);
  EXPECT_EQ(SafeText("a\x1b[31mb\nc"), "a\\x1b[31mb\\x0ac");
  EXPECT_EQ(SafeText(std::string(300, 'x'), 10), std::string(10, 'x') + "…");
}

TEST(HostileText, IntrinsicsOutOfRangeOrDuplicatedAreRefused) {
  testing::TempDir tmp;
  auto read = [&](const std::string& text) {
    testing::WriteText(tmp.File("intrinsics.txt"), text);
    return ErrorOf([&] { ReadIntrinsicsFile(tmp.File("intrinsics.txt")); });
  };
  EXPECT_EQ(read("seq0/frame_00000.jpg 500 500 270 360 540 720\n"), "");
  EXPECT_NE(read("seq0/frame_00000.jpg 500 500 1e6 360 540 720\n").find("far outside the 540x720 image"),
            std::string::npos);
  Camera c{500, 500, 1e6, 240, 0, 0};  // no image size known (freeloc pose --ref-intrinsics fx,fy,cx,cy)
  EXPECT_NE(ErrorOf([&] { c.Validate("--ref-intrinsics"); }).find("100 focal lengths"), std::string::npos);
  EXPECT_NE(read("seq0/frame_00000.jpg 1e9 500 270 360 540 720\n").find("100 image widths"), std::string::npos);
  EXPECT_NE(read("seq0/frame_00000.jpg 500 500 270 360 1e300 720\n").find("whole numbers"), std::string::npos);
  EXPECT_NE(read("seq0/frame_00000.jpg 500 500 270 360 540.5 720\n").find("whole numbers"), std::string::npos);
  const std::string dup = read(
      "seq0/frame_00000.jpg 500 500 270 360 540 720\nseq1/frame_00000.jpg 500 500 270 360 540 720\n"
      "seq0/frame_00000.jpg 600 600 270 360 540 720\n");
  EXPECT_NE(dup.find("line 3: frame seq0/frame_00000.jpg is already listed on line 1"), std::string::npos) << dup;
}

// A frame name may not leave its scene: "../s00002/seq1/…" once read another scene's files and wrote that name into
// the submission. Scene files name frames seq<N>/<file>; anything else is refused with the line number.
TEST(HostileText, FrameNamesStayInsideTheirScene) {
  namespace fs = std::filesystem;
  testing::TempDir tmp;
  const std::string scene = tmp.File("s00001");
  fs::create_directories(scene);
  const std::string ok = "seq0/frame_00000.jpg 500 500 270 360 540 720\nseq1/frame_00000.jpg 500 500 270 360 540 720\n";
  auto load = [&](const std::string& intrinsics, const std::string& poses) {
    testing::WriteText(scene + "/intrinsics.txt", intrinsics);
    testing::WriteText(scene + "/poses.txt", poses);
    return ErrorOf([&] { MapfreeScene::Load(scene); });
  };
  EXPECT_EQ(load(ok, "seq0/frame_00000.jpg 1 0 0 0 0 0 0\n"), "");
  for (const char* bad : {"../s00002/seq1/frame_00000.jpg", "/etc/passwd", "seq1/../../s00002/seq1/frame_00000.jpg",
                          "seq1//frame.jpg", "seq1/./frame.jpg", "frame_00000.jpg", "seqx/frame.jpg", "seq1\\f.jpg"}) {
    const std::string e = load(ok + bad + std::string(" 500 500 270 360 540 720\n"), "");
    EXPECT_NE(e.find("intrinsics.txt line 3: frame name"), std::string::npos) << bad << ": " << e;
    EXPECT_NE(e.find("is not a path inside the scene"), std::string::npos) << bad << ": " << e;
  }
  const std::string e = load(ok, "seq0/frame_00000.jpg 1 0 0 0 0 0 0\n../s00002/seq1/frame_00000.jpg 1 0 0 0 0 0 0\n");
  EXPECT_NE(e.find("poses.txt line 2: frame name"), std::string::npos) << e;
  // A blank line of spaces in poses.txt is skipped (it once indexed an empty split).
  EXPECT_EQ(load(ok, "seq0/frame_00000.jpg 1 0 0 0 0 0 0\n   \nseq1/frame_00000.jpg 1 0 0 0 0 0 0\n"), "");
  // relocalize --intrinsics FILE names the user's own images: any name is fine there.
  testing::WriteText(tmp.File("k.txt"), "photos/ref.jpg 500 500 270 360 540 720\n");
  EXPECT_EQ(ErrorOf([&] { ReadIntrinsicsFile(tmp.File("k.txt")); }), "");
}

}  // namespace
}  // namespace freeloc::io
