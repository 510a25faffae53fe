// Photos without a calibration: `relocalize` with intrinsics from EXIF (and its orientation) or from the pointmap,
// the check of given intrinsics, the errors, and `freeloc intrinsics` — on the bundled TUM pair re-encoded as JPEGs
// with the EXIF a camera writes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_testing.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/io/correspondence_file.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"
#include "testing/exif_writer.h"
#include "testing/testing.h"

namespace {

using freeloc::Image;
using freeloc::testing::ExifFields;
using freeloc::testing::Rational;

// The pair's calibration as a camera would write it: a 4 mm lens and the focal-plane resolution that makes
// fx = 520.9 px, fy = 521.0 px (s00003's intrinsics), principal point at the centre.
constexpr double kFx = 520.908620, kFy = 521.007327, kLensMm = 4.0;

Image Rotate90(const Image& im, bool clockwise) {
  Image out(im.height, im.width);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const int nx = clockwise ? im.height - 1 - y : y, ny = clockwise ? x : im.width - 1 - x;
      for (int c = 0; c < 3; ++c) out.pixel(nx, ny)[c] = im.at(x, y, c);
    }
  return out;
}

// `image` stored as a JPEG with EXIF focal fields, turned for `orientation` (1: as is; 6: stored turned 90°
// counter-clockwise, so that the viewer turns it clockwise back; 8: the other way).
std::string WriteJpeg(const freeloc::testing::TempDir& tmp, const std::string& name, const Image& upright,
                      int orientation, ExifFields f = {}) {
  const Image stored = orientation == 6   ? Rotate90(upright, false)
                       : orientation == 8 ? Rotate90(upright, true)
                                          : upright;
  if (f.focal_length.denominator == 0 && f.focal_35mm < 0) {
    f.focal_length = Rational(kLensMm);
    // Stored x is displayed y for 6 and 8.
    const double xres = (orientation >= 5 ? kFy : kFx) / kLensMm, yres = (orientation >= 5 ? kFx : kFy) / kLensMm;
    f.focal_plane_x = Rational(xres, 100000);
    f.focal_plane_y = Rational(yres, 100000);
    f.focal_plane_unit = 4;
  }
  f.orientation = orientation;
  const std::vector<uint8_t> bytes = freeloc::testing::WithExif(freeloc::io::EncodeJpeg(stored, 95, name), f);
  const std::string path = tmp.File(name);
  freeloc::io::WriteFileAtomic(path, bytes.data(), bytes.size());
  return path;
}

struct Pair {
  std::string ref, query, ref_depth, query_depth;
};

Pair S00003(const freeloc::testing::TempDir& tmp, int ref_orientation = 1, int query_orientation = 1) {
  const std::string s = freeloc::testing::DemoPath("val/s00003/");
  Pair p;
  p.ref = WriteJpeg(tmp, "ref_o" + std::to_string(ref_orientation) + ".jpg",
                    freeloc::io::ReadImage(s + "seq0/frame_00000.png"), ref_orientation);
  p.query = WriteJpeg(tmp, "query_o" + std::to_string(query_orientation) + ".jpg",
                      freeloc::io::ReadImage(s + "seq1/frame_00000.png"), query_orientation);
  p.ref_depth = s + "seq0/frame_00000.sensor.png";
  p.query_depth = s + "seq1/frame_00000.sensor.png";
  return p;
}

nlohmann::json Relocalize(const Pair& p, const std::string& extra, bool depth = true) {
  const Result r =
      RunFreeloc("relocalize --ref " + p.ref + " --query " + p.query +
                 (depth ? " --ref-depth " + p.ref_depth + " --query-depth " + p.query_depth : "") + " --json " + extra);
  EXPECT_EQ(r.code, 0) << r.out;
  const size_t brace = r.out.find('{');
  if (brace == std::string::npos) return nlohmann::json::object();
  return nlohmann::json::parse(r.out.substr(brace));
}

freeloc::Rigid3d PoseOf(const nlohmann::json& j) {
  const auto q = j.at("qvec"), t = j.at("tvec");
  return freeloc::Rigid3d(
      Eigen::Quaterniond(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>()).normalized(),
      Eigen::Vector3d(t[0].get<double>(), t[1].get<double>(), t[2].get<double>()));
}

double RotationDeg(const freeloc::Rigid3d& a, const freeloc::Rigid3d& b) {
  return Eigen::AngleAxisd(a.rotation * b.rotation.inverse()).angle() * 180 / M_PI;
}

