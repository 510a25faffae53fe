// The Multi Frame track: whole runs on rendered hand-held sequences (testing/sequence_scene.h) through the run
// controller and the evaluator (the fusion's own tests: pose/window_fusion_test.cc).
#include "freeloc/pipeline/multi_frame.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "freeloc/eval/report.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/submission.h"
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/relocalizer.h"
#include "freeloc/pipeline/run_controller.h"
#include "testing/sequence_scene.h"
#include "testing/testing.h"

namespace freeloc::pipeline {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------------------------
// Whole runs on rendered sequences.

std::vector<Image> Photos() {
  std::vector<Image> photos;
  for (const char* p : {"s00001/seq0/frame_00000.png", "s00002/seq0/frame_00000.png", "s00003/seq0/frame_00000.png",
                        "s00003/seq1/frame_00000.png"})
    photos.push_back(io::ReadImage(std::string(FREELOC_SOURCE_DIR) + "/data/demo/val/" + p));
  return photos;
}

// Two scenes of two windows (+ 2 trailing frames), 240×320.
std::vector<std::vector<std::string>> WriteSequences(const std::string& split, uint32_t seed) {
  testing::SequenceOptions so;
  so.windows = 2;
  so.width = 240;
  so.height = 320;
  std::vector<std::vector<std::string>> names;
  const auto photos = Photos();
  for (int s = 0; s < 2; ++s)
    names.push_back(testing::WriteSequenceScene(split + "/s0000" + std::to_string(s), seed + 17u * s, photos, so));
  return names;
}

PipelineOptions MultiFrameOptions(const std::string& depth, int frames, const std::string& device) {
  PipelineOptions o = ResolvePreset("sift-essential");
  o.depth = DepthSpec::FromString("provided:" + depth);
  SetOption(&o, "track", "multi-frame");
  SetOption(&o, "frames", std::to_string(frames));
  SetOption(&o, "device_poses", device);
  return o;
}

RunResult RunSplit(const std::string& split, const std::string& out, const PipelineOptions& o) {
  RunSpec spec;
  spec.data = split;
  spec.out = out;
  spec.progress_bar = false;
  return ExecuteRun(spec, o);
}

TEST(MultiFrameRun, OneLinePerEvaluatedFrameAndNothingOutsideTheWindowsIsRead) {
  testing::TempDir tmp;
  const std::string split = tmp.path() + "/val";
  const auto names = WriteSequences(split, 424242);
  const PipelineOptions o = MultiFrameOptions("exact", 9, "auto");
  const RunResult a = RunSplit(split, tmp.File("a.zip"), o);
  for (int s = 0; s < 2; ++s) {
    const std::string scene = "s0000" + std::to_string(s);
    const auto& res = a.results.at(scene);
    ASSERT_EQ(res.size(), 2u);
    EXPECT_EQ(res[0].frame, names[s][9]);
    EXPECT_EQ(res[1].frame, names[s][19]);
    for (const auto& r : res) {
      EXPECT_TRUE(r.ok()) << r.frame;
      EXPECT_EQ(r.window.frames, 9);
      EXPECT_EQ(r.window.votes.front().frame, names[s][r.frame == names[s][9] ? 1 : 11]);
    }
  }
  const io::ZipContents za = io::ZipContents::Read(tmp.File("a.zip"));
  // Frames at linear positions 0, 10 and the trailing ones replaced by noise (images and depth maps): the same bytes.
  std::mt19937 rng(5);
  for (int s = 0; s < 2; ++s)
    for (size_t pos : {size_t{0}, size_t{10}, size_t{20}, size_t{21}}) {
      const std::string dir = split + "/s0000" + std::to_string(s) + "/";
      Image noise(240, 320);
      for (auto& v : noise.data) v = static_cast<uint8_t>(rng());
      io::WriteImagePng(dir + names[s][pos], noise);
      const std::string stem = dir + names[s][pos].substr(0, names[s][pos].size() - 4);
      testing::WriteText(stem + ".exact.png", "not a png");
    }
  RunSplit(split, tmp.File("b.zip"), o);
  const io::ZipContents zb = io::ZipContents::Read(tmp.File("b.zip"));
  EXPECT_EQ(za.files, zb.files);
  // Interrupted after the first scene and resumed: the same bytes (the window records go through the journal).
  {
    RunSpec spec;
    spec.data = split;
    spec.out = tmp.File("r.zip");
    spec.progress_bar = false;
    spec.on_progress = [](int64_t done, int64_t) {
      if (done == 3) throw std::runtime_error("interrupted");
    };
    EXPECT_THROW(ExecuteRun(spec, o), std::runtime_error);
    ASSERT_TRUE(fs::exists(tmp.File("r.zip.progress.jsonl")));
    spec.on_progress = nullptr;
    spec.resume = true;
    const RunResult resumed = ExecuteRun(spec, o);
    EXPECT_EQ(resumed.resumed_scenes, 1u);
    EXPECT_EQ(io::ZipContents::Read(tmp.File("r.zip")).files, zb.files);
    EXPECT_EQ(resumed.results.at("s00000")[1].window.votes.size(), 9u);
  }
  // --frames 1 is the single-frame answer on the same frames.
  const RunResult one = RunSplit(split, tmp.File("one.zip"), MultiFrameOptions("exact", 1, "auto"));
  PipelineOptions single = ResolvePreset("sift-essential");
  single.depth = DepthSpec::FromString("provided:exact");
  Relocalizer reloc(single);
  const io::MapfreeScene sc = io::MapfreeScene::Load(split + "/s00000");
  reloc.SetReference(sc.LoadImage(sc.reference), sc.reference.camera, sc.LoadDepth(sc.reference, "exact"));
  for (const auto& r : one.results.at("s00000")) {
    const io::MapfreeFrame* f = nullptr;
    for (const auto& q : sc.queries)
      if (q.name == r.frame) f = &q;
    ASSERT_NE(f, nullptr);
    const QueryResult s = reloc.Relocalize(sc.LoadImage(*f), f->camera, sc.LoadDepth(*f, "exact"));
    EXPECT_EQ(s.query_from_ref.translation, r.query_from_ref.translation) << r.frame;
    EXPECT_EQ(s.confidence, r.confidence);
  }
}

TEST(MultiFrameRun, EvalScoresTheEvaluatedFramesAsAnIndependentComputation) {
  testing::TempDir tmp;
  const std::string split = tmp.path() + "/val";
  const auto names = WriteSequences(split, 515151);
  const RunResult r = RunSplit(split, tmp.File("m.zip"), MultiFrameOptions("degraded8", 9, "ignore"));
  const eval::EvalRun run = eval::RunEvaluation(split, r.scenes, tmp.File("m.zip"), io::Track::kMultiFrame);
  // Independently: the camera-centre and rotation errors of the frames at linear positions 9 and 19, the median per
  // scene, the average of the medians (two frames per scene: the mean of the two).
  double sum_t = 0, sum_r = 0;
  int ok = 0;
  for (int s = 0; s < 2; ++s) {
    const std::string scene = "s0000" + std::to_string(s);
    const io::MapfreeScene& sc = r.loaded.at(scene);
    std::vector<double> te, re;
    for (const auto& q : r.results.at(scene)) {
      const Rigid3d& gt = sc.gt.at(q.frame);
      te.push_back((q.query_from_ref.Center() - gt.Center()).norm());
      re.push_back(RotationAngleDeg(q.query_from_ref.rotation, gt.rotation));
      ok += te.back() < 0.25 && re.back() < 5;
    }
    ASSERT_EQ(te.size(), 2u);
    sum_t += 0.5 * (te[0] + te[1]);
    sum_r += 0.5 * (re[0] + re[1]);
  }
  EXPECT_NEAR(run.overall.avg_median_trans, sum_t / 2, 1e-5);
  EXPECT_NEAR(run.overall.avg_median_rot, sum_r / 2, 1e-4);
  EXPECT_NEAR(run.overall.precision_pose, ok / 4.0, 1e-12);
  EXPECT_EQ(run.overall.estimates + run.overall.failures, 4);
}

}  // namespace
}  // namespace freeloc::pipeline
