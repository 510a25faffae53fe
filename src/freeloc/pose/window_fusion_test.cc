// The Multi Frame fusion (window_fusion.h) on synthetic evidence, seeded, every device-pose variant: a true pose, a
// 9-frame path, per-frame answers with noise and depth-made range errors.
#include "freeloc/pose/window_fusion.h"

#include <gtest/gtest.h>

#include <random>

#include "freeloc/pipeline/record.h"

namespace freeloc::pose {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// The fusion on synthetic evidence: a true pose, a 9-frame path, per-frame answers with noise and a depth-made
// range error (`ref_scale`: shared by every frame, as a reference depth map's; `frame_sigma`: each frame's own),
// image relations whose lengths carry the evaluated frame's depth scale (`query_scale`), device relations from a
// tracker with 1 % scale error.

struct Truth {
  Rigid3d q_from_ref;
  std::vector<Rigid3d> j_from_q;  // the evaluated frame's own last (identity)
};

Eigen::Vector3d RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
}

Rigid3d Perturb(const Rigid3d& p, double rot_deg, double t_sigma, std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  const Eigen::Quaterniond dq(Eigen::AngleAxisd(rot_deg * M_PI / 180 * g(rng), RandomUnit(rng)));
  return Rigid3d(dq * p.rotation, p.translation + t_sigma * Eigen::Vector3d(g(rng), g(rng), g(rng)));
}

Truth MakeTruth(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Truth t;
  const Eigen::Quaterniond r(Eigen::AngleAxisd(0.2 * (u(rng) - 0.5), RandomUnit(rng)));
  const Eigen::Vector3d centre = (0.5 + 0.6 * u(rng)) * RandomUnit(rng);  // the query's centre in the reference
  t.q_from_ref = Rigid3d(r, -(r * centre));
  const Eigen::Vector3d v = (0.02 + 0.05 * u(rng)) * RandomUnit(rng);
  const Eigen::Vector3d axis = RandomUnit(rng);
  for (int k = -8; k <= 0; ++k) {
    const Eigen::Quaterniond rk(Eigen::AngleAxisd(0.005 * k, axis));  // ≈ 0.3° per frame
    const Eigen::Vector3d ck = v * k;                                 // frame k's centre in the query frame
    t.j_from_q.push_back(k == 0 ? Rigid3d() : Rigid3d(rk, -(rk * ck)));
  }
  return t;
}

struct EvidenceOptions {
  double ref_scale = 1, query_scale = 1, frame_sigma = 0;
  double rot_noise_deg = 0.05, dir_noise = 0.002;  // per frame answer
  enum Device { kNone, kDocumented, kOther, kGarbage } device = kNone;
  // The anchored scale's two halves per frame (geometry::AnchorScales): the reference map's anchoring off by
  // log(ref_scale), each frame's own map by its own N(0, map_sigma); the answer is their geometric mean.
  bool anchors = false;
  double map_sigma = 0.2;
  double relation_position_sigma = -1;  // ≥ 0: the image relations' predicted position error (else 3 mm + 5 %)
  bool relation_anchors = false;        // the image relations' lengths as each of their two maps anchors them
};

