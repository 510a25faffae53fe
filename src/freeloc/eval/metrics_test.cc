#include "freeloc/eval/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/eval/report.h"
#include "freeloc/io/submission.h"
#include "testing/testing.h"

namespace freeloc::eval {
namespace {

namespace fs = std::filesystem;

io::OfficialPose FromQueryFromRef(const Rigid3d& p, double conf = 0) {
  return io::ParseOfficialPoses(io::FormatPoseFile({{"seq1/frame_00000.jpg", p, conf}}), true).poses.at(0);
}

const std::array<float, 4> kK = {590.f, 591.f, 270.f, 360.f};

TEST(Metrics, KnownRotationAndTranslationErrors) {
  const Rigid3d gt(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 2, 3).normalized())),
                   Eigen::Vector3d(0.3, -0.1, 1.2));
  // Rotate the query camera by 10° about its own y axis, keeping its centre: rotation error 10°, translation 0.
  const Eigen::Quaterniond d(Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitY()));
  Rigid3d est;
  est.rotation = d * gt.rotation;
  est.translation = -(est.rotation * gt.Center());
  const FrameErrors e = ComputeFrameErrors(FromQueryFromRef(gt), FromQueryFromRef(est), kK, 540, 720);
  EXPECT_NEAR(e.rot_err, 10.0, 1e-9);
  EXPECT_NEAR(e.trans_err, 0.0, 1e-12);
  EXPECT_GT(e.vcre, 20.0);
  // Perfect estimate: all zero.
  const FrameErrors z = ComputeFrameErrors(FromQueryFromRef(gt), FromQueryFromRef(gt), kK, 540, 720);
  EXPECT_NEAR(z.rot_err, 0, 1e-6);
  EXPECT_NEAR(z.trans_err, 0, 1e-12);
  EXPECT_NEAR(z.vcre, 0, 1e-9);
  // Pure centre offset of 0.3 m along the optical axis.
  Rigid3d shifted = gt;
  shifted.translation = -(gt.rotation * (gt.Center() + Eigen::Vector3d(0.1, 0.2, 0.2)));
  EXPECT_NEAR(ComputeFrameErrors(FromQueryFromRef(gt), FromQueryFromRef(shifted), kK, 540, 720).trans_err, 0.3, 1e-12);
}

TEST(Metrics, VcreMatchesHandComputation) {
  // Identity GT; the estimate's camera centre is 0.1 m to the side (x). The virtual point X (camera frame) is seen by
  // the estimate at X + (0.1, 0, 0)... in its own frame: residual = T_est⁻¹·T_gt = translation −c_est.
  const Rigid3d gt;
  const Rigid3d est(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.1, 0, 0));  // centre (0.1,0,0)
  double sum = 0;
  int n = 0;
  for (int iy = 0; iy < 4; ++iy)
    for (int ix = 0; ix < 7; ++ix)
      for (int iz = 0; iz < 7; ++iz) {
        const double x = (ix - 3) * 0.3, y = (iy - 1.5) * 0.3, z = 1.8 + 0.3 * iz;
        const double u0 = std::clamp(590.0 * x / z + 270, 0.0, 540.0), v0 = std::clamp(591.0 * y / z + 360, 0.0, 720.0);
        const double u1 = std::clamp(590.0 * (x - 0.1) / z + 270, 0.0, 540.0);
        (void)v0;
        sum += std::abs(u1 - u0);
        ++n;
      }
  const FrameErrors e = ComputeFrameErrors(FromQueryFromRef(gt), FromQueryFromRef(est), kK, 540, 720);
  EXPECT_EQ(n, 196);
  EXPECT_NEAR(e.vcre, sum / n, 1e-9);
}

SceneRecord Scene(const std::string& name, std::vector<std::tuple<double, double, double, double>> frames,
                  int failures) {
  SceneRecord s;
  s.name = name;
  s.file_present = true;
  s.failures = failures;
  int64_t k = 0;
  for (auto [t, r, v, c] : frames) {
    FrameRecord f{name, k++, "submitted", {t, r, v}, c};
    s.frames.push_back(f);
  }
  for (int i = 0; i < failures; ++i) s.frames.push_back({name, k++, "missing", {}, 0});
  return s;
}

