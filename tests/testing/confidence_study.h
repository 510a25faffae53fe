// The confidence study, shared by pipeline/confidence_test.cc and bench/confidence: a
// seeded population of synthetic queries of varied difficulty — baseline, match count, pixel noise, outlier fraction,
// exact, degraded or monocular-like depth — run through one of the pipeline's solvers, scored with the
// official map-free errors, and ranked by several confidences to compare the AUCs they give. Header-only.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "freeloc/eval/metrics.h"
#include "freeloc/pipeline/relocalize_scene.h"
#include "testing/synthetic_scene.h"

namespace freeloc::testing {

struct StudyQuery {
  bool exact_depth = true;
  int depth_mode = 0;  // 0 exact, 1 degraded (DegradeDepth), 2 monocular-like (DegradeDepthMonocular)
  pipeline::QueryResult result;
  eval::FrameErrors err;  // official errors (valid when result.ok)
};

// Query `i` of the population (deterministic in `seed` and `i`), solved by `solver` (essential | hybrid | pnp |
// procrustes, optionally with a scale method: essential/robust, essential/official) on the precomputed
// correspondences: depth exact for i % 3 == 0, degraded for 1, monocular-like for 2.
inline StudyQuery RunStudyQuery(uint32_t seed, int i, int width, int height, const std::string& solver = "essential") {
  std::mt19937 rng(seed * 7919u + static_cast<uint32_t>(i));
  std::uniform_real_distribution<double> u01(0, 1);
  const double baseline = 0.1 + 1.4 * u01(rng);
  const int n = static_cast<int>(std::round(30 * std::pow(50.0, u01(rng))));  // 30 … 1500, log-uniform
  const double noise = 0.3 + 2.2 * u01(rng);
  const double outliers = 0.6 * u01(rng);
  StudyQuery q;
  q.depth_mode = i % 3;
  q.exact_depth = q.depth_mode == 0;
  const SyntheticScene sc = MakeRoomScene(seed + 100003u * static_cast<uint32_t>(i), baseline, width, height);
  std::vector<Eigen::Vector2d> p1, p2;
  sc.Correspondences(n, noise, rng(), &p1, &p2);
  std::uniform_real_distribution<double> ux(0, width - 1), uy(0, height - 1);
  for (size_t k = 0; k < p1.size(); ++k)
    if (u01(rng) < outliers) p2[k] = Eigen::Vector2d(ux(rng), uy(rng));
  DepthMap dr = sc.depth_ref, dq = sc.depth_query;
  if (q.depth_mode == 1) {
    const double g = 0.15 * u01(rng), sm = 0.10 * u01(rng), out = 0.30 * u01(rng);
    dr = DegradeDepth(dr, rng(), g, sm, out, 0.05);
    dq = DegradeDepth(dq, rng(), g, sm, out, 0.05);
  } else if (q.depth_mode == 2) {
    dr = DegradeDepthMonocular(dr, rng());
    dq = DegradeDepthMonocular(dq, rng());
  }
  std::vector<Eigen::Vector4d> pre;
  for (size_t k = 0; k < p1.size(); ++k) pre.emplace_back(p1[k].x(), p1[k].y(), p2[k].x(), p2[k].y());
  const size_t slash = solver.find('/');
  pipeline::PipelineOptions o = pipeline::ResolvePreset("precomputed:SIFT-" + solver.substr(0, slash));
  if (slash != std::string::npos) pipeline::SetOption(&o, "scale", solver.substr(slash + 1));
  o.depth = pipeline::DepthSpec::FromString("provided:synthetic");
  pipeline::Relocalizer reloc(o);
  reloc.SetReference(Image(width, height), sc.ref, dr);
  q.result = reloc.Relocalize(Image(width, height), sc.query, dq, &pre);
  if (q.result.ok() || q.result.weak()) {  // weak-support answers are submitted and ranked too
    auto official = [](const Rigid3d& query_from_ref) {
      io::OfficialPose p;
      const Eigen::Quaterniond c2w = query_from_ref.rotation.conjugate();
      p.q_c2w = {c2w.w(), c2w.x(), c2w.y(), c2w.z()};
      p.t_c2w = query_from_ref.Center();
      return p;
    };
    const std::array<float, 4> k = {static_cast<float>(sc.query.fx), static_cast<float>(sc.query.fy),
                                    static_cast<float>(sc.query.cx), static_cast<float>(sc.query.cy)};
    q.err = eval::ComputeFrameErrors(official(sc.query_from_ref), official(q.result.query_from_ref), k, width, height);
  }
  return q;
}

// The confidences compared.
enum class StudyConfidence { kInlierCount, kScaleSupport, kFreeloc, kOracle };
inline const char* StudyConfidenceName(StudyConfidence c) {
  switch (c) {
    case StudyConfidence::kInlierCount: return "inlier count";
    case StudyConfidence::kScaleSupport: return "scale-vote support";
    case StudyConfidence::kFreeloc: return "freeloc (predicted error)";
    case StudyConfidence::kOracle: return "oracle (−true error)";
  }
  return "?";
}

inline double StudyConfidenceOf(const StudyQuery& q, StudyConfidence c) {
  switch (c) {
    case StudyConfidence::kInlierCount: return q.result.inliers;
    case StudyConfidence::kScaleSupport: return q.result.scale_inliers;
    case StudyConfidence::kFreeloc: return q.result.confidence;
    case StudyConfidence::kOracle: return -std::max(q.err.trans_err / 0.25, q.err.rot_err / 5.0);
  }
  return 0;
}

struct StudyScore {
  double auc_pose = 0, auc_vcre = 0, precision_pose = 0, precision_vcre = 0;
  int estimates = 0, failures = 0;
};

// The official AUCs of `queries` (failures in the denominators) with confidence `c`.
inline StudyScore ScoreStudy(const std::vector<StudyQuery>& queries, StudyConfidence c) {
  std::vector<double> conf;
  std::vector<bool> pose_ok, vcre_ok;
  StudyScore s;
  for (const auto& q : queries) {
    if (!q.result.ok() && !q.result.weak()) {
      ++s.failures;
      continue;
    }
    conf.push_back(StudyConfidenceOf(q, c));
    pose_ok.push_back(q.err.trans_err < 0.25 && q.err.rot_err < 5.0);
    vcre_ok.push_back(q.err.vcre < 90.0);
  }
  s.estimates = static_cast<int>(conf.size());
  const double total = static_cast<double>(queries.size());
  s.precision_pose = std::count(pose_ok.begin(), pose_ok.end(), true) / total;
  s.precision_vcre = std::count(vcre_ok.begin(), vcre_ok.end(), true) / total;
  s.auc_pose = eval::PrecisionRecallAuc(conf, pose_ok, s.failures);
  s.auc_vcre = eval::PrecisionRecallAuc(conf, vcre_ok, s.failures);
  return s;
}

}  // namespace freeloc::testing