std::vector<FrameEvidence> MakeEvidence(const Truth& t, const EvidenceOptions& o, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u(0, 1);
  std::mt19937 dev_rng(seed ^ 0x9e3779b9u);  // the device poses' own draws: the images' evidence stays the same
  const Rigid3d tracker_from_ref(Eigen::Quaterniond(Eigen::AngleAxisd(6.28 * u(dev_rng), Eigen::Vector3d::UnitY())),
                                 Eigen::Vector3d(1, 0.2, -2));
  std::vector<FrameEvidence> ev(t.j_from_q.size());
  // Each frame's own depth map error (anchors), drawn apart so that the images' evidence stays the same.
  std::mt19937 map_rng(seed ^ 0x51ed270bu);
  std::vector<double> e_map(ev.size());
  for (double& e : e_map) e = o.map_sigma * g(map_rng);
  for (size_t k = 0; k < ev.size(); ++k) {
    FrameEvidence& e = ev[k];
    e.name = "seq1/frame_0000" + std::to_string(k + 1) + ".png";
    const Rigid3d j_from_ref = t.j_from_q[k] * t.q_from_ref;
    Rigid3d est = Perturb(j_from_ref, o.rot_noise_deg, 0, rng);
    double range = j_from_ref.translation.norm() * o.ref_scale * (1 + o.frame_sigma * g(rng));
    if (o.anchors) {
      const double truth = j_from_ref.translation.norm(), e_q = e_map[k];
      e.anchors.log_ref = std::log(truth * o.ref_scale);
      e.anchors.log_query = std::log(truth) + e_q;
      e.anchors.kept_ref = e.anchors.kept_query = 50;
      range = std::exp(0.5 * (e.anchors.log_ref + e.anchors.log_query));
    }
    est.translation = range * (j_from_ref.translation.normalized() + o.dir_noise * RandomUnit(rng)).normalized();
    e.to_ref.status = Status::kOk;
    e.to_ref.query_from_ref = est;
    e.to_ref.predicted_translation_m = 0.02 * range;
    e.to_ref.predicted_rotation_deg = 0.1;
    e.to_ref.confidence = 5;
    const bool self = k + 1 == ev.size();
    if (!self) {
      e.has_image_relation = true;
      e.image_relation_metric = true;
      e.image_relation = Perturb(t.j_from_q[k], 0.05, 0.002, rng);
      e.image_relation.translation *= o.query_scale;
      e.image_relation_rot_sigma_deg = 0.05;
      e.image_relation_position_sigma_m =
          o.relation_position_sigma >= 0 ? o.relation_position_sigma : 0.003 + 0.05 * t.j_from_q[k].translation.norm();
      if (o.relation_anchors) {  // the relation's length as the evaluated frame's map and this frame's map say it
        const double len = t.j_from_q[k].translation.norm();
        e.relation_anchors.log_ref = std::log(len) + e_map.back();
        e.relation_anchors.log_query = std::log(len) + e_map[k];
        e.relation_anchors.kept_ref = e.relation_anchors.kept_query = 50;
      }
    }
    if (o.device != EvidenceOptions::kNone) {
      e.has_device = true;
      if (self) continue;  // the identity
      if (o.device == EvidenceOptions::kDocumented) {
        e.device = Perturb(t.j_from_q[k], 0.03, 0.002, dev_rng);
        e.device.translation *= 1.01;
      } else if (o.device == EvidenceOptions::kOther) {
        const Rigid3d Pq = t.q_from_ref * tracker_from_ref.Inverse(), Pj = j_from_ref * tracker_from_ref.Inverse();
        e.device = Pq.Inverse() * Pj;
      } else {
        e.device = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * u(dev_rng), RandomUnit(dev_rng))),
                           0.4 * u(dev_rng) * RandomUnit(dev_rng));
      }
    }
  }
  return ev;
}

double CentreError(const PoseEstimate& r, const Truth& t) {
  return (r.query_from_ref.Center() - t.q_from_ref.Center()).norm();
}

// Medians over held-out seeds of the single frame's and the fused answer's camera-centre errors.
struct Study {
  double single = 0, fused = 0;
  int device_used = 0;
};