TEST(Metrics, ThresholdsAreStrict) {
  // Exactly 0.25 m / 5° / 90 px is not accepted; just below is.
  const Metrics m = Aggregate({Scene("a", {{0.25, 1, 90, 1}, {0.1, 5.0, 89.999, 1}, {0.2499999, 4.9999, 10, 1}}, 0)});
  EXPECT_NEAR(m.precision_pose, 1.0 / 3, 1e-15);
  EXPECT_NEAR(m.precision_vcre, 2.0 / 3, 1e-15);
}

TEST(Metrics, AucWithTiesByHand) {
  // conf 3,2,2,1; accepted 1,0,1,0; one failure. Points: (r .2, p 1), (r .6, p 2/3), (r .8, p .5).
  const double auc = PrecisionRecallAuc({3, 2, 2, 1}, {true, false, true, false}, 1);
  EXPECT_NEAR(auc, 0.2 * 1 + 0.4 * (2.0 / 3) + 0.2 * 0.5, 1e-7);
  // Tie order cannot matter.
  EXPECT_NEAR(PrecisionRecallAuc({2, 3, 1, 2}, {true, true, false, false}, 1), auc, 1e-12);
}

TEST(Metrics, EqualConfidencesGiveAucEqualToPrecision) {
  const Metrics m = Aggregate({Scene("a", {{0.1, 1, 10, 4}, {1.0, 1, 100, 4}, {0.1, 1, 10, 4}, {0.1, 1, 10, 4}}, 2)});
  EXPECT_NEAR(m.precision_pose, 0.5, 1e-15);
  EXPECT_NEAR(m.auc_pose, m.precision_pose, 1e-7);
  EXPECT_NEAR(m.auc_vcre, m.precision_vcre, 1e-7);
  EXPECT_NEAR(m.estimates_ratio, 4.0 / 6, 1e-15);
}

TEST(Metrics, AverageOfPerSceneMedians) {
  // Scene a medians: t 0.2 (even count: mean of 0.1 and 0.3); scene b: 1.0. Average: 0.6. A scene without
  // estimates takes no part in the medians but its failures count.
  const Metrics m =
      Aggregate({Scene("a", {{0.1, 1, 1, 1}, {0.3, 3, 3, 1}}, 0), Scene("b", {{1.0, 2, 2, 1}}, 1), Scene("c", {}, 3)});
  EXPECT_NEAR(m.avg_median_trans, 0.6, 1e-15);
  EXPECT_NEAR(m.avg_median_rot, 2.0, 1e-15);
  EXPECT_EQ(m.failures, 4);
  EXPECT_EQ(m.estimates, 3);
  EXPECT_EQ(m.scenes_with_estimates, 2);
  EXPECT_THROW(Aggregate({Scene("c", {}, 3)}), Error);
}

// ---- End to end on a dataset written to disk -------------------------------------------------------------------

struct Dataset {
  testing::TempDir tmp;
  std::string split() const { return tmp.path() + "/val"; }
  // A scene whose queries have the given frame numbers; GT poses random but seeded.
  std::map<int, Rigid3d> AddScene(const std::string& name, const std::vector<int>& frames, uint32_t seed) {
    const std::string dir = split() + "/" + name;
    fs::create_directories(dir);
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0, 0.3);
    std::string intr = "seq0/frame_00000.jpg 590 591 270 360 540 720\n", poses = "seq0/frame_00000.jpg 1 0 0 0 0 0 0\n";
    std::map<int, Rigid3d> gt;
    for (int f : frames) {
      char nm[64];
      std::snprintf(nm, sizeof(nm), "seq1/frame_%05d.jpg", f);
      const Rigid3d p(Eigen::Quaterniond(1, n(rng) * 0.2, n(rng) * 0.2, n(rng) * 0.2).normalized(),
                      Eigen::Vector3d(n(rng), n(rng), n(rng)));
      gt[f] = p;
      intr += std::string(nm) + " 590 591 270 360 540 720\n";
      poses += io::FormatPoseLine({nm, p, 0}).substr(0, io::FormatPoseLine({nm, p, 0}).rfind(' ')) + "\n";
    }
    testing::WriteText(dir + "/intrinsics.txt", intr);
    testing::WriteText(dir + "/poses.txt", poses);
    return gt;
  }
};

std::vector<io::SubmissionEntry> Entries(const std::map<int, Rigid3d>& poses, double conf = 1) {
  std::vector<io::SubmissionEntry> e;
  for (const auto& [f, p] : poses) {
    char nm[64];
    std::snprintf(nm, sizeof(nm), "seq1/frame_%05d.jpg", f);
    e.push_back({nm, p, conf});
  }
  return e;
}

