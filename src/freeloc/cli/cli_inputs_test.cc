// Plausible inputs through the command line (inputs/input_checks.h, docs/formats.md "Plausible inputs"): the
// mistakes people make first with well-formed files — depth in metres or centimetres, a transposed depth map,
// normalised or reordered intrinsics, the same photo twice, a missing depth map — on the bundled TUM pair s00003.
// Each is refused naming the input and the fix, answered with a status and a message, or answered right (within 5 %
// and 2° of the correct run); none is `ok` with a wrong pose.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_testing.h"
#include "freeloc/core/rigid3d.h"
#include "freeloc/io/mapfree.h"
#include "testing/testing.h"

namespace {

using freeloc::DepthMap;
using Json = nlohmann::json;

const std::string kK = "535.4,539.2,320.1,247.6";

std::string Scene() { return freeloc::testing::DemoPath("val/s00003"); }
std::string RefImage() { return Scene() + "/seq0/frame_00000.png"; }
std::string QueryImage() { return Scene() + "/seq1/frame_00000.png"; }
std::string RefDepth() { return Scene() + "/seq0/frame_00000.sensor.png"; }
std::string QueryDepth() { return Scene() + "/seq1/frame_00000.sensor.png"; }

// `relocalize --json` on s00003 with these depth files and intrinsics (and extra flags).
Result Relocalize(const std::string& ref_depth, const std::string& query_depth, const std::string& k_ref = kK,
                  const std::string& k_query = kK, const std::string& extra = "") {
  std::string args = "relocalize --ref " + RefImage() + " --query " + QueryImage() + " --ref-intrinsics " + k_ref +
                     " --query-intrinsics " + k_query + " --preset sift-essential --json " + extra;
  if (!ref_depth.empty()) args += " --ref-depth " + ref_depth;
  if (!query_depth.empty()) args += " --query-depth " + query_depth;
  return RunFreeloc(args);
}

// The sensor depth map stored as integers of `per_metre` per metre (1000: as it is; 1: metres; 100: cm).
std::string Restored(const freeloc::testing::TempDir& tmp, const std::string& src, double per_metre,
                     const std::string& name) {
  DepthMap d = freeloc::io::ReadDepthPng(src);
  for (float& v : d.data) v = static_cast<float>(std::round(v * per_metre) / 1000.0);
  const std::string path = tmp.File(name);
  freeloc::io::WriteDepthPng(path, d);
  return path;
}

freeloc::Rigid3d PoseOf(const Json& j) {
  const auto& q = j.at("qvec");
  const auto& t = j.at("tvec");
  return freeloc::Rigid3d(Eigen::Quaterniond(q[0], q[1], q[2], q[3]), Eigen::Vector3d(t[0], t[1], t[2]));
}

// The answer of the correct inputs.
const Json& Correct() {
  static const Json j = [] {
    const Result r = Relocalize(RefDepth(), QueryDepth());
    EXPECT_EQ(r.code, 0) << r.out;
    return Json::parse(r.out);
  }();
  return j;
}

// Right: ok within 5 % of the correct translation and 2° of its rotation.
void ExpectRight(const Result& r) {
  ASSERT_EQ(r.code, 0) << r.out;
  const Json j = Json::parse(r.out);
  ASSERT_EQ(j["status"], "ok") << r.out;
  const freeloc::Rigid3d got = PoseOf(j), want = PoseOf(Correct());
  EXPECT_LT((got.translation - want.translation).norm(), 0.05 * want.translation.norm()) << r.out;
  EXPECT_LT(freeloc::RotationAngleDeg(got.rotation, want.rotation), 2.0) << r.out;
}

TEST(CliInputs, DepthInTheWrongUnitIsRefusedWithTheFlagThatFixesIt) {
  ASSERT_EQ(Correct()["status"], "ok");
  freeloc::testing::TempDir tmp;
  const std::string rm = Restored(tmp, RefDepth(), 1, "ref_m.png"), qm = Restored(tmp, QueryDepth(), 1, "q_m.png");
  Result r = Relocalize(rm, qm);
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"ref_m.png", "metres stored as integers? set depth_unit=m", "[--depth-unit m]"});
  // Told the unit, it answers — never with a confidence above the correct run's for the integer-metre map.
  r = Relocalize(rm, qm, kK, kK, "--depth-unit m");
  if (r.code == 0 && Json::parse(r.out)["status"] == "ok")
    EXPECT_LT(Json::parse(r.out)["confidence"].get<double>(), 10 * Correct()["confidence"].get<double>());
  const std::string rc = Restored(tmp, RefDepth(), 100, "ref_cm.png"),
                    qc = Restored(tmp, QueryDepth(), 100, "q_cm.png");
  r = Relocalize(rc, qc);
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"ref_cm.png", "centimetres stored as integers? set depth_unit=cm", "[--depth-unit cm]"});
  ExpectRight(Relocalize(rc, qc, kK, kK, "--depth-unit cm"));
  // One map in centimetres, the other in millimetres: the centimetre one is named.
  r = Relocalize(RefDepth(), qc);
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"q_cm.png", "--depth-unit cm"});
}