Study RunStudy(const EvidenceOptions& base, DevicePoseUse use, uint32_t first_seed, int n = 40) {
  std::vector<double> single, fused;
  Study s;
  std::mt19937 rng(first_seed);
  std::normal_distribution<double> g(0, 1);
  for (int i = 0; i < n; ++i) {
    const uint32_t seed = first_seed + 101u * static_cast<uint32_t>(i);
    const Truth t = MakeTruth(seed);
    EvidenceOptions o = base;
    // A monocular-like study draws each window's map scales (the reference's and the evaluated frame's).
    if (base.ref_scale != 1) o.ref_scale = std::exp(0.2 * g(rng)), o.query_scale = std::exp(0.2 * g(rng));
    const auto ev = MakeEvidence(t, o, seed + 7);
    const FusedWindow r = FuseWindow(ev, use);
    EXPECT_TRUE(r.ok()) << seed;
    EXPECT_TRUE(std::isfinite(r.confidence) && r.confidence > 0) << seed;
    single.push_back(CentreError(ev.back().to_ref, t));
    fused.push_back(CentreError(r, t));
    s.device_used += r.window.device.rfind("used", 0) == 0;
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  s.single = median(single);
  s.fused = median(fused);
  return s;
}

TEST(FuseWindow, MonocularDepthWithTrustworthyDevicePosesHalvesTheError) {
  EvidenceOptions o;
  o.ref_scale = 1.2;  // drawn per window by RunStudy
  o.frame_sigma = 0.1;
  o.device = EvidenceOptions::kDocumented;
  const Study s = RunStudy(o, DevicePoseUse::kAuto, 5001);
  EXPECT_EQ(s.device_used, 40);
  EXPECT_LE(s.fused, 0.5 * s.single) << s.fused << " vs " << s.single;
}

TEST(FuseWindow, MonocularDepthWithoutDevicePosesStillGains) {
  EvidenceOptions o;
  o.ref_scale = 1.2;
  o.frame_sigma = 0.1;
  const Study s = RunStudy(o, DevicePoseUse::kAuto, 6001);
  EXPECT_LE(s.fused, 0.9 * s.single) << s.fused << " vs " << s.single;
}

TEST(FuseWindow, EachFramesOwnDepthMapIsIndependentEvidence) {
  // Monocular-like maps, every one off by its own amount (the reference's too): the frames' own-map anchorings
  // average out what the reference map alone cannot.
  EvidenceOptions o;
  o.ref_scale = 1.2;  // drawn per window by RunStudy (σ 0.2 in log)
  o.anchors = true;
  o.relation_position_sigma = 0.5;  // relations too loose for a rig: the maps alone must make the gain
  const Study s = RunStudy(o, DevicePoseUse::kAuto, 6501);
  EXPECT_LE(s.fused, 0.8 * s.single) << s.fused << " vs " << s.single;
  // Good maps (1 % each): the single frame's answer is kept to within its noise.
  o.ref_scale = 1;
  o.map_sigma = 0.005;
  const Study good = RunStudy(o, DevicePoseUse::kAuto, 6501);
  EXPECT_LE(good.fused, 1.05 * good.single + 1e-3) << good.fused << " vs " << good.single;
}

// Every map at once (geometry/window_scale.h): each anchoring of a frame's answer and of its relation is a
// measurement of one scale through one map, so ten maps off by 20 % each give about √(2/10) of the single frame's
// scale error (0.45×; asked ≤ 0.7×). Good maps leave the single frame's answer as it is.
TEST(FuseWindow, AllDepthMapsAtOnceWithoutDevicePoses) {
  EvidenceOptions o;
  o.ref_scale = 1.2;  // drawn per window by RunStudy (σ 0.2 in log)
  o.anchors = true;
  o.relation_anchors = true;
  const Study s = RunStudy(o, DevicePoseUse::kIgnore, 7301, 60);
  std::printf("all maps at once: median centre error %.4f m vs single frame %.4f m (%.2f×)\n", s.fused, s.single,
              s.fused / s.single);
  EXPECT_LE(s.fused, 0.7 * s.single) << s.fused << " vs " << s.single;
  o.ref_scale = 1;
  o.map_sigma = 0.005;
  const Study good = RunStudy(o, DevicePoseUse::kIgnore, 7301, 60);
  EXPECT_LE(good.fused, 1.05 * good.single + 1e-3) << good.fused << " vs " << good.single;
}

// Good maps: a window that agrees with the evaluated frame leaves its pose exactly as it is; a window that shows it
// wrong (a move beyond twice its predicted error) still repairs it.
TEST(FuseWindow, GoodMapsKeepTheSingleFrameUnlessTheWindowShowsItWrong) {
  EvidenceOptions o;
  o.anchors = true;
  o.relation_anchors = true;
  o.map_sigma = 0.005;
  int kept = 0, repaired = 0;
  for (uint32_t seed = 8101; seed < 8121; ++seed) {
    const Truth t = MakeTruth(seed);
    std::vector<FrameEvidence> ev = MakeEvidence(t, o, seed + 3);
    const FusedWindow agree = FuseWindow(ev, DevicePoseUse::kIgnore);
    kept += agree.query_from_ref.translation == ev.back().to_ref.query_from_ref.translation &&
            agree.window.scale == "single frame (the window agrees)";
    // The evaluated frame's answer 10 % long: five times its predicted error of 2 %.
    ev.back().to_ref.query_from_ref.translation *= 1.1;
    const FusedWindow fixed = FuseWindow(ev, DevicePoseUse::kIgnore);
    repaired += CentreError(fixed, t) < 0.5 * CentreError(ev.back().to_ref, t);
  }
  EXPECT_GE(kept, 18);
  EXPECT_GE(repaired, 18);
}

TEST(FuseWindow, DevicePosesInAnotherConventionOrGarbageAreIgnored) {
  for (auto kind : {EvidenceOptions::kOther, EvidenceOptions::kGarbage}) {
    EvidenceOptions o;
    o.ref_scale = 1.2;
    o.frame_sigma = 0.1;
    o.device = kind;
    const Study s = RunStudy(o, DevicePoseUse::kAuto, 7001);
    EvidenceOptions without = o;
    without.device = EvidenceOptions::kNone;
    const Study images = RunStudy(without, DevicePoseUse::kAuto, 7001);
    // A tracker world whose heading happens to match the cameras' (within ~10°: 3 of these 40 windows) makes the
    // other convention nearly the documented one, and the check lets it through; otherwise it is refused. The
    // answers stay as good as the images' alone (within 2 %).
    EXPECT_LE(s.device_used, kind == EvidenceOptions::kGarbage ? 0 : 4) << kind;
    EXPECT_LE(s.fused, images.fused * 1.02) << kind;
    // The same windows without device poses: identical answers.
    EvidenceOptions none = o;
    none.device = EvidenceOptions::kNone;
    for (uint32_t seed : {7001u, 7102u, 7203u}) {
      const Truth t = MakeTruth(seed);
      const FusedWindow a = FuseWindow(MakeEvidence(t, o, seed + 7), DevicePoseUse::kAuto);
      const FusedWindow b = FuseWindow(MakeEvidence(t, none, seed + 7), DevicePoseUse::kAuto);
      EXPECT_EQ(a.query_from_ref.translation, b.query_from_ref.translation) << kind << " " << seed;
      EXPECT_EQ(a.window.device.rfind("ignored", 0), 0u) << a.window.device;
    }
  }
}

TEST(FuseWindow, ExactDepthKeepsTheSingleFramesAccuracy) {
  EvidenceOptions o;  // no scale error anywhere: the per-frame noise only
  o.frame_sigma = 0.01;
  for (auto device : {EvidenceOptions::kNone, EvidenceOptions::kDocumented}) {
    o.device = device;
    const Study s = RunStudy(o, DevicePoseUse::kAuto, 8001);
    EXPECT_LE(s.fused, 1.05 * s.single) << device << ": " << s.fused << " vs " << s.single;
  }
}

TEST(FuseWindow, AFrameThatDisagreesLosesItsVote) {
  const Truth t = MakeTruth(9001);
  EvidenceOptions o;
  auto ev = MakeEvidence(t, o, 9008);
  const FusedWindow clean = FuseWindow(ev, DevicePoseUse::kAuto);
  // Frame 2 answers with a rotation 20° off, frame 5 with a ray 30° off.
  ev[2].to_ref.query_from_ref.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(20 * M_PI / 180, Eigen::Vector3d::UnitY())) *
      ev[2].to_ref.query_from_ref.rotation;
  ev[5].to_ref.query_from_ref.translation =
      Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d::UnitX()) * ev[5].to_ref.query_from_ref.translation;
  const FusedWindow r = FuseWindow(ev, DevicePoseUse::kAuto);
  EXPECT_FALSE(r.window.votes[2].used);
  EXPECT_FALSE(r.window.votes[5].used);
  EXPECT_EQ(r.window.used, 7);
  EXPECT_LT(CentreError(r, t), CentreError(clean, t) + 0.01);
  EXPECT_LT(RotationAngleDeg(r.query_from_ref.rotation, t.q_from_ref.rotation), 0.2);
}

