// Runs the `freeloc` binary and checks its output and exit codes (0 ok, 1 input error, 2 usage error).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli_testing.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/io/submission.h"
#include "freeloc/pipeline/options.h"
#include "testing/mapfree_writer.h"
#include "testing/pth_builder.h"
#include "testing/testing.h"

namespace {

TEST(Cli, HelpAndVersion) {
  Result h = RunFreeloc("--help");
  EXPECT_EQ(h.code, 0);
  ExpectMentions(h.out, {"inspect", "--threads", "--device"});
  Result v = RunFreeloc("--version");
  EXPECT_EQ(v.code, 0);
  EXPECT_TRUE(Contains(v.out, "freeloc 0.")) << v.out;
}

TEST(Cli, UsageErrorsExitTwo) {
  EXPECT_EQ(RunFreeloc("").code, 2);
  EXPECT_EQ(RunFreeloc("no-such-command").code, 2);
  EXPECT_EQ(RunFreeloc("--device tpu inspect x").code, 2);
  EXPECT_EQ(RunFreeloc("--threads 0 inspect x").code, 2);
  EXPECT_EQ(RunFreeloc("--quiet --verbose demo").code, 2);
  Result r = RunFreeloc("inspect");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(Contains(r.out, "FILE")) << r.out;
}

TEST(Cli, InputErrorsExitOneWithOneLine) {
  freeloc::testing::TempDir tmp;
  Result r = RunFreeloc("inspect " + tmp.File("missing.pth"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "missing.pth")) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  freeloc::testing::WriteText(tmp.File("junk.safetensors"), "this is not a checkpoint at all");
  r = RunFreeloc("inspect " + tmp.File("junk.safetensors"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "junk.safetensors")) << r.out;
}

TEST(Cli, InspectDust3rPth) {
  Result r = RunFreeloc("inspect " + freeloc::testing::TinyModelPath("dust3r_tiny.pth"));
  ASSERT_EQ(r.code, 0) << r.out;
  ExpectMentions(r.out, {"tensors:  745", "model constructor (args.model): AsymmetricCroCo3DStereo(pos_embed='RoPE100'",
                         "model.patch_embed.proj.weight", "float32  [64, 3, 16, 16]"});
}

TEST(Cli, InspectSafetensorsWithFilter) {
  Result r =
      RunFreeloc("inspect --filter decoder_pred.1 " + freeloc::testing::TinyModelPath("seggpt/model.safetensors"));
  ASSERT_EQ(r.code, 0) << r.out;
  ExpectMentions(r.out,
                 {"format:   safetensors", "decoder_pred.1.weight", "(2 of 354 tensors match 'decoder_pred.1')"});
}

// A perfect submission made from the GT of the real TUM scenes: zero errors, precision 1 (issue acceptance).
TEST(Cli, EvalPerfectSubmissionOnTumScenes) {
  freeloc::testing::TempDir tmp;
  std::map<std::string, std::vector<freeloc::io::SubmissionEntry>> sub;
  for (const char* s : {"s00001", "s00002", "s00003"}) {
    std::istringstream in(
        freeloc::testing::ReadText(freeloc::testing::DemoPath(std::string("val/") + s + "/poses.txt")));
    std::string l;
    while (std::getline(in, l)) {
      std::istringstream ls(l);
      std::string name;
      double q[4], t[3];
      ls >> name >> q[0] >> q[1] >> q[2] >> q[3] >> t[0] >> t[1] >> t[2];
      if (name.rfind("seq1/", 0) == 0)
        sub[s].push_back(
            {name, freeloc::Rigid3d::FromWxyz({q[0], q[1], q[2], q[3]}, Eigen::Vector3d(t[0], t[1], t[2])), 1});
    }
  }
  freeloc::io::WriteSubmission(tmp.File("gt.zip"), sub);
  const std::string data = freeloc::testing::DemoPath();
  Result r = RunFreeloc("eval --data " + data + " --split val --submission " + tmp.File("gt.zip") +
                        " --json - --report " + tmp.File("rep"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_LT(j["Average Median Translation Error"].get<double>(), 1e-9);
  EXPECT_LT(j["Average Median Reprojection Error"].get<double>(), 1e-6);
  EXPECT_EQ(j["Precision @ Pose Error < (25.0cm, 5deg)"].get<double>(), 1.0);
  EXPECT_EQ(j["Precision @ VCRE < 90px"].get<double>(), 1.0);
  EXPECT_EQ(j["counts"]["failures"], 0);
  EXPECT_TRUE(std::filesystem::exists(tmp.File("rep/cdf_vcre.svg")));
  // Markdown table on stdout; --data may point at the split folder.
  r = RunFreeloc("eval --data " + data + "/val --scenes s00002 --submission " + tmp.File("gt.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "| Precision @ VCRE < 90px | 1.0000 |")) << r.out;
  EXPECT_TRUE(Contains(r.out, "| s00002 | 1 | 0 |")) << r.out;
  // Bad input: not a ZIP, unknown scene, no submission → exit 1, 1, 2.
  freeloc::testing::WriteText(tmp.File("bad.zip"), "not a zip");
  r = RunFreeloc("eval --data " + data + " --submission " + tmp.File("bad.zip"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "bad.zip: not a ZIP file")) << r.out;
  EXPECT_EQ(RunFreeloc("eval --data " + data + " --scenes s09999 --submission " + tmp.File("gt.zip")).code, 1);
  EXPECT_EQ(RunFreeloc("eval --data " + data).code, 2);
  EXPECT_EQ(RunFreeloc("eval --data " + tmp.File("nowhere") + " --submission " + tmp.File("gt.zip")).code, 1);
}

// `freeloc pose` on the committed SIFT correspondences of the real TUM pair s00003 with its sensor depth.
TEST(Cli, PoseFromCorrespondenceFile) {
  const std::string scene = freeloc::testing::DemoPath("val/s00003");
  const std::string matches = freeloc::testing::SourceDir() + "/tests/data/tum_sift/s00003_sift_matches.txt";
  const std::string k = "535.4,539.2,320.1,247.6";
  const std::string base = "pose --matches " + matches + " --ref-intrinsics " + k + " --query-intrinsics " + k;
  Result r = RunFreeloc(base + " --ref-depth " + scene + "/seq0/frame_00000.sensor.png --query-depth " + scene +
                        "/seq1/frame_00000.sensor.png --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["status"], "ok");
  const freeloc::Rigid3d est = freeloc::Rigid3d::FromWxyz({j["qvec"][0], j["qvec"][1], j["qvec"][2], j["qvec"][3]},
                                                          Eigen::Vector3d(j["tvec"][0], j["tvec"][1], j["tvec"][2]));
  // GT of s00003 (poses.txt): compare rotation and camera centre.
  std::istringstream gt(freeloc::testing::ReadText(scene + "/poses.txt"));
  std::string l, name;
  double q[4], t[3];
  while (std::getline(gt, l)) {
    std::istringstream ls(l);
    ls >> name >> q[0] >> q[1] >> q[2] >> q[3] >> t[0] >> t[1] >> t[2];
    if (name.rfind("seq1/", 0) == 0) break;
  }
  const freeloc::Rigid3d truth =
      freeloc::Rigid3d::FromWxyz({q[0], q[1], q[2], q[3]}, Eigen::Vector3d(t[0], t[1], t[2]));
  EXPECT_LT(freeloc::RotationAngleDeg(est.rotation, truth.rotation), 0.5);
  EXPECT_LT((est.Center() - truth.Center()).norm(), 0.02);
  EXPECT_GT(j["inliers"].get<int>(), 300);
  // Without depth: unit translation, and the text output says so.
  r = RunFreeloc(base);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "unit norm: no depth given")) << r.out;
  // PnP and Procrustes run on the same data.
  r = RunFreeloc(base + " --solver pnp --ref-depth " + scene + "/seq0/frame_00000.sensor.png --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["status"], "ok");
  // Bad input: a NaN row, too few fields, missing file, bad intrinsics.
  freeloc::testing::TempDir tmp;
  freeloc::testing::WriteText(tmp.File("m.txt"), "1 2 3 4\n5 nan 7 8\n");
  r = RunFreeloc("pose --matches " + tmp.File("m.txt") + " --ref-intrinsics " + k + " --query-intrinsics " + k);
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "m.txt line 2: non-finite coordinate")) << r.out;
  freeloc::testing::WriteText(tmp.File("m3.txt"), "1 2 3\n");
  EXPECT_EQ(
      RunFreeloc("pose --matches " + tmp.File("m3.txt") + " --ref-intrinsics " + k + " --query-intrinsics " + k).code,
      1);
  EXPECT_EQ(RunFreeloc("pose --matches " + matches + " --ref-intrinsics 1,2,3 --query-intrinsics " + k).code, 1);
  // A depth map of another resolution (320x240 for 640x480 matches) is an error, not a metric scale 2x off.
  freeloc::io::WriteDepthPng(tmp.File("small_depth.png"), freeloc::DepthMap(320, 240));
  r = RunFreeloc(base + " --ref-depth " + tmp.File("small_depth.png") + " --query-depth " + scene +
                 "/seq1/frame_00000.sensor.png");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "reference depth: the map is 320x240 but")) << r.out;
  EXPECT_TRUE(Contains(r.out, "give the depth map at its image's resolution")) << r.out;
  // An 8-bit PNG is not a depth map.
  freeloc::io::WritePng8(tmp.File("d8.png"), 640, 480, std::vector<uint8_t>(640 * 480, 3));
  r = RunFreeloc(base + " --ref-depth " + tmp.File("d8.png") + " --query-depth " + scene +
                 "/seq1/frame_00000.sensor.png");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "8-bit PNG is not a depth map")) << r.out;
  // Four matches: a status (too-few-matches), exit 1, no crash.
  freeloc::testing::WriteText(tmp.File("m4.txt"), "1 2 3 4\n5 6 7 8\n9 10 11 12\n13 14 15 16\n");
  r = RunFreeloc("pose --matches " + tmp.File("m4.txt") + " --ref-intrinsics " + k + " --query-intrinsics " + k);
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "too-few-matches")) << r.out;
}

// `freeloc relocalize --json` on the first TUM pair of s00003, with its sensor depth.
Result RelocalizeS00003(const std::string& data, const std::string& extra = "") {
  const std::string s = data + "/val/s00003/";
  return RunFreeloc("relocalize --ref " + s + "seq0/frame_00000.png --query " + s +
                    "seq1/frame_00000.png --ref-intrinsics 535.4,539.2,320.1,247.6 --query-intrinsics "
                    "535.4,539.2,320.1,247.6 --ref-depth " +
                    s + "seq0/frame_00000.sensor.png --query-depth " + s + "seq1/frame_00000.sensor.png --json" +
                    extra);
}

