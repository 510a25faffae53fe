#include "freeloc/io/mapfree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/submission.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

namespace fs = std::filesystem;

void MakeScene(const std::string& dir, const std::string& intrinsics, const std::string& poses) {
  fs::create_directories(dir + "/seq0");
  fs::create_directories(dir + "/seq1");
  testing::WriteText(dir + "/intrinsics.txt", intrinsics);
  if (!poses.empty()) testing::WriteText(dir + "/poses.txt", poses);
}

TEST(Mapfree, LoadsTumScene) {
  const std::string split = ResolveSplitDir(testing::DemoPath(), "val");
  EXPECT_EQ(ListScenes(split), (std::vector<std::string>{"s00001", "s00002", "s00003"}));
  const MapfreeScene s = MapfreeScene::Load(split + "/s00002");
  EXPECT_EQ(s.name, "s00002");
  EXPECT_EQ(s.reference.name, "seq0/frame_00000.png");
  ASSERT_EQ(s.queries.size(), 1u);
  EXPECT_EQ(s.queries[0].camera.fx, 517.3);
  EXPECT_EQ(s.queries[0].camera.width, 640);
  ASSERT_TRUE(s.has_gt());
  EXPECT_NEAR(s.gt.at("seq1/frame_00000.png").translation.z(), -0.036247766, 1e-12);
  EXPECT_NEAR(s.gt.at("seq0/frame_00000.png").translation.norm(), 0, 1e-15);
  const Image im = s.LoadImage(s.queries[0]);
  EXPECT_EQ(im.width, 640);
  const DepthMap d = s.LoadDepth(s.reference, "sensor");
  EXPECT_EQ(d.width, 640);
  EXPECT_THROW(s.LoadDepth(s.reference, "dptnyu"), Error);
  // The split folder can be given directly.
  EXPECT_EQ(ResolveSplitDir(split, "val"), split);
  EXPECT_THROW(ListScenes(split, {"s09999"}), Error);
  EXPECT_EQ(ListScenes(split, {"s00003", "s00001"}), (std::vector<std::string>{"s00001", "s00003"}));
}

// TUM depth (uint16, value/5000 m) → freeloc DepthMap → map-free mm PNG → back: within half a millimetre, same
// holes, and identical to the sensor depth shipped in the map-free layout.
// A real Kinect depth map (the bundled TUM RGB-D demo frame, millimetres) through the map-free depth writer and reader.
TEST(Mapfree, DepthPngRoundTripFromTumDepth) {
  int w, h;
  const auto raw = ReadPng16(testing::DemoPath("val/s00002/seq0/frame_00000.sensor.png"), &w, &h);
  DepthMap d(w, h);
  size_t valid = 0;
  for (size_t i = 0; i < raw.size(); ++i) {
    d.data[i] = raw[i] / 1000.0f;
    valid += raw[i] > 0;
  }
  ASSERT_GT(valid, raw.size() / 2);
  testing::TempDir tmp;
  WriteDepthPng(tmp.File("d.png"), d);
  const DepthMap back = ReadDepthPng(tmp.File("d.png"));
  ASSERT_EQ(back.width, w);
  double max_err = 0;
  for (size_t i = 0; i < raw.size(); ++i) {
    ASSERT_EQ(back.data[i] > 0, raw[i] > 0);
    max_err = std::max(max_err, static_cast<double>(std::abs(back.data[i] - d.data[i])));
  }
  EXPECT_LE(max_err, 0.0005 + 1e-6);
  {
    const DepthMap ship = ReadDepthPng(testing::DemoPath("val/s00002/seq0/frame_00000.sensor.png"));
    size_t diff = 0;
    for (size_t i = 0; i < raw.size(); ++i) diff += std::abs(ship.data[i] - back.data[i]) > 0.0011f;
    EXPECT_EQ(diff, 0u);
  }
}