TEST(FuseWindow, TheEvaluatedFrameFailsButItsWindowAnswers) {
  const Truth t = MakeTruth(9101);
  auto ev = MakeEvidence(t, EvidenceOptions{}, 9108);
  ev.back().to_ref = PoseEstimate();
  ev.back().to_ref.status = Status::kNoConsensus;
  const FusedWindow r = FuseWindow(ev, DevicePoseUse::kAuto);
  EXPECT_EQ(r.status, Status::kOk);
  EXPECT_LT(CentreError(r, t), 0.05);
  EXPECT_EQ(r.window.used, 8);
  // Nothing answered: the evaluated frame's own failure.
  for (auto& e : ev) e.to_ref.status = Status::kNoConsensus;
  EXPECT_EQ(FuseWindow(ev, DevicePoseUse::kAuto).status, Status::kNoConsensus);
}

TEST(FuseWindow, DevicePosesNotAnchoredAtTheEvaluatedFrameAreRefused) {
  const Truth t = MakeTruth(9201);
  EvidenceOptions o;
  o.device = EvidenceOptions::kDocumented;
  auto ev = MakeEvidence(t, o, 9208);
  EXPECT_EQ(FuseWindow(ev, DevicePoseUse::kUse).window.device, "used");
  ev.back().device.translation = Eigen::Vector3d(0.1, 0, 0);
  const FusedWindow r = FuseWindow(ev, DevicePoseUse::kUse);
  EXPECT_NE(r.window.device.find("not the identity"), std::string::npos) << r.window.device;
  EXPECT_EQ(FuseWindow(ev, DevicePoseUse::kIgnore).window.device, "off");
}