// `freeloc pointmap` (with --matches) and `freeloc match` (with instance label masks) on real TUM photos with the
// tiny fixture weights: the numbers are meaningless, the path is real.
TEST(Cli, PointmapAndMatchOnRealPhotos) {
  freeloc::testing::TempDir tmp;
  const std::string model = freeloc::testing::TinyModelPath("dust3r_tiny.pth");
  const std::string s = freeloc::testing::DemoPath("val/s00003");
  const std::string pair = s + "/seq0/frame_00000.png " + s + "/seq1/frame_00000.png";
  Result r = RunFreeloc("pointmap --model " + model + " --size 224,128 " + pair + " --out " +
                        tmp.File("pm.safetensors") + " --matches --conf-thr 1.2");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto f = freeloc::io::SafetensorsFile::Open(tmp.File("pm.safetensors"));
  EXPECT_EQ(f.Get("pts3d_1").shape, (std::vector<int64_t>{224, 224, 3}));
  EXPECT_EQ(f.Get("pts3d_2").shape, (std::vector<int64_t>{96, 128, 3}));
  EXPECT_EQ(f.Get("conf_2").shape, (std::vector<int64_t>{96, 128}));
  EXPECT_EQ(f.Get("image_1").dtype, freeloc::io::DType::kU8);
  EXPECT_EQ(f.Get("matches").shape.at(1), 4);
  EXPECT_EQ(f.Get("matches_orig").shape, f.Get("matches").shape);
  EXPECT_EQ(f.metadata.at("size"), "224,128");
  EXPECT_TRUE(Contains(f.metadata.at("timings"), "decode_ms")) << f.metadata.at("timings");
  // Instance labels: one object (label 1) in both images, plus one label only in the reference (ignored).
  std::vector<uint16_t> lr(640 * 480, 0), lq(640 * 480, 0);
  for (int y = 100; y < 380; ++y)
    for (int x = 150; x < 500; ++x) lr[y * 640 + x] = lq[y * 640 + x] = 1;
  lr[0] = 2;
  freeloc::io::WritePng16(tmp.File("lr.png"), 640, 480, lr);
  freeloc::io::WritePng16(tmp.File("lq.png"), 640, 480, lq);
  r = RunFreeloc("match --model " + model + " --size 224 " + pair + " --ref-masks " + tmp.File("lr.png") +
                 " --query-masks " + tmp.File("lq.png") + " --out " + tmp.File("m.txt"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "of 1 instances used")) << r.out;
  const std::string text = freeloc::testing::ReadText(tmp.File("m.txt"));
  EXPECT_GT(std::count(text.begin(), text.end(), '\n'), 10);
  // The matches file feeds `freeloc pose` directly.
  r = RunFreeloc("pose --matches " + tmp.File("m.txt") +
                 " --ref-intrinsics 535.4,539.2,320.1,247.6 --query-intrinsics 535.4,539.2,320.1,247.6 --json");
  // Random weights: the pose may or may not be solved; the exit code says which (0 solved, 1 not).
  const nlohmann::json pj = nlohmann::json::parse(r.out);
  EXPECT_EQ(r.code, pj["solved"].get<bool>() ? 0 : 1) << r.out;
  EXPECT_EQ(pj["qvec"].size(), 4u) << r.out;
  // The pipeline's dust3r matcher gives the same global matches as `freeloc match` without masks.
  r = RunFreeloc("match --model " + model + " --size 224 " + pair + " --out " + tmp.File("g.txt"));
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string g = freeloc::testing::ReadText(tmp.File("g.txt"));
  r = RelocalizeS00003(freeloc::testing::DemoPath(), " --preset dust3r --dust3r-size 224 --dust3r-model " + model);
  // (Random weights also give a focal far from the given one: the intrinsics check's warning comes first.)
  EXPECT_TRUE(Contains(r.out, "differs from the pointmap's estimate")) << r.out;
  const nlohmann::json rj = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  EXPECT_EQ(r.code, rj["solved"].get<bool>() ? 0 : 1)
      << r.out;  // random weights: the pose may well fail; the code says
  EXPECT_EQ(rj["matches"], std::count(g.begin(), g.end(), '\n')) << r.out;
  r = RelocalizeS00003(freeloc::testing::DemoPath(), " --preset dust3r");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out,
                       "preset dust3r needs the DUSt3R weights: looked for "
                       "DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth"))
      << r.out;
  // A whole scene through `run` loads the model once and writes a submission.
  r = RunFreeloc("run --data " + freeloc::testing::DemoPath() +
                 " --scenes s00003 --preset dust3r --dust3r-size 224 --dust3r-model " + model + " --out " +
                 tmp.File("d.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "in 1 scene,")) << r.out;
  EXPECT_TRUE(std::filesystem::exists(tmp.File("d.zip")));
  // A weights file that is not there stops the run before any scene: exit 1, no submission, no progress file.
  r = RunFreeloc("run --data " + freeloc::testing::DemoPath() + " --scenes s00003 --preset dust3r --dust3r-model " +
                 tmp.File("nope.pth") + " --out " + tmp.File("e.zip"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "nope.pth: cannot open the checkpoint")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.File("e.zip")));
  EXPECT_FALSE(std::filesystem::exists(tmp.File("e.zip.progress.jsonl")));
  // Masks of the wrong size: a clear error.
  freeloc::io::WritePng16(tmp.File("small.png"), 10, 10, std::vector<uint16_t>(100, 1));
  r = RunFreeloc("match --model " + model + " --size 224 " + pair + " --ref-masks " + tmp.File("small.png") +
                 " --query-masks " + tmp.File("lq.png") + " --out " + tmp.File("m2.txt"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "small.png: the label image is 10x10 but its photo is 640x480")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.File("m2.txt")));
  // Bad model file.
  r = RunFreeloc("pointmap --model " + tmp.File("lr.png") + " " + pair + " --out " + tmp.File("x.safetensors"));
  EXPECT_EQ(r.code, 1);
}

TEST(Cli, SegmentWritesTheMaskAndRawOutput) {
  // freeloc's own tiny SegGPT (written by the build) with two prompts (the feature ensemble) on bundled TUM frames:
  // the file plumbing of the command (SegGPT's masks against the reference's: SegGpt.FromPngsToTheBinaryMask).
  freeloc::testing::TempDir tmp;
  const std::string d = tmp.File("") + "/";
  namespace fs = std::filesystem;
  fs::copy_file(freeloc::testing::DemoPath("val/s00001/seq0/frame_00000.png"), d + "prompt_image_0.png");
  fs::copy_file(freeloc::testing::DemoPath("val/s00002/seq0/frame_00000.png"), d + "prompt_image_1.png");
  fs::copy_file(freeloc::testing::DemoPath("val/s00001/seq1/frame_00000.png"), d + "target_image.png");
  for (int k = 0; k < 2; ++k) {
    freeloc::Image mask(640, 480);
    for (int y = 100 + 40 * k; y < 300; ++y)
      for (int x = 150; x < 420 - 60 * k; ++x)
        for (int c = 0; c < 3; ++c) mask.pixel(x, y)[c] = 255;
    freeloc::io::WriteImagePng(d + "prompt_mask_" + std::to_string(k) + ".png", mask);
  }
  const std::string model = "--model " + freeloc::testing::TinyModelPath("seggpt/model.safetensors") + " --config " +
                            freeloc::testing::TinyModelPath("seggpt/config.json");
  Result r = RunFreeloc("segment " + model + " --prompt-image " + d + "prompt_image_0.png --prompt-mask " + d +
                        "prompt_mask_0.png --prompt-image " + d + "prompt_image_1.png --prompt-mask " + d +
                        "prompt_mask_1.png --target " + d + "target_image.png --out " + tmp.File("m.png") + " --raw " +
                        tmp.File("raw.safetensors"));
  ASSERT_EQ(r.code, 0) << r.out;
  const freeloc::Image got = freeloc::io::ReadImage(tmp.File("m.png"));
  ASSERT_EQ(got.width, 640);  // the target's size
  ASSERT_EQ(got.height, 480);
  for (size_t i = 0; i < got.data.size(); ++i) ASSERT_TRUE(got.data[i] == 0 || got.data[i] == 255) << i;
  const auto raw = freeloc::io::SafetensorsFile::Open(tmp.File("raw.safetensors"));
  EXPECT_EQ(raw.Get("pred").shape, (std::vector<int64_t>{3, 64, 64}));
  // Mismatched prompt lists and a missing target: exit 1 with a message.
  r = RunFreeloc("segment " + model + " --prompt-image " + d + "prompt_image_0.png --prompt-mask " + d +
                 "prompt_mask_0.png --prompt-image " + d + "prompt_image_1.png --target " + d +
                 "target_image.png --out " + tmp.File("x.png"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "one --prompt-mask per --prompt-image")) << r.out;
  r = RunFreeloc("segment " + model + " --prompt-image " + d + "prompt_image_0.png --prompt-mask " + d +
                 "prompt_mask_0.png --target " + tmp.File("nope.png") + " --out " + tmp.File("y.png"));
  EXPECT_EQ(r.code, 1);
  EXPECT_FALSE(std::filesystem::exists(tmp.File("y.png")));
}

// `freeloc depth` on real frames (a bundled TUM frame, and a KITTI-shaped wide cut of it) with a tiny model (numbers
// meaningless, the path real): valid PNGs at the image's size and the raw outputs.
TEST(Cli, DepthOnRealFrames) {
  freeloc::testing::TempDir tmp;
  const std::string dir = freeloc::testing::TinyModelPath("metric3d/");  // freeloc's own tiny model (the build's)
  const std::string model = "--model " + dir + "model.safetensors --config " + dir + "config.json";
  // A bundled TUM frame, and a wide 1242×375 one cut and scaled from it (KITTI's shape).
  const freeloc::Image tum = freeloc::io::ReadImage(freeloc::testing::DemoPath("val/s00003/seq0/frame_00000.png"));
  freeloc::Image wide(1242, 375);
  for (int y = 0; y < 375; ++y)
    for (int x = 0; x < 1242; ++x)
      for (int c = 0; c < 3; ++c) wide.pixel(x, y)[c] = tum.at(x * 640 / 1242, 100 + y * 200 / 375, c);
  freeloc::io::WriteImagePng(tmp.File("wide.png"), wide);
  struct Frame {
    std::string image, k;
    int w, h;
  };
  const Frame frames[] = {
      {freeloc::testing::DemoPath("val/s00003/seq0/frame_00000.png"), "535.4,539.2,320.1,247.6", 640, 480},
      {tmp.File("wide.png"), "707.0493,707.0493,604.0814,180.5066", 1242, 375}};
  for (const Frame& f : frames) {
    Result r = RunFreeloc("depth " + model + " --image " + f.image + " --intrinsics " + f.k + " --out " +
                          tmp.File("d.png") + " --raw " + tmp.File("d.safetensors"));
    ASSERT_EQ(r.code, 0) << r.out;
    int w, h;
    const auto mm = freeloc::io::ReadPng16(tmp.File("d.png"), &w, &h);
    EXPECT_EQ(w, f.w);
    EXPECT_EQ(h, f.h);
    size_t valid = 0;
    for (uint16_t v : mm) valid += v > 0;
    EXPECT_GT(valid, mm.size() / 2);
    const auto raw = freeloc::io::SafetensorsFile::Open(tmp.File("d.safetensors"));
    EXPECT_EQ(raw.Get("depth").shape, (std::vector<int64_t>{f.h, f.w}));
    EXPECT_EQ(raw.Get("normal").shape, (std::vector<int64_t>{3, f.h, f.w}));
    EXPECT_EQ(raw.Get("canonical_depth").shape, (std::vector<int64_t>{112, 196}));
    EXPECT_EQ(raw.metadata.at("variant"), "custom");
  }
  // Bad intrinsics and a missing image: exit 1, no output written.
  Result r =
      RunFreeloc("depth " + model + " --image " + frames[0].image + " --intrinsics 0,1,2,3 --out " + tmp.File("x.png"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "--intrinsics")) << r.out;
  r = RunFreeloc("depth " + model + " --image " + tmp.File("none.jpg") + " --intrinsics 1,1,1,1 --out " +
                 tmp.File("y.png"));
  EXPECT_EQ(r.code, 1);
  EXPECT_FALSE(std::filesystem::exists(tmp.File("y.png")));
}