TEST(Mapfree, SyntheticSceneOrderCommentsAndTestScenes) {
  testing::TempDir tmp;
  const std::string dir = tmp.path() + "/val/s00460";
  MakeScene(dir,
            "# comment\nseq0/frame_00000.jpg 590 591 270 360 540 720\nseq1/frame_00003.jpg 590.5 591 270 360 540 720\n"
            "seq1/frame_00001.jpg 590 591 270 360 540 720\n",
            "# path qw qx qy qz tx ty tz\nseq0/frame_00000.jpg 1 0 0 0 0 0 0\n"
            "seq1/frame_00001.jpg 1 0 0 0 0 0 1\nseq1/frame_00003.jpg 0 1 0 0 0 0 2\n");
  const MapfreeScene s = MapfreeScene::Load(dir);
  ASSERT_EQ(s.queries.size(), 2u);
  EXPECT_EQ(s.queries[0].name, "seq1/frame_00001.jpg");  // poses.txt order
  EXPECT_EQ(s.queries[1].camera.fx, 590.5);
  EXPECT_TRUE(s.has_gt());
  EXPECT_EQ(ResolveSplitDir(tmp.path(), "val"), tmp.path() + "/val");
  // Test scene: all-zero poses load fine, without GT.
  const std::string tdir = tmp.path() + "/test/s00525";
  MakeScene(tdir, "seq0/frame_00000.jpg 590 591 270 360 540 720\nseq1/frame_00000.jpg 590 591 270 360 540 720\n",
            "seq0/frame_00000.jpg 0 0 0 0 0 0 0\nseq1/frame_00000.jpg 0 0 0 0 0 0 0\n");
  const MapfreeScene t = MapfreeScene::Load(tdir);
  EXPECT_FALSE(t.has_gt());
  EXPECT_EQ(t.queries.size(), 1u);
}

TEST(Mapfree, BadSceneFiles) {
  testing::TempDir tmp;
  const std::string dir = tmp.path() + "/s1";
  MakeScene(dir, "seq0/frame_00000.jpg 590 591 270 360 540\n", "");
  try {
    MapfreeScene::Load(dir);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("intrinsics.txt line 1: expected 7 fields"), std::string::npos) << e.what();
  }
  MakeScene(dir, "seq0/frame_00000.jpg 590 591 270 360 540 720\nseq1/frame_00000.jpg 590 591 270 360 540 720\n",
            "seq1/frame_00000.jpg 1 0 nan 0 0 0 0\n");
  EXPECT_THROW(MapfreeScene::Load(dir), Error);
  EXPECT_THROW(MapfreeScene::Load(tmp.path() + "/nope"), Error);
  fs::create_directories(tmp.path() + "/s2");
  EXPECT_THROW(MapfreeScene::Load(tmp.path() + "/s2"), Error);  // no intrinsics.txt
  EXPECT_THROW(ResolveSplitDir(tmp.path() + "/missing", "val"), Error);
}

TEST(Mapfree, PrecomputedCorrespondences) {
  testing::TempDir tmp;
  const std::string dir = tmp.path() + "/s1";
  MakeScene(
      dir,
      "seq0/frame_00000.jpg 590 591 270 360 540 720\nseq1/frame_00000.jpg 590 591 270 360 540 720\n"
      "seq1/frame_00001.jpg 590 591 270 360 540 720\n",
      "seq0/frame_00000.jpg 1 0 0 0 0 0 0\nseq1/frame_00000.jpg 1 0 0 0 0 0 0\nseq1/frame_00001.jpg 1 0 0 0 0 0 0\n");
  // float64, shape (2, 2, 4), second row of query 0 is NaN padding.
  const double nan = std::nan("");
  const double v[16] = {1, 2, 3, 4, nan, nan, nan, nan, 5, 6, 7, 8, 9, 10, 11, 12};
  std::string h = "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 2, 4), }";
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::string npy = std::string("\x93NUMPY\x01\x00", 8) + static_cast<char>(h.size()) + '\0' + h +
                    std::string(reinterpret_cast<const char*>(v), sizeof(v));
  WriteZipAtomic(dir + "/correspondences_SIFT.npz", {{"correspondences.npy", npy}});
  const MapfreeScene s = MapfreeScene::Load(dir);
  const auto c = s.LoadCorrespondences("SIFT");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].size(), 1u);
  EXPECT_EQ(c[1].size(), 2u);
  EXPECT_EQ(c[1][1].w(), 12.0);
  EXPECT_THROW(s.LoadCorrespondences("LoFTR"), Error);
}

}  // namespace
}  // namespace freeloc::io