TEST(Metrics, PerfectSubmissionRoundTrip) {
  Dataset d;
  const auto a = d.AddScene("s00460", {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, 1);
  const auto b = d.AddScene("s00461", {0, 2, 3, 7, 8, 9, 15, 16}, 2);  // skipped frame numbers
  io::WriteSubmission(d.tmp.File("perfect.zip"), {{"s00460", Entries(a)}, {"s00461", Entries(b)}});
  const EvalRun r = RunEvaluation(d.split(), {"s00460", "s00461"}, d.tmp.File("perfect.zip"));
  // Evaluated: keys at positions 0,5,10 of scene a (frames 0,5,10) and 0,5 of scene b (frames 0, 9).
  EXPECT_EQ(r.overall.estimates, 5);
  EXPECT_EQ(r.overall.failures, 0);
  ASSERT_EQ(r.scenes[1].frames.size(), 2u);
  EXPECT_EQ(r.scenes[1].frames[1].frame, 9);
  EXPECT_NEAR(r.overall.avg_median_trans, 0, 1e-12);
  EXPECT_NEAR(r.overall.avg_median_vcre, 0, 1e-9);
  EXPECT_EQ(r.overall.precision_pose, 1.0);
  EXPECT_EQ(r.overall.precision_vcre, 1.0);
  EXPECT_NEAR(r.overall.auc_vcre, 1.0, 1e-12);
  EXPECT_EQ(r.overall.estimates_ratio, 1.0);
}

TEST(Metrics, MissingSceneVersusSceneWithoutEvaluatedFrames) {
  Dataset d;
  const auto a = d.AddScene("s00460", {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, 1);
  const auto b = d.AddScene("s00461", {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, 2);
  const auto c = d.AddScene("s00462", {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, 3);
  // s00461 missing: all 12 GT keys fail (the seq0 line shares key 0). s00462 present but only frames 1 and 2,
  // neither evaluated: its 3 evaluated frames (0, 5, 10) fail.
  std::map<int, Rigid3d> c_some = {{1, c.at(1)}, {2, c.at(2)}};
  io::WriteSubmission(d.tmp.File("s.zip"), {{"s00460", Entries(a)}, {"s00462", Entries(c_some)}});
  const EvalRun r = RunEvaluation(d.split(), {"s00460", "s00461", "s00462"}, d.tmp.File("s.zip"));
  EXPECT_EQ(r.scenes[1].failures, 12);
  EXPECT_FALSE(r.scenes[1].file_present);
  EXPECT_EQ(r.scenes[2].failures, 3);
  EXPECT_EQ(r.overall.failures, 15);
  EXPECT_EQ(r.overall.estimates, 3);
  EXPECT_NEAR(r.overall.precision_pose, 3.0 / 18, 1e-15);
  EXPECT_EQ(r.overall.scenes_with_estimates, 1);
  (void)b;
}

TEST(Metrics, NoisyPosesAndMalformedLines) {
  Dataset d;
  const auto a = d.AddScene("s00460", {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15}, 1);
  auto noisy = a;
  noisy[5].translation += Eigen::Vector3d(0, 0, 0.5);  // 0.5 m off → pose rejected
  std::string text = io::FormatPoseFile(Entries(noisy));
  text +=
      "seq1/frame_00010.jpg 1 0 0 nan 0 0 0 1\n";  // NaN line for an evaluated frame: dropped, the earlier line stays
  text += "seq1/frame_00000.jpg 1 0 0 0 0 0 0\n";  // 8 fields: dropped
  io::WriteZipAtomic(d.tmp.File("n.zip"), {{"pose_s00460.txt", text}});
  const EvalRun r = RunEvaluation(d.split(), {"s00460"}, d.tmp.File("n.zip"));
  EXPECT_EQ(r.overall.estimates, 4);  // frames 0, 5, 10, 15
  EXPECT_EQ(r.scenes[0].dropped.size(), 2u);
  EXPECT_NEAR(r.overall.precision_pose, 0.75, 1e-15);
  EXPECT_NEAR(r.scenes[0].frames[1].err.trans_err, 0.5, 1e-12);
}

TEST(Metrics, ErrorsWhereTheOfficialEvaluatorPrintsNothing) {
  Dataset d;
  const auto a = d.AddScene("s00460", {0, 1, 2, 3, 4, 5}, 1);
  auto neg = Entries(a);
  std::string text = io::FormatPoseFile(neg);
  text += "seq1/frame_00005.jpg 1 0 0 0 0 0 0 -1\n";  // negative confidence on an evaluated frame
  io::WriteZipAtomic(d.tmp.File("neg.zip"), {{"pose_s00460.txt", text}});
  EXPECT_THROW(RunEvaluation(d.split(), {"s00460"}, d.tmp.File("neg.zip")), Error);
  io::WriteZipAtomic(d.tmp.File("latin1.zip"), {{"pose_s00460.txt", "seq1/frame_00000.jpg 1 0 0 0 0 0 0 1 \xe9\n"}});
  EXPECT_THROW(RunEvaluation(d.split(), {"s00460"}, d.tmp.File("latin1.zip")), Error);
  io::WriteZipAtomic(d.tmp.File("other.zip"), {{"pose_s99999.txt", io::FormatPoseFile(Entries(a))}});
  EXPECT_THROW(RunEvaluation(d.split(), {"s00460"}, d.tmp.File("other.zip")), Error);
  // A folder inside the ZIP: the official evaluator does not find pose_s00460.txt → counted failures, not an error.
  io::WriteZipAtomic(d.tmp.File("folder.zip"), {{"sub/pose_s00460.txt", io::FormatPoseFile(Entries(a))},
                                                {"pose_s00460.txt", io::FormatPoseFile(Entries(a))}});
  EXPECT_EQ(RunEvaluation(d.split(), {"s00460"}, d.tmp.File("folder.zip")).overall.failures, 0);
  io::WriteZipAtomic(d.tmp.File("only_folder.zip"), {{"sub/pose_s00460.txt", io::FormatPoseFile(Entries(a))}});
  EXPECT_THROW(RunEvaluation(d.split(), {"s00460"}, d.tmp.File("only_folder.zip")), Error);
  // Missing GT folder, intrinsics with 6 fields.
  EXPECT_THROW(RunEvaluation(d.split(), {"s00999"}, d.tmp.File("folder.zip")), Error);
  testing::WriteText(d.split() + "/s00460/intrinsics.txt", "seq0/frame_00000.jpg 590 591 270 360 540\n");
  try {
    RunEvaluation(d.split(), {"s00460"}, d.tmp.File("folder.zip"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("intrinsics.txt line 1"), std::string::npos) << e.what();
  }
}

TEST(Metrics, RealTumScenesPerfectSubmission) {
  const std::string split = testing::DemoPath("val");
  testing::TempDir tmp;
  std::map<std::string, std::vector<io::SubmissionEntry>> sub;
  for (const char* s : {"s00001", "s00002", "s00003"}) {
    // Re-emit the GT lines of the queries with a confidence.
    std::istringstream in(testing::ReadText(split + "/" + s + "/poses.txt"));
    std::string l;
    std::vector<io::SubmissionEntry> e;
    while (std::getline(in, l)) {
      std::istringstream ls(l);
      std::string name;
      double q[4], t[3];
      ls >> name >> q[0] >> q[1] >> q[2] >> q[3] >> t[0] >> t[1] >> t[2];
      if (name.rfind("seq1/", 0) != 0) continue;
      e.push_back({name, Rigid3d::FromWxyz({q[0], q[1], q[2], q[3]}, Eigen::Vector3d(t[0], t[1], t[2])), 1});
    }
    sub[s] = e;
  }
  io::WriteSubmission(tmp.File("gt.zip"), sub);
  const EvalRun r = RunEvaluation(split, {"s00001", "s00002", "s00003"}, tmp.File("gt.zip"));
  EXPECT_EQ(r.overall.estimates, 3);  // one evaluated key per scene (≤ 5 keys each)
  EXPECT_NEAR(r.overall.avg_median_trans, 0, 1e-9);
  EXPECT_NEAR(r.overall.avg_median_rot, 0, 1e-4);
  EXPECT_NEAR(r.overall.avg_median_vcre, 0, 1e-6);
  EXPECT_EQ(r.overall.precision_pose, 1.0);
  EXPECT_EQ(r.overall.precision_vcre, 1.0);
}

}  // namespace
}  // namespace freeloc::eval