// EXIF focal + focal-plane resolution: the focal used is the truth to 0.1 %, and the pose is the one the same
// intrinsics give when handed in explicitly (0.1° / 1 cm).
TEST(CliIntrinsics, ExifGivesTheExplicitPose) {
  freeloc::testing::TempDir tmp;
  const Pair p = S00003(tmp);
  const nlohmann::json exif = Relocalize(p, "");
  ASSERT_TRUE(exif.contains("intrinsics")) << exif.dump();
  for (const char* frame : {"ref", "query"}) {
    const auto& k = exif["intrinsics"][frame];
    EXPECT_EQ(k["source"], "exif");
    EXPECT_NEAR(k["fx"].get<double>() / kFx, 1.0, 1e-3);
    EXPECT_NEAR(k["fy"].get<double>() / kFy, 1.0, 1e-3);
    EXPECT_DOUBLE_EQ(k["cx"].get<double>(), 319.5);
    EXPECT_DOUBLE_EQ(k["cy"].get<double>(), 239.5);
  }
  const std::string k = std::to_string(kFx) + "," + std::to_string(kFy) + ",319.5,239.5";
  const nlohmann::json given = Relocalize(p, "--ref-intrinsics " + k + " --query-intrinsics " + k);
  EXPECT_EQ(given["intrinsics"]["ref"]["source"], "given");
  ASSERT_EQ(exif["status"], "ok");
  ASSERT_EQ(given["status"], "ok");
  const freeloc::Rigid3d a = PoseOf(exif), b = PoseOf(given);
  EXPECT_LT(RotationDeg(a, b), 0.1);
  EXPECT_LT((a.translation - b.translation).norm(), 0.01);
  // The text output says where the intrinsics came from.
  const Result text = RunFreeloc("relocalize --ref " + p.ref + " --query " + p.query);
  EXPECT_TRUE(Contains(text.out, "intrinsics:  ref fx 520.91 fy 521.01 cx 319.50 cy 239.50 (exif")) << text.out;
}

// A photo stored turned with Orientation 6 or 8 gives the pose of the same photo stored upright (0.5°: the pixels
// are re-encoded turned), with EXIF intrinsics, with and without depth (the depth maps are in displayed orientation).
TEST(CliIntrinsics, OrientationSixAndEightGiveTheUprightPose) {
  freeloc::testing::TempDir tmp;
  const Pair upright = S00003(tmp);
  for (bool depth : {true, false}) {
    const nlohmann::json base = Relocalize(upright, "", depth);
    ASSERT_TRUE(base["solved"].get<bool>()) << base.dump();
    for (auto [ro, qo] : {std::pair{1, 6}, std::pair{8, 1}, std::pair{6, 8}}) {
      const Pair turned = S00003(tmp, ro, qo);
      const nlohmann::json j = Relocalize(turned, "", depth);
      ASSERT_TRUE(j["solved"].get<bool>()) << j.dump();
      const freeloc::Rigid3d a = PoseOf(base), b = PoseOf(j);
      EXPECT_LT(RotationDeg(a, b), 0.5) << "orientations " << ro << "/" << qo << (depth ? " with depth" : "");
      if (depth) {
        EXPECT_LT((a.translation - b.translation).norm(), 0.02);
      } else {  // unit translations: their direction (from a few hundred matches that the re-encoding moves)
        EXPECT_LT(std::acos(std::min(1.0, a.translation.normalized().dot(b.translation.normalized()))) * 180 / M_PI,
                  2.0);
      }
      EXPECT_EQ(j["intrinsics"]["query"]["orientation"], qo);
      EXPECT_NEAR(j["intrinsics"]["query"]["fx"].get<double>() / kFx, 1.0, 1e-3);  // displayed x: the swap undone
      EXPECT_NEAR(j["intrinsics"]["ref"]["fy"].get<double>() / kFy, 1.0, 1e-3);
    }
  }
}

// No source at all: one line naming the flags, exit 1. Absurd EXIF: a warning naming the file and the next source.
TEST(CliIntrinsics, NoSourceIsOneLineAndAbsurdExifWarns) {
  freeloc::testing::TempDir tmp;
  const std::string s = freeloc::testing::DemoPath("val/s00003/");
  const std::string png_ref = s + "seq0/frame_00000.png", png_query = s + "seq1/frame_00000.png";
  Result r = RunFreeloc("relocalize --ref " + png_ref + " --query " + png_query);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_TRUE(Contains(r.out, png_ref + ": no intrinsics")) << r.out;
  EXPECT_TRUE(Contains(r.out, "--ref-intrinsics")) << r.out;
  EXPECT_TRUE(Contains(r.out, "--intrinsics FILE")) << r.out;

  const Image ref = freeloc::io::ReadImage(png_ref);
  ExifFields absurd;
  absurd.focal_length = Rational(5000);  // a 5 m lens on a phone sensor
  absurd.focal_plane_x = Rational(1000);
  absurd.focal_plane_unit = 4;
  const std::string bad = WriteJpeg(tmp, "absurd.jpg", ref, 1, absurd);
  r = RunFreeloc("relocalize --ref " + bad + " --query " + png_query + " --query-intrinsics 520.9,521,319.5,239.5");
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "warning")) << r.out;
  EXPECT_TRUE(Contains(r.out, "absurd")) << r.out;
  EXPECT_TRUE(Contains(r.out, bad + ": no intrinsics")) << r.out;
  // … and with a 35 mm equivalent as well, that one is used.
  absurd.focal_35mm = 29;
  const std::string with35 = WriteJpeg(tmp, "absurd35.jpg", ref, 1, absurd);
  r = RunFreeloc("relocalize --ref " + with35 + " --query " + png_query +
                 " --query-intrinsics 520.9,521,319.5,239.5 --json");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "absurd")) << r.out;
  EXPECT_TRUE(Contains(r.out, "\"fx\": " + std::to_string(29.0 / 36 * 640).substr(0, 6))) << r.out;
}