TEST(FuseWindow, TheWindowsAccountSurvivesTheRecord) {
  const Truth t = MakeTruth(9301);
  EvidenceOptions o;
  o.device = EvidenceOptions::kGarbage;
  const FusedWindow r = FuseWindow(MakeEvidence(t, o, 9308), DevicePoseUse::kAuto);
  ASSERT_EQ(r.window.votes.size(), 9u);
  pipeline::QueryResult q;
  static_cast<PoseEstimate&>(q) = r;
  q.window = r.window;
  const pipeline::QueryResult back = pipeline::QueryResultFromJson(pipeline::QueryRecordJson("s00000", q));
  EXPECT_EQ(back.window.frames, 9);
  EXPECT_EQ(back.window.used, r.window.used);
  EXPECT_EQ(back.window.device, r.window.device);
  EXPECT_EQ(back.window.scale, r.window.scale);
  EXPECT_EQ(back.window.rig_distance_m, r.window.rig_distance_m);
  for (size_t k = 0; k < 9; ++k) {
    EXPECT_EQ(back.window.votes[k].frame, r.window.votes[k].frame);
    EXPECT_EQ(back.window.votes[k].relation, r.window.votes[k].relation);
    EXPECT_EQ(back.window.votes[k].used, r.window.votes[k].used);
    EXPECT_EQ(back.window.votes[k].rotation_dev_deg, r.window.votes[k].rotation_dev_deg);
  }
  EXPECT_EQ(back.query_from_ref.translation, r.query_from_ref.translation);
}

}  // namespace
}  // namespace freeloc::pose
