#include "freeloc/eval/report.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "testing/testing.h"

namespace freeloc::eval {
namespace {

EvalRun SmallRun() {
  EvalRun r;
  r.label = "method.zip";
  SceneRecord a;
  a.name = "s00460";
  a.file_present = true;
  a.frames = {{"s00460", 0, "submitted", {0.1, 2.0, 30.0}, 5},
              {"s00460", 5, "submitted", {1.0, 20.0, 300.0}, 1},
              {"s00460", 10, "missing", {}, 0}};
  a.failures = 1;
  SceneRecord b;
  b.name = "s00461";
  b.failures = 3;
  b.frames = {{"s00461", 0, "scene-missing", {}, 0},
              {"s00461", 1, "scene-missing", {}, 0},
              {"s00461", 2, "scene-missing", {}, 0}};
  r.scenes = {a, b};
  r.overall = Aggregate(r.scenes);
  r.per_scene.emplace_back("s00460", Aggregate({a}));
  return r;
}

TEST(Report, JsonHasOfficialKeysPerSceneAndCounts) {
  const EvalRun r = SmallRun();
  const auto j = nlohmann::json::parse(JsonReport(r));
  std::vector<std::string> keys;
  for (auto it = j.begin(); it != j.end(); ++it) keys.push_back(it.key());
  std::vector<std::string> expected(kMetricNames, kMetricNames + 8);
  expected.push_back("per_scene");
  expected.push_back("counts");
  std::sort(keys.begin(), keys.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(keys, expected);
  EXPECT_EQ(j["Estimates for % of frames"].get<double>(), 2.0 / 6);
  EXPECT_EQ(j["Precision @ Pose Error < (25.0cm, 5deg)"].get<double>(), 1.0 / 6);
  EXPECT_EQ(j["counts"]["failures"], 4);
  EXPECT_EQ(j["per_scene"]["s00461"]["pose_file"], false);
  EXPECT_EQ(j["per_scene"]["s00460"]["Average Median Translation Error"].get<double>(), 0.55);
}

TEST(Report, CsvMarkdownAndPlots) {
  const EvalRun r = SmallRun();
  const std::string csv = ErrorsCsv(r);
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "scene,frame,trans_err,rot_err,vcre,confidence,status");
  EXPECT_NE(csv.find("s00460,00000,0.1,2,30,5,submitted"), std::string::npos) << csv;
  EXPECT_NE(csv.find("s00460,00010,,,,,missing"), std::string::npos);
  EXPECT_NE(csv.find("s00461,00002,,,,,scene-missing"), std::string::npos);
  const std::string md = MarkdownReport(r);
  EXPECT_NE(md.find("| Average Median Translation Error | 0.5500 m |"), std::string::npos) << md;
  EXPECT_NE(md.find("| s00461 | 0 | 3 | no pose file"), std::string::npos) << md;
  const std::string cmp = MarkdownCompare({r, r});
  EXPECT_NE(cmp.find("| metric | method.zip | method.zip |"), std::string::npos) << cmp;
  testing::TempDir tmp;
  WriteReportDir(tmp.path() + "/rep", {&r});
  for (const char* f : {"metrics.json", "errors.csv", "cdf_translation.svg", "cdf_rotation.svg", "cdf_vcre.svg"}) {
    EXPECT_TRUE(std::filesystem::exists(tmp.path() + "/rep/" + f)) << f;
  }
  const std::string svg = testing::ReadText(tmp.path() + "/rep/cdf_translation.svg");
  EXPECT_EQ(svg.rfind("<svg xmlns=\"http://www.w3.org/2000/svg\"", 0), 0u);
  EXPECT_NE(svg.find("translation error [m]"), std::string::npos);
  EXPECT_NE(svg.find("fraction of evaluated frames"), std::string::npos);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

}  // namespace
}  // namespace freeloc::eval