TEST(CliInputs, DepthOfAnotherShapeIsResampledOrRefused) {
  freeloc::testing::TempDir tmp;
  // Transposed (the stored orientation of a photo turned by its EXIF looks the same): refused.
  const DepthMap q = freeloc::io::ReadDepthPng(QueryDepth());
  DepthMap t(q.height, q.width);
  for (int y = 0; y < q.height; ++y)
    for (int x = 0; x < q.width; ++x) t.at(y, x) = q.at(x, y);
  freeloc::io::WriteDepthPng(tmp.File("q_t.png"), t);
  Result r = Relocalize(RefDepth(), tmp.File("q_t.png"));
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"q_t.png", "480x640 but the photo is 640x480", "transposed",
                         "give the depth map in the photo's displayed orientation"});
  // A phone's depth resolution (a quarter of the photo's): resampled, right, noted, a lower confidence.
  DepthMap s(160, 120);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) s.at(x, y) = q.at(4 * x + 1, 4 * y + 1);
  freeloc::io::WriteDepthPng(tmp.File("q_small.png"), s);
  r = Relocalize(RefDepth(), tmp.File("q_small.png"));
  ExpectRight(r);
  const Json j = Json::parse(r.out);
  ASSERT_TRUE(j.contains("inputs")) << r.out;
  EXPECT_NE(j["inputs"][0].get<std::string>().find("query depth: resampled from 160x120 to 640x480"), std::string::npos)
      << r.out;
  EXPECT_LT(j["confidence"].get<double>(), Correct()["confidence"].get<double>());
}

TEST(CliInputs, IntrinsicsThatDoNotFitThePhotoAreRefusedWithTheFix) {
  Result r = Relocalize(RefDepth(), QueryDepth(), "0.836,0.842,0.5,0.5", kK);
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"reference intrinsics 0.836,0.842,0.5,0.5", "look normalised"});
  r = Relocalize(RefDepth(), QueryDepth(), kK, "320.1,247.6,535.4,539.2");
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"query intrinsics", "look like cx,cy,fx,fy: give fx,fy,cx,cy: 535.4,539.2,320.1,247.6"});
  r = Relocalize(RefDepth(), QueryDepth(), "535.4,320.1,539.2,247.6", "535.4,320.1,539.2,247.6");
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"look like fx,cx,fy,cy"});
  // An exotic lens: the bound loosened by --set, noted with the answer and its confidence lowered.
  r = Relocalize(RefDepth(), QueryDepth(), kK, kK, "--set focal_min=0.9");
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"below 0.9 × the long side", "--set focal_min="});
  r = Relocalize(RefDepth(), QueryDepth(), "535.4,539.2,680,247.6", kK, "--set principal_point_margin=0.1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("accepted only by a loosened bound"), std::string::npos) << r.out;
}