namespace freeloc::io {
namespace {

TEST(MultiFrame, FrameNumbersAndWindowsByLinearPosition) {
  EXPECT_EQ(FrameNumber("seq1/frame_00011.jpg"), 11);
  EXPECT_EQ(FrameNumber("seq1/frame_00000.png"), 0);
  EXPECT_EQ(FrameNumber("seq1/img_00011.jpg"), -1);
  EXPECT_EQ(FrameNumber("seq1/frame_.jpg"), -1);
  EXPECT_EQ(FrameNumber("seq1/frame_12"), -1);
  // 25 frames whose numbers skip (as val s00470: the first evaluated frame is frame_00011), listed out of order.
  testing::TempDir tmp;
  const std::string dir = tmp.path() + "/s00470";
  std::vector<int> numbers = {0,  1,  3,  5,  6,  7,  8,  9,  10, 11, 12, 14, 15,
                              16, 17, 18, 19, 20, 21, 22, 30, 31, 32, 33, 34};
  std::string k = "seq0/frame_00000.jpg 500 500 270 360 540 720\n", p;
  for (auto it = numbers.rbegin(); it != numbers.rend(); ++it) {
    char name[64];
    std::snprintf(name, sizeof(name), "seq1/frame_%05d.jpg", *it);
    k += std::string(name) + " 500 500 270 360 540 720\n";
    p += std::string(name) + " 1 0 0 0 0 0 0\n";
  }
  MakeScene(dir, k, p);
  const MapfreeScene s = MapfreeScene::Load(dir);
  const auto windows = MultiFrameWindows(s, 9);
  ASSERT_EQ(windows.size(), 2u);  // linear positions 9 and 19 of 25
  EXPECT_EQ(s.queries[windows[0].evaluated].name, "seq1/frame_00011.jpg");
  std::vector<int64_t> got;
  for (size_t i : windows[0].frames) got.push_back(FrameNumber(s.queries[i].name));
  EXPECT_EQ(got, (std::vector<int64_t>{1, 3, 5, 6, 7, 8, 9, 10, 11}));
  EXPECT_EQ(s.queries[windows[1].evaluated].name, "seq1/frame_00022.jpg");
  const auto three = MultiFrameWindows(s, 3);
  ASSERT_EQ(three.size(), 2u);
  got.clear();
  for (size_t i : three[1].frames) got.push_back(FrameNumber(s.queries[i].name));
  EXPECT_EQ(got, (std::vector<int64_t>{20, 21, 22}));
  EXPECT_THROW(MultiFrameWindows(s, 0), Error);
  EXPECT_THROW(MultiFrameWindows(s, 10), Error);
}

TEST(MultiFrame, DevicePosesFile) {
  testing::TempDir tmp;
  const std::string path = tmp.path() + "/poses_device.txt";
  // Signed zeros, no final newline, a blank line.
  testing::WriteText(path,
                     "seq1/frame_00001.jpg 0.9999500004166653 0.0099998333341667 0.0 0.0 0.01 -0.02 0.03\n\n"
                     "seq1/frame_00009.jpg 1.0000000000000000 -0.0000000000000000 0.0000000000000000 "
                     "-0.0000000000000000 0.0000000000000000 -0.0000000000000000 0.0000000000000000");
  const auto poses = ReadDevicePoses(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_NEAR(poses.at("seq1/frame_00001.jpg").translation.y(), -0.02, 1e-15);
  EXPECT_NEAR(RotationAngleDeg(poses.at("seq1/frame_00001.jpg").rotation, Eigen::Quaterniond::Identity()),
              2 * std::asin(0.0099998333341667) * 180 / M_PI, 1e-9);
  EXPECT_EQ(poses.at("seq1/frame_00009.jpg").translation.norm(), 0.0);
  auto refused = [&](const std::string& text, const std::string& needle) {
    testing::WriteText(path, text);
    try {
      ReadDevicePoses(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("poses_device.txt line"), std::string::npos) << e.what();
    }
  };
  refused("seq1/frame_00001.jpg 1 0 0 0 0 0\n", "expected 8 fields");
  refused("seq1/frame_00001.jpg 1 0 0 0 0 nan 0\n", "not a finite number");
  refused("seq1/frame_00001.jpg 2 0 0 0 0 0 0\n", "norm");
  refused("seq1/frame_00001.jpg 1 0 0 0 0 0 0\nseq1/frame_00001.jpg 1 0 0 0 0 0 0\n", "twice");
  refused("../s00002/seq1/frame_00001.jpg 1 0 0 0 0 0 0\n", "not a path inside the scene");
}

}  // namespace
}  // namespace freeloc::io