// The same correspondences and depth give the same pose, status and confidence from `freeloc pose` and `freeloc
// run`: two synthetic scenes with precomputed correspondences and provided depth, run with
// --save-matches; each query's saved correspondences through `pose --preset <the run's preset>` reproduce the log's
// record to the last bit, failures included.
TEST(Cli, PoseAndRunAgreeOnTheSameCorrespondences) {
  freeloc::testing::TempDir tmp;
  for (uint32_t s : {1u, 2u})
    freeloc::testing::WriteSyntheticMapfreeScene(tmp.File("data/val/s0000" + std::to_string(s)), 40 + s);
  const std::string preset = "precomputed:SIFT-essential";
  Result r = RunFreeloc("run --data " + tmp.File("data") + " --preset " + preset + " --depth provided:gt --out " +
                        tmp.File("s.zip") + " --log " + tmp.File("log.jsonl") + " --save-matches " + tmp.File("m"));
  ASSERT_EQ(r.code, 0) << r.out;
  std::istringstream log(freeloc::testing::ReadText(tmp.File("log.jsonl")));
  std::string line;
  std::getline(log, line);  // the header
  int compared = 0, ok = 0;
  while (std::getline(log, line)) {
    const auto rec = nlohmann::json::parse(line);
    const std::string scene = rec["scene"], frame = rec["frame"];
    SCOPED_TRACE(scene + "/" + frame);
    const freeloc::io::MapfreeScene sc = freeloc::io::MapfreeScene::Load(tmp.File("data/val/" + scene));
    const freeloc::io::MapfreeFrame* q = nullptr;
    for (const auto& f : sc.queries)
      if (f.name == frame) q = &f;
    ASSERT_NE(q, nullptr);
    auto k = [](const freeloc::Camera& c) {
      char b[160];
      std::snprintf(b, sizeof(b), "%.17g,%.17g,%.17g,%.17g", c.fx, c.fy, c.cx, c.cy);
      return std::string(b);
    };
    const std::string stem = frame.substr(0, frame.size() - 4);
    const Result p = RunFreeloc("pose --preset " + preset + " --matches " + tmp.File("m/" + scene + "/" + stem) +
                                ".matches.txt --ref-intrinsics " + k(sc.reference.camera) + " --query-intrinsics " +
                                k(q->camera) + " --ref-depth " + sc.DepthPath(sc.reference, "gt") + " --query-depth " +
                                sc.DepthPath(*q, "gt") + " --json");
    const auto j = nlohmann::json::parse(p.out);
    EXPECT_EQ(p.code, rec["solved"].get<bool>() ? 0 : 1) << p.out;  // the run's query solved ⇔ pose exits 0
    EXPECT_EQ(j["status"], rec["status"]);
    auto rel = [](double a, double b) {
      return std::abs(a - b) / std::max(1e-300, std::max(std::abs(a), std::abs(b)));
    };
    EXPECT_LE(rel(j["confidence"], rec["confidence"]), 1e-9);
    for (int i = 0; i < 4; ++i) EXPECT_LE(rel(j["qvec"][i], rec["qvec"][i]), 1e-9) << i;
    for (int i = 0; i < 3; ++i) EXPECT_LE(rel(j["tvec"][i], rec["tvec"][i]), 1e-9) << i;
    EXPECT_EQ(j["inliers"], rec["inliers"]);
    EXPECT_EQ(j["options"]["threshold_px"], 3.0);
    // pose's defaults are this preset's: the same answer with no flags beyond the inputs.
    const Result d =
        RunFreeloc("pose --matches " + tmp.File("m/" + scene + "/" + stem) + ".matches.txt " + "--ref-intrinsics " +
                   k(sc.reference.camera) + " --query-intrinsics " + k(q->camera) + " --ref-depth " +
                   sc.DepthPath(sc.reference, "gt") + " --query-depth " + sc.DepthPath(*q, "gt") + " --json");
    const auto jd = nlohmann::json::parse(d.out);
    EXPECT_EQ(jd["status"], rec["status"]);
    EXPECT_EQ(jd["tvec"], j["tvec"]);
    EXPECT_EQ(jd["confidence"], j["confidence"]);
    ++compared;
    ok += rec["status"] == "ok";
  }
  EXPECT_EQ(compared, 8);
  EXPECT_GE(ok, 4);  // the comparison covers real answers, not only failures
}

// Provenance: the log's first line and the sidecar <out>.json hold the version and every resolved option;
// relocalize --json and pose --json carry the options too.
TEST(Cli, RunRecordsItsProvenance) {
  freeloc::testing::TempDir tmp;
  const std::string data = freeloc::testing::DemoPath();
  Result r = RunFreeloc("--threads 1 run --data " + data +
                        " --scenes s00002 --solver essential --set "
                        "proposals.max_instances=3 --out " +
                        tmp.File("s.zip") + " --log " + tmp.File("l.jsonl"));
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string log = freeloc::testing::ReadText(tmp.File("l.jsonl"));
  const auto header = nlohmann::json::parse(log.substr(0, log.find('\n')));
  const auto sidecar = nlohmann::json::parse(freeloc::testing::ReadText(tmp.File("s.zip.json")));
  for (const auto& h : {header, sidecar}) {
    EXPECT_TRUE(Contains(h["freeloc_version"].get<std::string>(), "0.")) << h.dump();
    EXPECT_EQ(h["options"]["preset"], "sift-essential");
    EXPECT_EQ(h["options"]["depth"], "provided:sensor");
    EXPECT_EQ(h["options"]["threads"], 1);
    EXPECT_EQ(h["options"]["proposals.max_instances"], 3);
    EXPECT_EQ(h["split"], "val");
    EXPECT_EQ(h["scenes"], nlohmann::json::array({"s00002"}));
    EXPECT_TRUE(h["shard"].is_null());
  }
  EXPECT_EQ(sidecar["summary"]["queries"], 1);
  r = RelocalizeS00003(data);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["options"]["matcher"], "sift");
  // Bad option values name the flag and the choices; unknown --set fields list the options.
  r = RunFreeloc("run --data " + data + " --solver ransac --out " + tmp.File("x.zip"));
  EXPECT_EQ(r.code, 2);  // a value outside the flag's own choices: a usage error
  EXPECT_TRUE(Contains(r.out, "--solver: 'ransac' is not one of essential, pnp, procrustes")) << r.out;
  r = RunFreeloc("run --data " + data + " --set colour=red --out " + tmp.File("x.zip"));
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(Contains(r.out, "colour: not an option; the options are preset, matcher")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.File("x.zip")));
}

// `run --report`: a static folder with every query in the table, detail views (JPEG) for the first query of each
// scene, the failures and the worst, every referenced file present, nothing from the network; bounded by the
// options (unselected detail images are deleted).
TEST(Cli, RunWritesAnHtmlReport) {
  freeloc::testing::TempDir tmp;
  Result r = RunFreeloc("-q run --data " + freeloc::testing::DemoPath() + " --out " + tmp.File("s.zip") + " --report " +
                        tmp.File("rep"));
  ASSERT_EQ(r.code, 0) << r.out;
  // The run's words (pipeline/query_result.h): 2 of the 7 queries solved, all 7 submitted (s00001's with the prior).
  EXPECT_TRUE(Contains(freeloc::testing::ReadText(tmp.File("rep") + "/index.html"),
                       "7 queries: 2 solved (status ok), 7 submitted"));
  auto check = [&](const std::string& dir, int rows, int details) {
    const std::string html = freeloc::testing::ReadText(dir + "/index.html");
    size_t n = 0;
    for (size_t p = 0; (p = html.find("<tr class=\"", p)) != std::string::npos; ++p) ++n;
    EXPECT_EQ(n, static_cast<size_t>(rows)) << dir;
    int jpgs = 0;
    for (size_t p = 0; (p = html.find("src=\"", p)) != std::string::npos;) {
      p += 5;
      const std::string src = html.substr(p, html.find('"', p) - p);
      EXPECT_TRUE(std::filesystem::exists(dir + "/" + src)) << src;
      EXPECT_EQ(src.find("http"), std::string::npos) << src;
      jpgs += src.size() > 4 && src.substr(src.size() - 4) == ".jpg";
    }
    EXPECT_EQ(jpgs, details) << dir;
    int files = 0, views = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      files += e.path().extension() == ".jpg";
      views += e.path().string().size() > 9 && e.path().string().substr(e.path().string().size() - 9) == "jpg.3d.js";
    }
    EXPECT_EQ(files, details) << "unselected detail images must be removed";
    // Each detail view has its 3D view: the data beside it, a button, and the view's script (three.js copied when
    // libjs-three is installed).
    EXPECT_EQ(views, details) << "a 3D view per detail view, the unselected ones removed";
    size_t buttons = 0;
    for (size_t p = 0; (p = html.find(">3D view</button>", p)) != std::string::npos; ++p) ++buttons;
    EXPECT_EQ(buttons, static_cast<size_t>(details));
    EXPECT_TRUE(std::filesystem::exists(dir + "/view3d.js"));
    if (std::filesystem::exists("/usr/share/javascript/three/build/three.min.js")) {
      EXPECT_TRUE(std::filesystem::exists(dir + "/three.min.js"));
    }
    return html;
  };
  const std::string html = check(tmp.File("rep"), 7, 7);  // 3 first-of-scene + failures (s00001's no-depth)
  EXPECT_TRUE(Contains(html, "Average Median Translation Error")) << "metrics";
  EXPECT_TRUE(Contains(html, "<h3>no-depth (5)</h3>")) << "failures grouped by status";
  EXPECT_TRUE(Contains(html, "cdf_translation.svg"));
  // Synthetic scenes with ground truth: 2 scenes × 4 queries; no first-of-scene sample, the 2 worst answered
  // queries and at most 1 failure in detail.
  for (uint32_t s : {1u, 2u})
    freeloc::testing::WriteSyntheticMapfreeScene(tmp.File("syn/val/s0000" + std::to_string(s)), 70 + s);
  r = RunFreeloc("-q run --data " + tmp.File("syn") +
                 " --preset precomputed:SIFT-essential --depth provided:gt --out " + tmp.File("t.zip") + " --report " +
                 tmp.File("rep2") + " --report-worst 2 --report-per-scene 0");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string h2 = check(tmp.File("rep2"), 8, 2 + 2);  // the 2 worst + both too-few-matches failures
  EXPECT_TRUE(Contains(h2, "too-few-matches (2)")) << h2.substr(0, 2000);
}