TEST(CliInputs, TheSamePhotoTwiceIsTheIdentityAndAMissingDepthIsNamed) {
  Result r = RunFreeloc("relocalize --ref " + RefImage() + " --query " + RefImage() + " --ref-intrinsics " + kK +
                        " --query-intrinsics " + kK + " --ref-depth " + RefDepth() + " --query-depth " + RefDepth() +
                        " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  Json j = Json::parse(r.out);
  EXPECT_EQ(j["status"], "ok");
  EXPECT_LT(PoseOf(j).translation.norm(), 1e-3) << r.out;
  EXPECT_NE(j["message"].get<std::string>().find("no parallax"), std::string::npos);
  // The record also gives the pose as COLMAP and hloc users read it (checked on the correct run's answer).
  const Json& c = Correct();
  const freeloc::Rigid3d p = PoseOf(c);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(c["centre"][k].get<double>(), p.Center()[k], 1e-12);
    EXPECT_NEAR(c["query_from_ref"][k][3].get<double>(), p.translation[k], 1e-12);
    EXPECT_NEAR(c["ref_from_query"][k][3].get<double>(), p.Center()[k], 1e-12);
    for (int l = 0; l < 3; ++l) {
      EXPECT_NEAR(c["query_from_ref"][k][l].get<double>(), p.R()(k, l), 1e-12);
      EXPECT_NEAR(c["ref_from_query"][k][l].get<double>(), p.R()(l, k), 1e-12);
    }
  }
  EXPECT_EQ(c["query_from_ref"][3], Json::array({0.0, 0.0, 0.0, 1.0}));
  // Without depth: a status and a message that says why.
  r = RunFreeloc("relocalize --ref " + RefImage() + " --query " + RefImage() + " --ref-intrinsics " + kK +
                 " --query-intrinsics " + kK);
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"degenerate", "no parallax", "give both depth maps"});
  // One depth map missing: the message names it, and the given intrinsics stay as given.
  r = Relocalize(RefDepth(), "", kK, kK, "--depth provided:sensor");
  EXPECT_EQ(r.code, 1) << r.out;
  j = Json::parse(r.out);
  EXPECT_EQ(j["status"], "no-depth");
  EXPECT_NE(j["message"].get<std::string>().find("no depth map for the query"), std::string::npos) << r.out;
  EXPECT_EQ(j["intrinsics"]["query"]["source"], "given") << r.out;
  EXPECT_DOUBLE_EQ(j["intrinsics"]["query"]["fx"].get<double>(), 535.4) << r.out;
}

// `run`: a scene whose depth maps are implausible fails alone (exit 3), naming the file and the fix.
TEST(CliInputs, ARunFailsTheSceneWithImplausibleDepthAlone) {
  freeloc::testing::TempDir tmp;
  namespace fs = std::filesystem;
  const std::string root = tmp.File("data");
  fs::create_directories(root + "/val");
  for (const char* s : {"s00002", "s00003"})
    fs::copy(freeloc::testing::DemoPath(std::string("val/") + s), root + "/val/" + s, fs::copy_options::recursive);
  for (const char* f : {"seq0/frame_00000.sensor.png", "seq1/frame_00000.sensor.png"}) {
    const std::string p = root + "/val/s00003/" + f;
    DepthMap d = freeloc::io::ReadDepthPng(p);
    for (float& v : d.data) v = std::round(v) / 1000.f;  // metres as integers
    freeloc::io::WriteDepthPng(p, d);
  }
  const Result r = RunFreeloc("run --data " + root + " --preset sift-essential --out " + tmp.File("sub.zip"));
  EXPECT_EQ(r.code, 3) << r.out;
  ExpectMentions(r.out, {"s00003", "set depth_unit=m"});
  EXPECT_TRUE(fs::exists(tmp.File("sub.zip")));
  EXPECT_FALSE(Contains(r.out, "s00002: ")) << r.out;
}

}  // namespace