// `freeloc intrinsics` says what it would use and why, per image; an unreadable image fails alone (exit 1).
TEST(CliIntrinsics, IntrinsicsCommand) {
  freeloc::testing::TempDir tmp;
  const Pair p = S00003(tmp, 1, 6);
  const std::string png = freeloc::testing::DemoPath("val/s00003/seq0/frame_00000.png");
  Result r = RunFreeloc("intrinsics " + p.ref + " " + p.query + " " + png);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, p.query + ": 640x480 as displayed (EXIF orientation 6: rotated 90° clockwise from the "
                                        "480x640 stored)"))
      << r.out;
  EXPECT_TRUE(Contains(r.out, "FocalLength 4 mm")) << r.out;
  EXPECT_TRUE(Contains(r.out, "intrinsics: fx 520.91 fy 521.01 cx 319.50 cy 239.50 (exif")) << r.out;
  EXPECT_TRUE(Contains(r.out, png + ": 640x480 as displayed\n  EXIF:       none")) << r.out;
  r = RunFreeloc("intrinsics --json " + p.query);
  EXPECT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["source"], "exif");
  EXPECT_EQ(j["orientation"], 6);
  r = RunFreeloc("intrinsics " + p.ref + " " + tmp.File("missing.jpg"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "missing.jpg")) << r.out;
  EXPECT_TRUE(Contains(r.out, "(exif")) << r.out;
}

// With a DUSt3R preset and no intrinsics, the pointmap gives the focal (principal point at the centre); with
// intrinsics given, the pointmap's focal checks them. (Tiny random weights: the values are meaningless, the path real.)
TEST(CliIntrinsics, PointmapEstimatesAndChecks) {
  const std::string model = freeloc::testing::TinyModelPath("dust3r_tiny.pth");
  const std::string s = freeloc::testing::DemoPath("val/s00003/");
  const std::string pair = "--ref " + s + "seq0/frame_00000.png --query " + s + "seq1/frame_00000.png";
  const std::string net = " --preset dust3r --dust3r " + model + " --dust3r-size 224 --depth none --json";
  // The reference without intrinsics (its pointmap gives them); the query's given (and checked).
  Result r = RunFreeloc("relocalize " + pair + net + " --query-intrinsics 520.9,521,319.5,239.5");
  const size_t brace = r.out.find('{');
  ASSERT_NE(brace, std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out.substr(brace));
  const auto& kr = j["intrinsics"]["ref"];
  EXPECT_EQ(kr["source"], "pointmap") << j.dump();
  EXPECT_GT(kr["fx"].get<double>(), 0);
  EXPECT_EQ(kr["fx"], kr["fy"]);
  EXPECT_EQ(kr["fx"], kr["pointmap_focal"]);
  EXPECT_DOUBLE_EQ(kr["cx"].get<double>(), 319.5);
  EXPECT_DOUBLE_EQ(kr["cy"].get<double>(), 239.5);
  EXPECT_EQ(j["intrinsics"]["query"]["source"], "given");
  // A focal 3× the estimate is flagged, naming both values; check_intrinsics 0 turns the check off.
  const double f3 = 3 * j["intrinsics"]["ref"]["fx"].get<double>();
  const std::string k = std::to_string(f3) + "," + std::to_string(f3) + ",319.5,239.5";
  r = RunFreeloc("relocalize " + pair + net + " --ref-intrinsics " + k + " --query-intrinsics 520.9,521,319.5,239.5");
  ExpectMentions(r.out,
                 {"warning", "reference intrinsics (given): the focal length", "differs from the pointmap's estimate"});
  r = RunFreeloc("relocalize " + pair + net + " --ref-intrinsics " + k +
                 " --query-intrinsics 520.9,521,319.5,239.5 --set check_intrinsics=0");
  EXPECT_FALSE(Contains(r.out, "differs from the pointmap's estimate")) << r.out;
  EXPECT_FALSE(Contains(r.out, "pointmap_focal")) << r.out;
}

}  // namespace