// A models folder laid out with the published file names, here symlinks to the tiny fixture weights (the
// Metric3D fixture is safetensors under the .pth name: checkpoints are recognised by content; its config.json
// sits beside it).
void LinkTinyModels(const freeloc::testing::TempDir& dir) {
  namespace fs = std::filesystem;
  fs::create_symlink(freeloc::testing::TinyModelPath("dust3r_tiny.pth"),
                     dir.File("DUSt3R_ViTLarge_BaseDecoder_512_dpt.pth"));
  fs::create_directories(dir.File("seggpt-vit-large"));
  fs::create_symlink(freeloc::testing::TinyModelPath("seggpt/model.safetensors"),
                     dir.File("seggpt-vit-large/model.safetensors"));
  fs::create_symlink(freeloc::testing::TinyModelPath("seggpt/config.json"), dir.File("seggpt-vit-large/config.json"));
  fs::create_symlink(freeloc::testing::TinyModelPath("metric3d/model.safetensors"),
                     dir.File("metric_depth_vit_small_800k.pth"));
  fs::create_symlink(freeloc::testing::TinyModelPath("metric3d/config.json"), dir.File("config.json"));
}

TEST(Cli, DemoRelocalizesTheBundledScenes) {
  Result r = RunFreeloc("demo");
  ASSERT_EQ(r.code, 0) << r.out;
  ExpectMentions(r.out,
                 {"preset sift-essential", "| s00002 | seq1/frame_00000.png | ok |", "| Estimates for % of frames |",
                  "not found: DUSt3R SegGPT Metric3D", "--models DIR or set FREELOC_MODELS"});
  // The closing note says what happened to the depth-less scene, as the table shows it (an estimate, no failure).
  EXPECT_TRUE(Contains(r.out, "| s00001 | 1 | 0 |")) << r.out;
  EXPECT_TRUE(Contains(r.out,
                       "(s00001 has no depth maps: its 5 queries got no metric pose (status no-depth) and were "
                       "submitted with the prior pose"))
      << r.out;
  EXPECT_FALSE(Contains(r.out, "count as failures")) << r.out;
}

// With all three networks' weights found in a models folder, demo runs the full method (preset seed).
TEST(Cli, DemoRunsTheSeedPresetWhenTheWeightsAreInstalled) {
  freeloc::testing::TempDir models;
  LinkTinyModels(models);
  Result r = RunFreeloc("demo --models " + models.path());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "preset seed on the bundled")) << r.out;
  EXPECT_TRUE(Contains(r.out, "matcher dust3r+instances, depth metric3d")) << r.out;
  EXPECT_TRUE(Contains(r.out, models.File("metric_depth_vit_small_800k.pth"))) << r.out;
  // Random test weights match nothing: every query must say so (never a confident pose from garbage matches).
  EXPECT_TRUE(Contains(r.out, "| s00003 | seq1/frame_00000.png | no-consensus |")) << r.out;
  EXPECT_TRUE(Contains(r.out, "no metrics to report")) << r.out;
  EXPECT_FALSE(Contains(r.out, "no-depth")) << r.out;  // Metric3D gives s00001 its depth
}

// The seed preset through `run` with the tiny weights of all three networks: models found through
// $FREELOC_MODELS, the log's per-stage fields, a killed run resumed to the same bytes.
TEST(Cli, SeedRunWithTinyWeightsLogsStagesAndResumes) {
  freeloc::testing::TempDir models, tmp;
  LinkTinyModels(models);
  const std::string data = freeloc::testing::DemoPath();
  const std::string run = "run --data " + data + " --scenes s00001,s00003 --preset seed --dust3r-size 224 ";
  // Without weights: the missing file, where to get it, the presets that work; exit 1 and nothing written.
  Result r = RunFreeloc(run + "--out " + tmp.File("none.zip"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "docs/models.md")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.File("none.zip")));
  const std::string env = "FREELOC_MODELS=" + models.path();
  auto Run = [&](const std::string& args) { return RunFreeloc(args, env); };
  r = Run(run + "--out " + tmp.File("a.zip") + " --log " + tmp.File("a.jsonl"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "in 2 scenes")) << r.out;
  const std::string log = freeloc::testing::ReadText(tmp.File("a.jsonl"));
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1 + 6);
  for (const char* field : {"\"global_matches\":", "\"instances\":", "\"depth_ms\":", "\"instance_ms\":"})
    EXPECT_TRUE(Contains(log, field)) << field << "\n" << log;
  EXPECT_FALSE(Contains(log, "no-depth")) << log;
  // Killed (SIGKILL) while the second scene runs: the progress file holds the first; --resume finishes the run
  // and writes the same bytes as the uninterrupted one.
  const std::string out = tmp.File("b.zip"), progress = out + ".progress.jsonl";
  const std::string kill_script = "bash -c 'env " + env + " " + FREELOC_BINARY + " " + run + "--out " + out +
                                  " >/dev/null 2>&1 & pid=$!; " + "for i in $(seq 1 1200); do [ -f " + progress +
                                  " ] && [ \"$(wc -l < " + progress +
                                  ")\" -ge 2 ] && break; sleep 0.025; done; kill -9 $pid; wait $pid' 2>/dev/null";
  ASSERT_NE(std::system(kill_script.c_str()), -1);
  ASSERT_FALSE(std::filesystem::exists(out)) << "the run finished before the kill; the test proves nothing";
  const std::string kept = freeloc::testing::ReadText(progress);
  ASSERT_TRUE(Contains(kept, "\"scene\":\"s00001\"")) << kept;
  EXPECT_FALSE(Contains(kept, "\"scene\":\"s00003\"")) << kept;
  r = Run(run + "--resume --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "1 of 2 scenes already done")) << r.out;
  EXPECT_EQ(freeloc::testing::ReadText(out), freeloc::testing::ReadText(tmp.File("a.zip")));
  EXPECT_FALSE(std::filesystem::exists(progress));
}

// run → submission → eval, and relocalize on one pair; bad presets and missing files are clear errors.
TEST(Cli, RunThenEvalAndRelocalize) {
  freeloc::testing::TempDir tmp;
  const std::string data = freeloc::testing::DemoPath();
  Result r = RunFreeloc("run --data " + data + " --preset sift-essential --out " + tmp.File("s.zip") + " --log " +
                        tmp.File("log.jsonl"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "2 of 7 queries solved in 3 scenes, 7 submitted")) << r.out;
  const std::string log = freeloc::testing::ReadText(tmp.File("log.jsonl"));
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1 + 7);  // the header, then a record per query
  EXPECT_TRUE(Contains(log, "\"status\":\"no-depth\"")) << log;
  r = RunFreeloc("-q eval --data " + data + " --submission " + tmp.File("s.zip") + " --json -");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  // Always answer: the no-depth queries are submitted too, with the prior pose and confidence 0.
  EXPECT_EQ(j["counts"]["estimates"], 3);
  EXPECT_TRUE(Contains(log, "\"solved\":false,\"submitted\":true")) << log;
  EXPECT_LT(j["Average Median Translation Error"].get<double>(), 0.03);
  r = RelocalizeS00003(data);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["status"], "ok");
  // --intrinsics FILE (the scene's intrinsics.txt) instead of the two strings, and --save-matches.
  const std::string s3 = data + "/val/s00003/";
  r = RunFreeloc("relocalize --ref " + s3 + "seq0/frame_00000.png --query " + s3 +
                 "seq1/frame_00000.png --intrinsics " + s3 + "intrinsics.txt --ref-depth " + s3 +
                 "seq0/frame_00000.sensor.png --query-depth " + s3 +
                 "seq1/frame_00000.sensor.png --json --save-matches " + tmp.File("m.txt"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto jr = nlohmann::json::parse(r.out);
  const std::string saved = freeloc::testing::ReadText(tmp.File("m.txt"));
  EXPECT_EQ(std::count(saved.begin(), saved.end(), '\n'), jr["matches"].get<int>());
  EXPECT_EQ(jr["status"], "ok");
  r = RunFreeloc("relocalize --ref " + s3 + "seq0/frame_00000.png --query " + tmp.File("other.png") + " --intrinsics " +
                 s3 + "intrinsics.txt");
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "intrinsics.txt: no line for " + tmp.File("other.png"))) << r.out;
  r = RunFreeloc("relocalize --ref " + s3 + "seq0/frame_00000.png --query " + s3 + "seq1/frame_00000.png");
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "--intrinsics FILE")) << r.out;
  r = RunFreeloc("run --data " + data + " --preset seed --out " + tmp.File("x.zip"));
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(Contains(r.out, "preset seed needs the DUSt3R weights")) << r.out;
  EXPECT_EQ(RunFreeloc("run --data " + data + " --preset nope --out " + tmp.File("x.zip")).code, 1);
  EXPECT_FALSE(std::filesystem::exists(tmp.File("x.zip")));
  EXPECT_EQ(RunFreeloc("run --data " + tmp.File("none") + " --out " + tmp.File("y.zip")).code, 1);
}

// Bad input: what stops a run (exit 1, one line naming the file or option, no submission) and what fails only
// its queries (status in the log, no line in the submission, exit 0).
TEST(Cli, RunReportsBadInputClearly) {
  namespace fs = std::filesystem;
  freeloc::testing::TempDir tmp;
  const std::string split = tmp.File("data/val");
  fs::create_directories(split);
  for (const char* s : {"s00002", "s00003"})
    fs::copy(freeloc::testing::DemoPath(std::string("val/") + s), split + "/" + s, fs::copy_options::recursive);
  const std::string run = "run --data " + tmp.File("data") + " --log " + tmp.File("log.jsonl") + " --out ";
  // A depth suffix no scene has: stops before any work.
  Result r = RunFreeloc(run + tmp.File("a.zip") + " --depth provided:sensr");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "--depth provided:sensr: no scene has this depth (e.g. " + split +
                                  "/s00002/seq0/frame_00000.sensr.png is missing)"))
      << r.out;
  EXPECT_FALSE(fs::exists(tmp.File("a.zip")));
  // A corrupt query image and a missing one: those queries fail, the run finishes.
  freeloc::testing::WriteText(split + "/s00002/seq1/frame_00000.png", "not a png");
  fs::remove(split + "/s00003/seq1/frame_00000.png");
  r = RunFreeloc(run + tmp.File("b.zip"));
  // The submission is written, but the run says how many queries failed on input errors, shows the first messages
  // and where the log is, and exits 3 (never a silent "0 of N" with exit 0).
  ASSERT_EQ(r.code, 3) << r.out;
  EXPECT_TRUE(Contains(r.out, "0 of 2 queries solved in 2 scenes")) << r.out;
  EXPECT_TRUE(Contains(r.out, "statuses: error 2")) << r.out;
  EXPECT_TRUE(
      Contains(r.out, "2 of 2 queries failed on input errors (status error), every record in " + tmp.File("log.jsonl")))
      << r.out;
  EXPECT_TRUE(Contains(r.out, "  s00002/seq1/frame_00000.png: " + split + "/s00002/seq1/frame_00000.png")) << r.out;
  const std::string log = freeloc::testing::ReadText(tmp.File("log.jsonl"));
  EXPECT_TRUE(Contains(log, "\"status\":\"error\",\"message\":\"" + split + "/s00002/seq1/frame_00000.png")) << log;
  EXPECT_TRUE(Contains(log, "\"status\":\"error\",\"message\":\"" + split + "/s00003/seq1/frame_00000.png")) << log;
  // Always answer: the failed queries are submitted with the prior pose and confidence 0 — unless
  // always_answer is 0, when nothing is submitted for them.
  const auto zip = freeloc::io::ZipContents::Read(tmp.File("b.zip")).files;
  EXPECT_EQ(zip.at("pose_s00002.txt"), "seq1/frame_00000.png 1.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0\n");
  EXPECT_EQ(zip.at("pose_s00003.txt"), "seq1/frame_00000.png 1.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0\n");
  r = RunFreeloc(run + tmp.File("b0.zip") + " --set always_answer=0");
  ASSERT_EQ(r.code, 3) << r.out;
  const auto zip0 = freeloc::io::ZipContents::Read(tmp.File("b0.zip")).files;
  EXPECT_EQ(zip0.at("pose_s00002.txt"), "");
  EXPECT_EQ(zip0.at("pose_s00003.txt"), "");
  // A missing reference image fails its scene's queries.
  fs::remove(split + "/s00003/seq0/frame_00000.png");
  r = RunFreeloc(run + tmp.File("c.zip") + " --scenes s00003");
  ASSERT_EQ(r.code, 3) << r.out;
  EXPECT_TRUE(
      Contains(freeloc::testing::ReadText(tmp.File("log.jsonl")), "\"status\":\"error\",\"message\":\"reference: "))
      << r.out;
  // A scene without intrinsics: stops before any scene is processed, naming the file.
  fs::remove(split + "/s00003/intrinsics.txt");
  r = RunFreeloc(run + tmp.File("d.zip"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, split + "/s00003/intrinsics.txt: missing")) << r.out;
  EXPECT_FALSE(fs::exists(tmp.File("d.zip")));
  EXPECT_FALSE(fs::exists(tmp.File("d.zip.progress.jsonl")));
}

