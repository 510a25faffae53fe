#include "freeloc/io/submission.h"

#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "freeloc/core/error.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

TEST(Submission, FormatDoubleRoundTrips) {
  for (double v : {0.1, 1.0 / 3.0, -2.5e-7, 123456789.123, 1e300, 0.999999999999}) {
    EXPECT_EQ(std::strtod(FormatDouble(v).c_str(), nullptr), v);
  }
  EXPECT_EQ(FormatDouble(1.0), "1.0");
  EXPECT_EQ(FormatDouble(0.5), "0.5");
  EXPECT_EQ(FormatDouble(0.0), "0.0");
  EXPECT_THROW(FormatDouble(NAN), Error);
}

TEST(Submission, LineFormat) {
  SubmissionEntry e{"seq1/frame_00005.jpg", Rigid3d(Eigen::Quaterniond(-2, 0, 0, 0), Eigen::Vector3d(0.5, -1, 2)), 42};
  EXPECT_EQ(FormatPoseLine(e), "seq1/frame_00005.jpg 1.0 0.0 0.0 0.0 0.5 -1.0 2.0 42.0");
  e.confidence = -1;
  EXPECT_THROW(FormatPoseLine(e), Error);
  e.confidence = 1;
  e.frame = "bad name";
  EXPECT_THROW(FormatPoseLine(e), Error);
}

TEST(Submission, ZipIsDeterministicAndReadable) {
  testing::TempDir tmp;
  std::map<std::string, std::vector<SubmissionEntry>> scenes;
  scenes["s00461"] = {
      {"seq1/frame_00000.jpg", Rigid3d(Eigen::Quaterniond(0.9, 0.1, 0.2, 0.3), Eigen::Vector3d(1, 2, 3)), 7}};
  scenes["s00460"] = {{"seq1/frame_00001.jpg", Rigid3d(), 0}};
  WriteSubmission(tmp.File("a.zip"), scenes);
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  WriteSubmission(tmp.File("b.zip"), scenes);
  EXPECT_EQ(testing::ReadText(tmp.File("a.zip")), testing::ReadText(tmp.File("b.zip")));
  const ZipContents z = ZipContents::Read(tmp.File("a.zip"));
  EXPECT_EQ(z.names, (std::vector<std::string>{"pose_s00460.txt", "pose_s00461.txt"}));
  const OfficialPoses p = ParseOfficialPoses(z.files.at("pose_s00461.txt"), true);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p.poses.at(0).confidence, 7.0);
  // No temporary files left behind.
  size_t n = 0;
  for (const auto& e : std::filesystem::directory_iterator(tmp.path())) n += e.path().filename().string()[0] == '.';
  EXPECT_EQ(n, 0u);
}

TEST(Submission, NotAZip) {
  testing::TempDir tmp;
  testing::WriteText(tmp.File("x.zip"), "definitely not a zip file");
  try {
    ZipContents::Read(tmp.File("x.zip"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("x.zip: not a ZIP file"), std::string::npos);
  }
  testing::WriteText(tmp.File("y.zip"), "PK\x03\x04 broken");
  EXPECT_THROW(ZipContents::Read(tmp.File("y.zip")), Error);
}

TEST(Submission, OfficialParsingRules) {
  const std::string text =
      "seq1/frame_00000.jpg 1 0 0 0 0 0 0 5\n"
      "seq1/frame_00001.jpg 1 0 0 0 0 0 0\n"      // 8 fields: dropped
      "seq1/frame_00002.jpg  1 0 0 0 0 0 0 5\n"   // double space: 10 fields, dropped
      "seq1/frame_00003.jpg 1 0 0 nan 0 0 0 5\n"  // NaN: dropped
      "seq1/frame_00004.jpg 0 0 0 0 1 2 3 5\n"    // zero quaternion: dropped
      "seq1/frame_0000x.jpg 1 0 0 0 0 0 0 5\n"    // no frame number: dropped
      "# comment line with nine fields x x x\n"
      "other/any_00006.png 2 0 0 0 0 0 -4 1_0\n"   // folder and extension unchecked; underscores allowed
      "seq1/frame_00000.jpg 1 0 0 0 0 0 1 9\r\n";  // duplicate key: last wins, first position kept
  const OfficialPoses p = ParseOfficialPoses(text, true);
  EXPECT_EQ(p.keys, (std::vector<int64_t>{0, 6}));
  EXPECT_EQ(p.dropped.size(), 5u);
  EXPECT_EQ(p.poses.at(0).confidence, 9.0);
  EXPECT_NEAR(p.poses.at(0).t_c2w.z(), -1.0, 1e-15);
  // Non-unit quaternion (2,0,0,0) is normalised: c = −Rᵀt = (0,0,4).
  EXPECT_NEAR(p.poses.at(6).t_c2w.z(), 4.0, 1e-15);
  EXPECT_EQ(p.poses.at(6).confidence, 10.0);
  EXPECT_EQ(p.poses.at(6).q_c2w[0], 1.0);
}

TEST(Submission, CameraCentreConversion) {
  // query_from_ref: rotation 90° about z, t = (1, 0, 0): centre c = −Rᵀt.
  const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  const Rigid3d pose(q, Eigen::Vector3d(1, 0, 0));
  const OfficialPoses p = ParseOfficialPoses(FormatPoseFile({{"seq1/frame_00010.jpg", pose, 1}}), true);
  const Eigen::Vector3d c = pose.Center();
  EXPECT_NEAR((p.poses.at(10).t_c2w - c).norm(), 0, 1e-12);
}

}  // namespace
}  // namespace freeloc::io