namespace {

// `im` ×`k` (bilinear, pixel centres as freeloc maps them): a "phone photo" of the bundled pair.
Image Upscaled(const Image& im, int k) {
  Image out(im.width * k, im.height * k);
  for (int y = 0; y < out.height; ++y) {
    const double v = std::clamp((y + 0.5) / k - 0.5, 0.0, im.height - 1.0);
    const int y0 = static_cast<int>(v), y1 = std::min(y0 + 1, im.height - 1);
    for (int x = 0; x < out.width; ++x) {
      const double u = std::clamp((x + 0.5) / k - 0.5, 0.0, im.width - 1.0);
      const int x0 = static_cast<int>(u), x1 = std::min(x0 + 1, im.width - 1);
      for (int c = 0; c < 3; ++c) {
        const double top = im.at(x0, y0, c) + (u - x0) * (im.at(x1, y0, c) - im.at(x0, y0, c));
        const double bottom = im.at(x0, y1, c) + (u - x0) * (im.at(x1, y1, c) - im.at(x0, y1, c));
        out.pixel(x, y)[c] = static_cast<uint8_t>(std::lround(top + (v - y0) * (bottom - top)));
      }
    }
  }
  return out;
}

}  // namespace

// A working resolution (docs/pipeline.md "Phone photos"): the pair ×4 (2560×1920, stored turned with EXIF
// orientation 6) with the 640×480 sensor depth, worked on at 800×600, gives the VGA pair's pose (5 %, 1°); the answer
// stays in the photo's pixels — the intrinsics as given, the saved matches across the whole photo — and says what it
// resampled; --verbose names the working size and each stage.
TEST(CliIntrinsics, PhonePhotosAreWorkedOnAtTheWorkingResolution) {
  freeloc::testing::TempDir tmp;
  const std::string s = freeloc::testing::DemoPath("val/s00003/");
  Pair p;
  p.ref = WriteJpeg(tmp, "ref4.jpg", Upscaled(freeloc::io::ReadImage(s + "seq0/frame_00000.png"), 4), 6);
  p.query = WriteJpeg(tmp, "query4.jpg", Upscaled(freeloc::io::ReadImage(s + "seq1/frame_00000.png"), 4), 6);
  p.ref_depth = s + "seq0/frame_00000.sensor.png";
  p.query_depth = s + "seq1/frame_00000.sensor.png";
  const std::string k1 = "535.4,539.2,320.1,247.6", k4 = "2141.6,2156.8,1281.9,991.9";
  const Pair vga{s + "seq0/frame_00000.png", s + "seq1/frame_00000.png", p.ref_depth, p.query_depth};
  const nlohmann::json want = Relocalize(vga, "--ref-intrinsics " + k1 + " --query-intrinsics " + k1);
  const nlohmann::json got = Relocalize(p, "--ref-intrinsics " + k4 + " --query-intrinsics " + k4 +
                                               " --max-side 800 --save-matches " + tmp.File("m.txt"));
  ASSERT_EQ(got["status"], "ok") << got.dump();
  const freeloc::Rigid3d a = PoseOf(got), b = PoseOf(want);
  EXPECT_LT((a.translation - b.translation).norm(), 0.05 * b.translation.norm());
  EXPECT_LT(RotationDeg(a, b), 1.0);
  EXPECT_DOUBLE_EQ(got["intrinsics"]["query"]["fx"].get<double>(), 2141.6);
  EXPECT_EQ(got["intrinsics"]["query"]["source"], "given");
  EXPECT_GT(got["decode_ms"].get<double>(), 0);
  EXPECT_GT(got["prepare_ms"].get<double>(), 0);
  ASSERT_EQ(got["inputs"].size(), 2u) << got.dump();
  EXPECT_EQ(got["inputs"][1], "query depth: resampled from 640x480 to 2560x1920");
  // The saved matches are photo pixels: they reach past the working size.
  double max_x = 0;
  for (const auto& row : freeloc::io::ReadCorrespondenceFile(tmp.File("m.txt"))) max_x = std::max(max_x, row(2));
  EXPECT_GT(max_x, 1600);
  EXPECT_LT(max_x, 2560);
  const Result v = RunFreeloc("-v relocalize --ref " + p.ref + " --query " + p.query + " --ref-intrinsics " + k4 +
                              " --query-intrinsics " + k4 + " --max-side 800");
  ExpectMentions(v.out, {"working at 800x600 for a 2560x1920 photo", "stage: query: matching", "times:       decode"});
}