// An interrupted run leaves <out>.progress.jsonl; --resume keeps its finished scenes (the planted pose below comes
// back verbatim, so that scene was not recomputed), ignores a last line cut short, and refuses other options.
TEST(Cli, RunResumesFromItsProgressFile) {
  freeloc::testing::TempDir tmp;
  const std::string data = freeloc::testing::DemoPath();
  const std::string out = tmp.File("r.zip"), progress = out + ".progress.jsonl";
  // A complete run leaves no progress file behind; its options line is what the header must carry.
  Result r = RunFreeloc("run --data " + data + " --scenes s00002 --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(std::filesystem::exists(progress));
  r = RelocalizeS00003(data);
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json options = nlohmann::json::parse(r.out)["options"];
  nlohmann::json header = {{"freeloc_run", 1}, {"options", options}};
  nlohmann::json planted = {{"scene", "s00003"},
                            {"queries",
                             {{{"frame", "seq1/frame_00000.png"},
                               {"status", "ok"},
                               {"ok", true},
                               {"confidence", 0.5},
                               {"matches", 9},
                               {"inliers", 8},
                               {"match_ms", 1.0},
                               {"solve_ms", 1.0},
                               {"qvec", {1, 0, 0, 0}},
                               {"tvec", {1.25, 2.5, 3.75}}}}}};
  freeloc::testing::WriteText(progress, header.dump() + "\n" + planted.dump() + "\n{\"scene\": \"s0000");
  r = RunFreeloc("run --data " + data + " --scenes s00002,s00003 --resume --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "1 of 2 scenes already done")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(progress));
  const auto zip = freeloc::io::ZipContents::Read(out).files;
  ASSERT_TRUE(zip.count("pose_s00003.txt"));
  EXPECT_TRUE(Contains(zip.at("pose_s00003.txt"), "seq1/frame_00000.png 1.0 0.0 0.0 0.0 1.25 2.5 3.75 0.5\n"))
      << zip.at("pose_s00003.txt");
  ASSERT_TRUE(zip.count("pose_s00002.txt"));
  EXPECT_TRUE(Contains(zip.at("pose_s00002.txt"), "seq1/frame_00000.png ")) << zip.at("pose_s00002.txt");
  // Other options, or a damaged line before the end: a clear error and no submission.
  std::filesystem::remove(out);
  freeloc::testing::WriteText(progress, header.dump() + "\n" + planted.dump() + "\n");
  r = RunFreeloc("run --data " + data + " --scenes s00002,s00003 --resume --solver pnp --out " + out);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "written with different options")) << r.out;
  freeloc::testing::WriteText(progress, header.dump() + "\nnot json\n" + planted.dump() + "\n");
  r = RunFreeloc("run --data " + data + " --scenes s00002,s00003 --resume --out " + out);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "line 2 is not JSON")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(out));
}

// Shards of a run, merged, give the same bytes as the whole run; overlapping shards and bad shard specs are refused.
// An options file: a run's sidecar read back with --options reproduces the run — the same options and scenes, the
// same submission byte for byte; a flag given over it wins; a name that is not an option is refused.
TEST(Cli, AnOptionsFileReproducesTheRunItRecords) {
  freeloc::testing::TempDir tmp;
  const std::string data = freeloc::testing::DemoPath();
  Result r = RunFreeloc("-q run --data " + data + " --scenes s00002,s00003 --solver hybrid --threshold 2 --set " +
                        "sprt_min_matches=0 --out " + tmp.File("a.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  r = RunFreeloc("-q run --options " + tmp.File("a.zip.json") + " --out " + tmp.File("b.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto a = freeloc::io::ZipContents::Read(tmp.File("a.zip")),
             b = freeloc::io::ZipContents::Read(tmp.File("b.zip"));
  EXPECT_EQ(a.files, b.files);
  const auto side_a = nlohmann::json::parse(freeloc::testing::ReadText(tmp.File("a.zip.json")));
  const auto side_b = nlohmann::json::parse(freeloc::testing::ReadText(tmp.File("b.zip.json")));
  EXPECT_EQ(side_a["options"], side_b["options"]);
  EXPECT_EQ(side_a["scenes"], side_b["scenes"]);
  EXPECT_EQ(side_b["options"]["solver"], "hybrid");
  EXPECT_EQ(side_b["options"]["threshold_px"], 2.0);
  // A flag over the file; the log's header line is an options file too.
  r = RunFreeloc("-q run --options " + tmp.File("a.zip.json") + " --solver essential --log " + tmp.File("c.log") +
                 " --out " + tmp.File("c.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto side_c = nlohmann::json::parse(freeloc::testing::ReadText(tmp.File("c.zip.json")));
  EXPECT_EQ(side_c["options"]["solver"], "essential");
  EXPECT_EQ(side_c["options"]["threshold_px"], 2.0);
  r = RunFreeloc("-q run --options " + tmp.File("c.log") + " --out " + tmp.File("d.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(freeloc::io::ZipContents::Read(tmp.File("d.zip")).files,
            freeloc::io::ZipContents::Read(tmp.File("c.zip")).files);
  freeloc::testing::WriteText(tmp.File("bad.json"), "{\"options\": {\"solvr\": \"pnp\"}}");
  r = RunFreeloc("run --data " + data + " --options " + tmp.File("bad.json") + " --out " + tmp.File("e.zip"));
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"bad.json", "solvr", "not an option"});
}

TEST(Cli, ShardedRunsMergeIntoTheWholeRun) {
  freeloc::testing::TempDir tmp;
  const std::string data = freeloc::testing::DemoPath();
  ASSERT_EQ(RunFreeloc("-q run --data " + data + " --out " + tmp.File("all.zip")).code, 0);
  Result r = RunFreeloc("run --data " + data + " --shard 1/2 --out " + tmp.File("a.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "in 2 scenes")) << r.out;  // s00001 and s00003 of three
  r = RunFreeloc("run --data " + data + " --shard 2/2 --out " + tmp.File("b.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "in 1 scene,")) << r.out;
  r = RunFreeloc("merge " + tmp.File("a.zip") + " " + tmp.File("b.zip") + " --out " + tmp.File("m.zip"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "merged 3 scenes from 2 submissions")) << r.out;
  EXPECT_EQ(freeloc::testing::ReadText(tmp.File("m.zip")), freeloc::testing::ReadText(tmp.File("all.zip")));
  r = RunFreeloc("merge " + tmp.File("a.zip") + " " + tmp.File("all.zip") + " --out " + tmp.File("x.zip"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "is also in")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.File("x.zip")));
  freeloc::testing::WriteText(tmp.File("junk.zip"), "not a zip");
  EXPECT_EQ(RunFreeloc("merge " + tmp.File("junk.zip") + " --out " + tmp.File("x.zip")).code, 1);
  EXPECT_EQ(RunFreeloc("run --data " + data + " --shard 3/2 --out " + tmp.File("x.zip")).code, 2);
  EXPECT_EQ(RunFreeloc("run --data " + data + " --shard 0/2 --out " + tmp.File("x.zip")).code, 2);
  for (const char* t : {"0", "-2", "nan", "inf", "3px"})  // not silently replaced by the default any more
    EXPECT_EQ(RunFreeloc("run --data " + data + " --threshold " + t + " --out " + tmp.File("x.zip")).code, 2) << t;
  EXPECT_FALSE(std::filesystem::exists(tmp.File("x.zip")));
  // default is the solver's own threshold, as --help says (-1, its older spelling, too).
  EXPECT_EQ(RunFreeloc("run --data " + data + " --threshold default --out " + tmp.File("x.zip")).code, 0);
  EXPECT_EQ(RunFreeloc("run --data " + data + " --threshold -1 --out " + tmp.File("y.zip")).code, 0);
}

}  // namespace

// Limits are the user's to set (flag or environment), and a limit error is one line naming the limit.
TEST(Cli, InputLimitsAreSetByFlagOrEnvironment) {
  // A checkpoint of four tensors, written by the test (testing/pth_builder.h).
  freeloc::testing::TempDir tmp;
  freeloc::testing::PthSpec spec;
  for (int k = 0; k < 4; ++k) {
    const std::string key = std::to_string(k);
    spec.storages.push_back({key, "FloatStorage", 6, 24});
    spec.tensors.push_back({"w" + key, key, 0, {2, 3}, {3, 1}});
  }
  const std::string pth = tmp.File("four.pth");
  freeloc::testing::WritePthSpec(pth, spec);
  Result ok = RunFreeloc("inspect " + pth);
  ASSERT_EQ(ok.code, 0) << ok.out;
  Result flag = RunFreeloc("--limit max_tensors=1 inspect " + pth);
  EXPECT_EQ(flag.code, 1) << flag.out;
  EXPECT_TRUE(Contains(flag.out, "raise the limit max_tensors (FREELOC_LIMIT_MAX_TENSORS=N")) << flag.out;
  EXPECT_EQ(std::count(flag.out.begin(), flag.out.end(), '\n'), 1) << flag.out;
  Result env = RunFreeloc("inspect " + pth, "-u FREELOC_MODELS FREELOC_LIMIT_MAX_TENSORS=1");
  EXPECT_EQ(env.code, 1) << env.out;
  EXPECT_TRUE(Contains(env.out, "max_tensors")) << env.out;
  Result bad = RunFreeloc("--limit max_pixels=5 inspect " + pth);
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_TRUE(Contains(bad.out, "unknown limit 'max_pixels'; the limits are max_image_pixels")) << bad.out;
}

namespace {

template <typename T>
std::vector<T> TensorValues(const freeloc::io::TensorView& t) {
  return std::vector<T>(t.as<T>(), t.as<T>() + t.numel());
}

// |a − b| ≤ 1e-4 + 1e-3·|b| everywhere (the fixture README's tolerance).
bool Close(const freeloc::io::TensorView& a, const freeloc::io::TensorView& b) {
  if (a.numel() != b.numel()) return false;
  for (int64_t i = 0; i < a.numel(); ++i)
    if (!(std::abs(a.as<float>()[i] - b.as<float>()[i]) <= 1e-4 + 1e-3 * std::abs(b.as<float>()[i]))) return false;
  return true;
}

}  // namespace

// `freeloc pointmap` on a MASt3R checkpoint, from the PNGs, as the fixture README §9.3 suggests: descriptors and
// desc_conf within tolerance, the raw fast reciprocal NN matches equal upstream's row for row, and the filtered ones
// equal upstream's 3-px border list; from the .pth and from an HF folder (config.json with Infinity tokens).
TEST(Cli, Mast3rPointmapMatchesUpstream) {
  FREELOC_REQUIRE_SHARED("fixtures/mast3r/mast3r_tiny.pth");
  freeloc::testing::TempDir tmp;
  const std::string fx = freeloc::testing::SharedPath("fixtures/mast3r/");
  // The HF layout: model.safetensors (one name per shared tensor) + the flat config.json.
  std::filesystem::create_directories(tmp.File("hf"));
  std::filesystem::copy_file(fx + "weights.safetensors", tmp.File("hf/model.safetensors"));
  freeloc::testing::WriteText(tmp.File("hf/config.json"), R"({"conf_mode": ["exp", 1, Infinity], "dec_depth": 12,
    "dec_embed_dim": 24, "dec_num_heads": 2, "depth_mode": ["exp", -Infinity, Infinity], "desc_conf_mode": ["exp", 0,
    Infinity], "desc_mode": "norm", "enc_depth": 2, "enc_embed_dim": 32, "enc_num_heads": 2, "head_type": "catmlp+dpt",
    "output_mode": "pts3d+desc8", "pos_embed": "RoPE100", "two_confs": true})");
  struct Case {
    const char* name;
    const char* a;
    const char* b;
    int size, subsample;
    std::string model;
  };
  for (const Case& c : {Case{"land_s128", "img_a", "img_d", 128, 4, fx + "mast3r_tiny.pth"},
                        Case{"mixed_s80", "img_a", "img_c", 80, 8, tmp.File("hf/model.safetensors")},
                        Case{"odd_s112", "img_b", "img_a", 112, 4, fx + "mast3r_tiny.pth"}}) {
    SCOPED_TRACE(c.name);
    Result r = RunFreeloc("pointmap --model " + c.model + " --size " + std::to_string(c.size) + " " + fx + "images/" +
                          c.a + ".png " + fx + "images/" + c.b + ".png --matches --subsample " +
                          std::to_string(c.subsample) + " --out " + tmp.File("pm.safetensors"));
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(Contains(r.out, "MASt3R pointmaps")) << r.out;
    const auto f = freeloc::io::SafetensorsFile::Open(tmp.File("pm.safetensors"));
    const auto g = freeloc::io::SafetensorsFile::Open(fx + "cases/" + c.name + ".safetensors");
    EXPECT_EQ(f.metadata.at("family"), "MASt3R");
    EXPECT_TRUE(Close(f.Get("desc_1"), g.Get("pred1.desc")));
    EXPECT_TRUE(Close(f.Get("desc_2"), g.Get("pred2.desc")));
    EXPECT_TRUE(Close(f.Get("desc_conf_1"), g.Get("pred1.desc_conf")));
    EXPECT_TRUE(Close(f.Get("desc_conf_2"), g.Get("pred2.desc_conf")));
    EXPECT_TRUE(Close(f.Get("pts3d_2"), g.Get("pred2.pts3d_in_other_view")));
    const std::string p = "fnn_s" + std::to_string(c.subsample) + ".";
    const auto m = TensorValues<int32_t>(f.Get("matches"));
    const auto x0 = TensorValues<int32_t>(g.Get(p + "xy_im0")), x1 = TensorValues<int32_t>(g.Get(p + "xy_im1"));
    ASSERT_EQ(m.size(), 2 * x0.size());
    for (size_t i = 0; i < x0.size() / 2; ++i) {
      EXPECT_EQ(m[4 * i], x0[2 * i]);
      EXPECT_EQ(m[4 * i + 1], x0[2 * i + 1]);
      EXPECT_EQ(m[4 * i + 2], x1[2 * i]);
      EXPECT_EQ(m[4 * i + 3], x1[2 * i + 1]);
    }
    EXPECT_EQ(f.Get("matches_orig").shape.at(0), g.Get(p + "border.xy_im0").shape.at(0));
  }
}

// The MASt3R presets end to end with the tiny weights through run + eval: found by published name in --models,
// deterministic, every query answered with a status (random weights: no pose, so eval reports that the submission
// holds none), missing weights a one-line error.
TEST(Cli, Mast3rPresetsRunAndEval) {
  freeloc::testing::TempDir models, tmp;
  LinkTinyModels(models);
  std::filesystem::create_symlink(freeloc::testing::TinyModelPath("mast3r_tiny.pth"),
                                  models.File("MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric.pth"));
  const std::string data = freeloc::testing::DemoPath();
  for (const char* preset : {"mast3r", "mast3r-pnp", "mast3r-metric3d", "seed-mast3r"}) {
    SCOPED_TRACE(preset);
    const std::string run =
        std::string("-q run --data ") + data + " --scenes s00002 --preset " + preset + " --dust3r-size 224 ";
    Result r = RunFreeloc(run + "--out " + tmp.File("none.zip"));
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_TRUE(Contains(r.out, "MASt3R_ViTLarge_BaseDecoder_512_catmlpdpt_metric.pth")) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    r = RunFreeloc(run + "--models " + models.path() + " --out " + tmp.File("a.zip") + " --log " + tmp.File("a.jsonl"));
    ASSERT_EQ(r.code, 0) << r.out;
    const std::string log = freeloc::testing::ReadText(tmp.File("a.jsonl"));
    EXPECT_TRUE(Contains(
        log, std::string("\"matcher\":\"") + (std::string(preset) == "seed-mast3r" ? "mast3r+instances" : "mast3r")))
        << log.substr(0, 600);
    EXPECT_TRUE(Contains(log, "\"status\":\"no-consensus\"") || Contains(log, "\"status\":\"too-few-matches\"")) << log;
    if (std::string(preset) == "mast3r") {
      r = RunFreeloc(run + "--models " + models.path() + " --out " + tmp.File("b.zip"));
      ASSERT_EQ(r.code, 0) << r.out;
      EXPECT_EQ(freeloc::testing::ReadText(tmp.File("a.zip")), freeloc::testing::ReadText(tmp.File("b.zip")));
    }
    // The submission is valid and evaluates: random weights solve nothing, so every query is answered with the
    // prior pose and confidence 0 (always answer).
    for (const auto& [name, text] : freeloc::io::ZipContents::Read(tmp.File("a.zip")).files) {
      std::stringstream lines(text);
      for (std::string line; std::getline(lines, line);)
        EXPECT_TRUE(Contains(line, ".png 1.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0")) << name << ": " << line;
    }
    r = RunFreeloc("eval --data " + data + " --submission " + tmp.File("a.zip") + " --scenes s00002");
    EXPECT_EQ(r.code, 0) << r.out;
    if (std::string(preset) == "mast3r") {  // without always_answer nothing is submitted: the evaluator says so
      r = RunFreeloc(run + "--models " + models.path() + " --set always_answer=0 --out " + tmp.File("c.zip"));
      ASSERT_EQ(r.code, 0) << r.out;
      r = RunFreeloc("eval --data " + data + " --submission " + tmp.File("c.zip") + " --scenes s00002");
      EXPECT_EQ(r.code, 1) << r.out;
      EXPECT_TRUE(Contains(r.out, "no valid pose estimate")) << r.out;
    }
  }
}

// On a CPU OpenBLAS does not know, a network command re-executes itself once with OPENBLAS_CORETYPE set to the
// kernels the CPU runs (simulated here: FREELOC_BLAS_ASSUME_REPORTED makes freeloc act as if OpenBLAS had reported a
// generic core); `-v` names the kernels. Commands without networks, a user-set OPENBLAS_CORETYPE and
// FREELOC_BLAS_SELECT=0 are left alone.
TEST(Cli, UnknownCpuGetsFastBlasKernels) {
  const std::string cmd = "-v match --model none.pth a.png b.png --out x.txt";
  Result r = RunFreeloc(cmd, "-u FREELOC_MODELS -u OPENBLAS_CORETYPE FREELOC_BLAS_ASSUME_REPORTED=Prescott");
  EXPECT_EQ(r.code, 1) << r.out;  // the files do not exist: the point is what ran before
  if (!Contains(r.out, "BLAS: OpenBLAS")) GTEST_SKIP() << "the BLAS is not OpenBLAS here: " << r.out;
  const bool fast_cpu = Contains(freeloc::testing::ReadText("/proc/cpuinfo"), " avx");
  if (fast_cpu) {
    EXPECT_TRUE(Contains(r.out, "selected by freeloc: OpenBLAS reported Prescott -> ")) << r.out;
    // The kernels OpenBLAS runs after the re-exec are the selected ones.
    const size_t a = r.out.find("Prescott -> ") + 12;
    const std::string pick = r.out.substr(a, r.out.find(' ', a) - a);
    EXPECT_TRUE(Contains(r.out, "OpenBLAS, " + pick + " kernels")) << r.out;
  }
  r = RunFreeloc(cmd, "-u FREELOC_MODELS OPENBLAS_CORETYPE=Haswell FREELOC_BLAS_ASSUME_REPORTED=Prescott");
  EXPECT_TRUE(Contains(r.out, "OPENBLAS_CORETYPE=Haswell set by the user")) << r.out;
  r = RunFreeloc(cmd,
                 "-u FREELOC_MODELS -u OPENBLAS_CORETYPE FREELOC_BLAS_SELECT=0 FREELOC_BLAS_ASSUME_REPORTED=Prescott");
  EXPECT_TRUE(Contains(r.out, "OpenBLAS's own choice")) << r.out;
  r = RunFreeloc("-v eval --data /nonexistent --submission x.zip",
                 "-u FREELOC_MODELS -u OPENBLAS_CORETYPE FREELOC_BLAS_ASSUME_REPORTED=Prescott");
  EXPECT_FALSE(Contains(r.out, "selected by freeloc")) << r.out;
}

// Instant start: commands that run no network never load LibTorch, and those that decode no photo never
// load OpenCV's image codecs (~140 libraries); the dynamic loader's own trace (LD_DEBUG=files) says what each process
// loaded. A network command loads both, on demand.
TEST(Cli, CommandsWithoutNetworksNeverLoadLibTorch) {
  const std::string s = freeloc::testing::DemoPath("val/s00003");
  const std::string k = "535.4,539.2,320.1,247.6";
  const std::string matches = freeloc::testing::SourceDir() + "/tests/data/tum_sift/s00003_sift_matches.txt";
  const std::string env = "-u FREELOC_MODELS LD_DEBUG=files";
  const auto loads = [](const Result& r, const std::string& lib) {
    return Contains(r.out, "file=" + lib) || Contains(r.out, "/" + lib);
  };
  freeloc::testing::TempDir tmp;
  struct Case {
    std::string args;
    bool decodes_photos;
  };
  const std::vector<Case> cases = {
      {"--version", false},
      {"--help", false},
      {"pose --matches " + matches + " --ref-intrinsics " + k + " --query-intrinsics " + k + " --ref-depth " + s +
           "/seq0/frame_00000.sensor.png --query-depth " + s + "/seq1/frame_00000.sensor.png",
       false},
      {"run --preset sift-essential --data " + freeloc::testing::DemoPath("") + " --split val --scenes s00003 --out " +
           tmp.File("sub.zip"),
       true},
  };
  for (const auto& c : cases) {
    const Result r = RunFreeloc(c.args, env);
    EXPECT_EQ(r.code, 0) << c.args << "\n" << r.out.substr(r.out.size() > 3000 ? r.out.size() - 3000 : 0);
    EXPECT_FALSE(loads(r, "libtorch_cpu.so")) << c.args;
    EXPECT_FALSE(loads(r, "libfreeloc_networks.so")) << c.args;
    EXPECT_EQ(loads(r, "libfreeloc_codecs.so"), c.decodes_photos) << c.args;
  }
  const Result r =
      RunFreeloc("pointmap --model " + freeloc::testing::TinyModelPath("dust3r_tiny.pth") + " --size 224 " + s +
                     "/seq0/frame_00000.png " + s + "/seq1/frame_00000.png --out " + tmp.File("pm.safetensors"),
                 env);
  EXPECT_EQ(r.code, 0);
  EXPECT_TRUE(loads(r, "libfreeloc_networks.so"));
  EXPECT_TRUE(loads(r, "libtorch_cpu.so"));
}

namespace {

// The text between `begin` and `end` in a file ("" when either is missing).
std::string Between(const std::string& text, const std::string& begin, const std::string& end) {
  const size_t b = text.find(begin);
  if (b == std::string::npos) return "";
  const size_t from = text.find('\n', b) + 1;
  const size_t e = text.find(end, from);
  return e == std::string::npos ? "" : text.substr(from, e - from);
}

}  // namespace

// docs/formats.md's option table is the code's option table: `freeloc options --markdown` prints it, the docs hold
// the same bytes (regenerate with `build/freeloc options --markdown` when an option changes).
TEST(Cli, DocsOptionTableIsTheCodesOptionTable) {
  const Result r = RunFreeloc("options --markdown");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string docs = freeloc::testing::ReadText(freeloc::testing::SourceDir() + "/docs/formats.md");
  const std::string block =
      Between(docs, "<!-- BEGIN generated by `freeloc options --markdown` -->", "<!-- END generated -->");
  ASSERT_FALSE(block.empty()) << "docs/formats.md has no generated option table";
  EXPECT_EQ(block, r.out) << "docs/formats.md's option table differs from the code's; paste the output of "
                             "`build/freeloc options --markdown` between its markers";
  // Every field by name, with its flag where it has one; the list has the MASt3R fields too.
  for (const char* field : {"mast3r_subsample", "mast3r_border", "mast3r_conf_threshold", "mast3r_model",
                            "threshold_px", "segmenter.max_batch"})
    EXPECT_TRUE(Contains(block, std::string("`") + field + "`")) << field;
  EXPECT_TRUE(Contains(block, "| `threshold_px` | `--threshold` |")) << block;
  EXPECT_TRUE(Contains(block, "| `scale` | `--scale` | text | `anchored` |")) << block;
}

// `freeloc options --preset P` shows what the preset resolves to; `--help` states the default preset's values from
// the same table (the default scale is anchored, not the vote).
TEST(Cli, OptionsAndHelpShowTheDefaultsOfTheOptionTable) {
  Result r = RunFreeloc("options --preset seed");
  ASSERT_EQ(r.code, 0) << r.out;
  ExpectMentions(r.out, {"solver", "= hybrid", "= dust3r+instances"});
  r = RunFreeloc("options --preset no-such-preset");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "no-such-preset")) << r.out;
  for (const char* cmd : {"pose", "relocalize", "run"}) {
    r = RunFreeloc(std::string(cmd) + " --help");
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(Contains(r.out, "(default anchored)")) << cmd << "\n" << r.out;
    EXPECT_FALSE(Contains(r.out, "robust scale")) << cmd << "\n" << r.out;
  }
}

// The flags are generated from the option registry: every row with a flag is offered where its scope says (with its
// second spelling and choices), and an option's error names the flag the command spells it with.
TEST(Cli, FlagsComeFromTheOptionRegistry) {
  using freeloc::pipeline::FlagScope;
  const Result top = RunFreeloc("--help"), run = RunFreeloc("run --help"), pose = RunFreeloc("pose --help"),
               reloc = RunFreeloc("relocalize --help");
  for (const auto& f : freeloc::pipeline::OptionFields()) {
    if (!f.flag) continue;
    const std::string flag = std::string(f.flag) + (f.alias ? std::string(",") + f.alias : std::string()) + " ";
    switch (f.scope) {
      case FlagScope::kGlobal: EXPECT_TRUE(Contains(top.out, flag)) << flag; break;
      case FlagScope::kSolve:
        for (const Result* h : {&run, &pose, &reloc}) EXPECT_TRUE(Contains(h->out, flag)) << flag;
        break;
      case FlagScope::kStages:
        EXPECT_TRUE(Contains(run.out, flag)) << flag;
        EXPECT_TRUE(Contains(reloc.out, flag)) << flag;
        EXPECT_FALSE(Contains(pose.out, flag)) << flag;
        break;
      case FlagScope::kRun:
        EXPECT_TRUE(Contains(run.out, flag)) << flag;
        EXPECT_FALSE(Contains(reloc.out, flag)) << flag;
        break;
      case FlagScope::kNone: ADD_FAILURE() << f.name << " has a flag but no scope";
    }
    if (!f.choices.empty() && f.scope != FlagScope::kGlobal) {
      EXPECT_TRUE(Contains(f.scope == FlagScope::kSolve ? pose.out : run.out, "one of " + f.choices)) << f.name;
    }
  }
  // An option's error names the flag: the registry's, or the command's own spelling (match --size is dust3r_size).
  freeloc::testing::TempDir tmp;
  const std::string img = freeloc::testing::DemoPath("val/s00001/seq0/frame_00000.png");
  Result r = RunFreeloc("match --model x.pth --size 100 " + img + " " + img + " --out " + tmp.File("m.txt"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "--size: 100 is too small")) << r.out;
  EXPECT_FALSE(Contains(r.out, "--dust3r-size")) << r.out;
  r = RunFreeloc("run --data " + freeloc::testing::DemoPath("") + " --frames 12 --out " + tmp.File("x.zip"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(Contains(r.out, "--frames: 12 is not in 1..9")) << r.out;
  EXPECT_EQ(RunFreeloc("run --data x --frames 0 --out " + tmp.File("x.zip")).code, 2);  // not a count
}

// --check-args checks a command line without running it: valid lines exit 0 even when their files do not exist,
// invalid ones exit 2 as they would without it.
TEST(Cli, CheckArgsValidatesWithoutRunning) {
  Result r = RunFreeloc(
      "--check-args relocalize --ref a.jpg --query b.jpg --ref-intrinsics 1,1,0,0 "
      "--query-intrinsics 1,1,0,0 --preset seed --models /nonexistent");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(Contains(r.out, "nothing was run")) << r.out;
  r = RunFreeloc("--check-args relocalize --ref a.jpg --query b.jpg --no-such-flag");
  EXPECT_EQ(r.code, 2) << r.out;
  r = RunFreeloc("--check-args run --data x --out y.zip --shard 5/4");
  EXPECT_EQ(r.code, 2) << r.out;
}

// Every output path is checked before the first byte of any output: a run whose --out or --log cannot be written
// fails at once and leaves nothing (no journal, no submission, no sidecar).
TEST(Cli, RunThatCannotWriteItsOutputsFailsAtOnceAndLeavesNothing) {
  namespace fs = std::filesystem;
  freeloc::testing::TempDir tmp;
  const std::string run = "run --data " + freeloc::testing::DemoPath() + " --scenes s00003";
  auto files = [&] {
    size_t n = 0;
    for (const auto& e : fs::recursive_directory_iterator(tmp.path())) n += e.is_regular_file() ? 1 : 0;
    return n;
  };
  fs::create_directories(tmp.File("adir"));
  Result r = RunFreeloc(run + " --out " + tmp.File("adir"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, tmp.File("adir") + ": is a folder, but the submission is a file")) << r.out;
  r = RunFreeloc(run + " --out " + tmp.File("s.zip") + " --log " + tmp.File("adir"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "is a folder, but the run log is a file")) << r.out;
  r = RunFreeloc(run + " --out " + tmp.File("s.zip") + " --log " + tmp.File("no/such/folder/log.jsonl"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "does not exist; create it first (the run log)")) << r.out;
  r = RunFreeloc(run + " --out " + tmp.File("s.zip") + " --log " + tmp.File("s.zip"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "--log: " + tmp.File("s.zip") + " is also the submission")) << r.out;
  freeloc::testing::WriteText(tmp.File("afile"), "x");
  r = RunFreeloc(run + " --out " + tmp.File("s.zip") + " --report " + tmp.File("afile"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "is a file, but the HTML report is a folder")) << r.out;
  EXPECT_EQ(files(), 1u);  // only the test's own afile
  EXPECT_FALSE(fs::exists(tmp.File("s.zip.progress.jsonl")));
  r = RunFreeloc(run + " --out " + tmp.File("s.zip") + " --log " + tmp.File("log.jsonl"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(tmp.File("s.zip")) && fs::exists(tmp.File("log.jsonl")));
}

// Names that become file names are names, not paths: a usage error where the flag is parsed, an error through --set.
TEST(Cli, NamesThatBecomeFileNamesAreNotPaths) {
  freeloc::testing::TempDir tmp;
  const std::string run = "run --data " + freeloc::testing::DemoPath() + " --out " + tmp.File("s.zip");
  for (const char* bad :
       {" --preset precomputed:../../x-essential", " --preset precomputed:/etc/x-pnp", " --matcher precomputed:../SIFT",
        " --depth provided:../../s00002/seq0/frame_00000.sensor", " --depth provided:a/b"}) {
    const Result r = RunFreeloc(run + bad);
    EXPECT_EQ(r.code, 2) << bad << "\n" << r.out;
    EXPECT_TRUE(Contains(r.out, "not a path")) << bad << "\n" << r.out;
  }
  Result r = RunFreeloc(run + " --set depth=provided:../x");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(Contains(r.out, "the suffix must be letters, digits")) << r.out;
  r = RunFreeloc(run + " --depth provided:sensor.v2 --scenes s00003");  // a dotted name is still a name
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "no scene has this depth")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.File("s.zip")));
}

// Intrinsics from the command line meet the map-free reader's bounds once the image's size is known.
TEST(Cli, IntrinsicsFromFlagsAreCheckedAgainstTheImage) {
  const std::string s = freeloc::testing::DemoPath("val/s00003/");
  const std::string pair = "relocalize --ref " + s + "seq0/frame_00000.png --query " + s + "seq1/frame_00000.png ";
  const std::string k = "535.4,539.2,320.1,247.6";
  Result r = RunFreeloc(pair + "--ref-intrinsics 1e308,1e308,320,240 --query-intrinsics " + k);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "reference intrinsics 1e+308,1e+308,320,240")) << r.out;
  EXPECT_TRUE(Contains(r.out, "is above 20 × the long side")) << r.out;
  r = RunFreeloc(pair + "--ref-intrinsics " + k + " --query-intrinsics 535,539,5000,247");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out,
                       "query intrinsics 535,539,5000,247 (fx,fy,cx,cy) do not fit the 640x480 photo: the "
                       "principal point (5000, 247) is outside the image"))
      << r.out;
  // depth --intrinsics: refused before any model is read (no weights needed to see it).
  freeloc::testing::TempDir tmp;
  r = RunFreeloc("depth --model " + tmp.File("none.pth") + " --image " + s +
                 "seq0/frame_00000.png --intrinsics "
                 "1e308,1e308,320,240 --out " +
                 tmp.File("d.png"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(Contains(r.out, "exceeds 100 image widths")) << r.out;
  EXPECT_FALSE(std::filesystem::exists(tmp.File("d.png")));
}

// An extreme estimate: the JSON and the Markdown table carry the same value — a finite number both ways, or the
// official evaluator's Infinity in both (json.dumps writes Infinity; null in one and a number in the other was a bug).
TEST(Cli, EvalJsonAndTableAgreeOnExtremeEstimates) {
  freeloc::testing::TempDir tmp;
  const std::string data = freeloc::testing::DemoPath();
  for (const double t : {1e150, 1e200, 1e308}) {
    std::map<std::string, std::vector<freeloc::io::SubmissionEntry>> sub;
    sub["s00003"].push_back(
        {"seq1/frame_00000.png", freeloc::Rigid3d::FromWxyz({1, 0, 0, 0}, Eigen::Vector3d(t, t, t)), 1});
    freeloc::io::WriteSubmission(tmp.File("x.zip"), sub);
    const Result j =
        RunFreeloc("-q eval --data " + data + " --scenes s00003 --submission " + tmp.File("x.zip") + " --json -");
    const Result m = RunFreeloc("-q eval --data " + data + " --scenes s00003 --submission " + tmp.File("x.zip"));
    ASSERT_EQ(j.code, 0) << j.out;
    ASSERT_EQ(m.code, 0) << m.out;
    EXPECT_FALSE(Contains(j.out, "null")) << j.out;
    for (const char* metric : {"Average Median Translation Error", "Average Median Reprojection Error"}) {
      const size_t at = j.out.find(std::string("\"") + metric + "\": ");
      ASSERT_NE(at, std::string::npos) << j.out;
      const std::string token =
          j.out.substr(at + std::strlen(metric) + 4, j.out.find_first_of(",\n}", at) - (at + std::strlen(metric) + 4));
      const size_t row = m.out.find(std::string("| ") + metric + " | ");
      ASSERT_NE(row, std::string::npos) << m.out;
      const std::string cell =
          m.out.substr(row + std::strlen(metric) + 5,
                       m.out.find(' ', row + std::strlen(metric) + 5) - (row + std::strlen(metric) + 5));
      if (token == "Infinity" || token == "NaN") {
        EXPECT_EQ(cell, token) << metric << " at t=" << t;
      } else {
        EXPECT_NEAR(std::stod(cell), std::stod(token), std::abs(std::stod(token)) * 1e-3 + 1e-3) << metric;
      }
    }
  }
}

// A typo names itself and the nearest real command or flag (exit 2), not a missing subcommand or a required flag.
TEST(Cli, TyposAreNamedWithTheNearestName) {
  Result r = RunFreeloc("relocalise --ref a.png --query b.png");
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectMentions(r.out, {"unknown command 'relocalise'; did you mean 'relocalize'?"});
  r = RunFreeloc("--threads 2 relocalize --ref a.png --querry b.png");
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectMentions(r.out, {"unknown flag '--querry' for relocalize; did you mean '--query'?"});
  r = RunFreeloc("run --data x --out y.zip --presett sift-essential");
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectMentions(r.out, {"unknown flag '--presett' for run; did you mean '--preset'?"});
  r = RunFreeloc("frobnicate");
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectMentions(r.out, {"unknown command 'frobnicate'"});
  EXPECT_FALSE(Contains(r.out, "did you mean")) << r.out;
}

// A flag's documented word is taken (--threshold default; -1, its older spelling), a value outside a flag's fixed
// choices is a usage error (exit 2, as the README's table says) — --check-args sees it too.
TEST(Cli, SentinelsAndChoicesAreCheckedAsTheFlagIsParsed) {
  const std::string k = "535.4,539.2,320.1,247.6";
  const std::string pose = "pose --matches " + freeloc::testing::SourceDir() +
                           "/tests/data/tum_sift/s00003_sift_matches.txt --ref-intrinsics " + k +
                           " --query-intrinsics " + k;
  EXPECT_EQ(RunFreeloc(pose + " --threshold default").code, 0);
  EXPECT_EQ(RunFreeloc(pose + " --threshold -1").code, 0);
  Result r = RunFreeloc(pose + " --threshold -2");
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectMentions(r.out, {"must be a positive number (or default)"});
  r = RunFreeloc(pose + " --solver fast");
  EXPECT_EQ(r.code, 2) << r.out;
  ExpectMentions(r.out, {"fast"});
  EXPECT_EQ(RunFreeloc("--check-args " + pose + " --solver fast").code, 2);
  EXPECT_EQ(RunFreeloc("--check-args " + pose + " --solver pnp").code, 0);
}

// The Multi Frame track on scenes too short for it says so before any work (not "0 of 0 queries", exit 0).
TEST(Cli, MultiFrameOnShortScenesSaysWhy) {
  freeloc::testing::TempDir tmp;
  const Result r =
      RunFreeloc("run --data " + freeloc::testing::DemoPath() + " --track multi-frame --out " + tmp.File("mf.zip"));
  EXPECT_EQ(r.code, 1) << r.out;
  ExpectMentions(r.out, {"--track: multi-frame, but no scene of", "has the 10 or more query frames",
                         "use single-frame for these scenes"});
  EXPECT_FALSE(std::filesystem::exists(tmp.File("mf.zip")));
  // eval of a (single-frame) submission on the same scenes: the same reason, not "check the scene names".
  ASSERT_EQ(RunFreeloc("-q run --data " + freeloc::testing::DemoPath() + " --out " + tmp.File("sf.zip")).code, 0);
  const Result e = RunFreeloc("eval --data " + freeloc::testing::DemoPath() + " --track multi-frame --submission " +
                              tmp.File("sf.zip"));
  EXPECT_EQ(e.code, 1) << e.out;
  ExpectMentions(e.out, {"no scene has a frame to evaluate", "10 or more query frames", "single-frame track"});
}

// Every command's --help ends with examples.
TEST(Cli, EveryCommandsHelpHasExamples) {
  for (const char* command : {"relocalize", "pose", "run", "eval", "demo", "serve", "intrinsics", "options", "merge",
                              "inspect", "pointmap", "match", "segment", "depth"}) {
    const Result r = RunFreeloc(std::string(command) + " --help");
    EXPECT_EQ(r.code, 0) << command;
    EXPECT_TRUE(Contains(r.out, "Examples:\n  freeloc " + std::string(command)) ||
                Contains(r.out, "Examples:\n  mpirun"))
        << command << "\n"
        << r.out;
  }
}

// A run that would replace an earlier run's progress says so before any work, naming --resume.
TEST(Cli, RunWarnsBeforeReplacingAnEarlierRunsProgress) {
  freeloc::testing::TempDir tmp;
  freeloc::testing::WriteText(tmp.File("sub.zip.progress.jsonl"), "{}\n");
  const Result r =
      RunFreeloc("run --data " + freeloc::testing::DemoPath() + " --scenes s00003 --out " + tmp.File("sub.zip"));
  EXPECT_EQ(r.code, 0) << r.out;
  ExpectMentions(r.out, {"sub.zip.progress.jsonl holds an earlier run's progress; this run starts over",
                         "add --resume to continue that run instead"});
  EXPECT_LT(r.out.find("holds an earlier run's progress"), r.out.find("queries solved")) << r.out;
}

// Hostile tracking poses (poses_device.txt) on the Multi Frame demo scene: garbage, non-finite, huge and absurd values
// give a per-scene warning and the images-only answer — byte for byte the submission of --device-poses ignore — never
// a crash, a hang or a pose pulled by garbage. (A translation of 1e308 ended the whole run before; 1e150 went into
// the submission.)
TEST(Cli, HostileTrackingPosesFallBackToTheImages) {
  freeloc::testing::TempDir tmp;
  const std::string scene = tmp.File("mf/val/s00004");
  std::filesystem::create_directories(tmp.File("mf/val"));
  std::filesystem::copy(std::string(FREELOC_SOURCE_DIR) + "/data/demo-multiframe/val/s00004", scene,
                        std::filesystem::copy_options::recursive);
  const std::string good = freeloc::testing::ReadText(scene + "/poses_device.txt");
  const std::string run = "-q run --data " + tmp.File("mf") + " --track multi-frame --depth none --out ";
  ASSERT_EQ(RunFreeloc(run + tmp.File("ignore.zip") + " --device-poses ignore").code, 0);
  const std::string images_only = freeloc::testing::ReadText(tmp.File("ignore.zip"));
  const std::string first = good.substr(0, good.find('\n'));  // seq1/frame_00001.jpg qw qx qy qz tx ty tz
  const std::string name = first.substr(0, first.find(' '));
  const std::string rest = good.substr(good.find('\n') + 1);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"a translation of 1e308", name + " 1 0 0 0 1e308 0 0\n" + rest},
      {"a translation of 1e150", name + " 1 0 0 0 1e150 0 0\n" + rest},
      {"nan", name + " nan 0 0 0 0 0 0\n" + rest},
      {"a non-unit quaternion", name + " 2 0 0 0 0.1 0 0\n" + rest},
      {"a duplicated frame", first + "\n" + good},
      {"text garbage", "\x01\xff garbage \x7f\n" + good},
      {"20 MB of newlines", std::string(20 << 20, '\n') + good},
  };
  for (const auto& [what, text] : cases) {
    {
      std::ofstream f(scene + "/poses_device.txt", std::ios::binary);
      f << text;
    }
    const std::string out = tmp.File("h.zip");
    const Result r = RunFreeloc("run --data " + tmp.File("mf") + " --track multi-frame --depth none --out " + out);
    EXPECT_EQ(r.code, 0) << what << "\n" << r.out;
    EXPECT_TRUE(Contains(r.out, "s00004: ") && Contains(r.out, "poses_device.txt") &&
                Contains(r.out, "the device poses are ignored for this scene"))
        << what << "\n"
        << r.out;
    EXPECT_EQ(freeloc::testing::ReadText(out), images_only) << what;
  }
}
