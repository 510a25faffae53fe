#include "freeloc/geometry/competing_models.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "freeloc/core/rigid3d.h"
#include "freeloc/geometry/five_point.h"
#include "freeloc/geometry/ransac.h"
#include "freeloc/geometry/refine_relative_pose.h"

namespace freeloc::geometry {

namespace {
constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
constexpr double kDistinctRotationDeg = 1.0;
constexpr double kDistinctDirectionDeg = 5.0;

double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

bool ValidDepth(const std::vector<double>& d, size_t i) { return i < d.size() && d[i] > 0 && std::isfinite(d[i]); }
}  // namespace

bool DistinctModels(const PoseRt& a, const PoseRt& b) {
  return RotationDistanceDeg(a.R, b.R) >= kDistinctRotationDeg ||
         DirectionDistanceDeg(a.t, b.t) >= kDistinctDirectionDeg;
}

double RotationDistanceDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return RotationAngleDeg(Eigen::Quaterniond(a), Eigen::Quaterniond(b));
}

double DirectionDistanceDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double na = a.norm(), nb = b.norm();
  if (!(na > 0) || !(nb > 0)) return 0;
  return std::acos(std::clamp(a.dot(b) / (na * nb), -1.0, 1.0)) * kRadToDeg;
}

ModelEvidence EvaluateRelativeModel(const std::vector<Eigen::Vector3d>& x1, const std::vector<Eigen::Vector3d>& x2,
                                    const PoseRt& pose, double threshold_sq, const DepthSamples& depth,
                                    double sigma_rad) {
  ModelEvidence ev;
  const Eigen::Matrix3d E = EssentialFromPose(pose);
  // Per in-front inlier with a depth: log(depth / triangulated depth), constant (the scale of t) on the right model.
  std::vector<double> lr, lq;
  std::vector<size_t> ir, iq;
  for (size_t i = 0; i < x1.size(); ++i) {
    if (!(SampsonSquared(E, x1[i], x2[i]) < threshold_sq)) continue;
    ++ev.inliers;
    double l1, l2;
    if (!TriangulateDepths(pose, x1[i], x2[i], &l1, &l2) || !(l1 > 0) || !(l2 > 0)) continue;
    ++ev.in_front;
    if (ValidDepth(depth.ref, i)) {
      lr.push_back(std::log(depth.ref[i] / l1));
      ir.push_back(i);
    }
    if (ValidDepth(depth.query, i)) {
      lq.push_back(std::log(depth.query[i] / l2));
      iq.push_back(i);
    }
  }
  // Reprojection through each depth map at the scale its depths agree on (median): the angle between the moved
  // point and the observed ray within 6σ (a few pixels).
  const double tau2 = 36.0 * sigma_rad * sigma_rad;
  for (int side = 0; side < 2; ++side) {
    const auto& l = side == 0 ? lr : lq;
    const auto& idx = side == 0 ? ir : iq;
    if (l.empty()) continue;
    ev.depth_samples += static_cast<int>(l.size());
    const Eigen::Vector3d t = pose.t * std::exp(Median(l));  // t in the depth's unit
    for (size_t i : idx) {
      const Eigen::Vector3d moved = side == 0 ? Eigen::Vector3d(pose.R * (depth.ref[i] * x1[i]) + t)
                                              : Eigen::Vector3d(pose.R.transpose() * (depth.query[i] * x2[i] - t));
      const Eigen::Vector3d& seen = side == 0 ? x2[i] : x1[i];
      const double e = moved.dot(seen) > 0 ? moved.normalized().cross(seen.normalized()).squaredNorm() : 1.0;
      ev.depth_reprojection_inliers += e < tau2;
    }
  }
  return ev;
}

std::vector<CompetingModel> FindCompetingRelativeModels(const std::vector<Eigen::Vector3d>& x1,
                                                        const std::vector<Eigen::Vector3d>& x2, const PoseRt& best,
                                                        const std::vector<int>& best_inliers, double threshold_sq,
                                                        double loss_scale, uint64_t seed, int samples,
                                                        double min_support_ratio, int max_models,
                                                        std::vector<CompetingModel>* near) {
  std::vector<CompetingModel> out;
  const size_t n_in = best_inliers.size();
  if (n_in < 8 || x1.size() != x2.size()) return out;
  // Scoring set: every correspondence, or an even subsample of 4000 on dense sets (support ratios only).
  std::vector<int> score_idx;
  const size_t stride = std::max<size_t>(1, x1.size() / 2000);
  for (size_t i = 0; i < x1.size(); i += stride) score_idx.push_back(static_cast<int>(i));
  auto support = [&](const PoseRt& p) {
    const Eigen::Matrix3d E = EssentialFromPose(p);
    int n = 0;
    for (int i : score_idx) n += SampsonSquared(E, x1[i], x2[i]) < threshold_sq;
    return n;
  };
  const int best_support = support(best);
  if (best_support == 0) return out;
  // Distinct hypotheses from minimal samples of the winner's inliers, clustered (the best of each cluster kept).
  std::vector<CompetingModel> clusters;
  SplitMix64 rng(seed ^ 0xC0FFEE1234567ull);
  std::vector<PoseRt> poses;
  int sample[5];
  for (int it = 0; it < samples; ++it) {
    for (int k = 0; k < 5; ++k) {
      bool dup;
      do {
        sample[k] = best_inliers[rng.Below(static_cast<uint32_t>(n_in))];
        dup = false;
        for (int j = 0; j < k; ++j) dup |= sample[j] == sample[k];
      } while (dup);
    }
    FivePointRelativePose(x1, x2, sample, &poses);
    for (const PoseRt& p : poses) {
      if (!DistinctModels(p, best)) {
        if (near) near->push_back({p, support(p)});
        continue;
      }
      const int s = support(p);
      if (s < 0.5 * min_support_ratio * best_support) continue;
      auto c = std::find_if(clusters.begin(), clusters.end(),
                            [&](const CompetingModel& m) { return !DistinctModels(m.pose, p); });
      if (c == clusters.end()) {
        clusters.push_back({p, s});
      } else if (s > c->inliers) {
        *c = {p, s};
      }
    }
  }
  std::sort(clusters.begin(), clusters.end(), [](const auto& a, const auto& b) { return a.inliers > b.inliers; });
  // Refine the strongest few as the winner was refined (two rounds on their own inliers); keep those that stay
  // distinct from the winner, from each other, and strong enough.
  for (size_t k = 0; k < clusters.size() && k < static_cast<size_t>(2 * max_models); ++k) {
    PoseRt p = clusters[k].pose;
    for (int round = 0; round < 2; ++round) {
      std::vector<int> in;  // on the scoring set: a dense set's rival is refined on ≤ 4000 of its matches
      const Eigen::Matrix3d E = EssentialFromPose(p);
      for (int i : score_idx)
        if (SampsonSquared(E, x1[i], x2[i]) < threshold_sq) in.push_back(i);
      if (in.size() < 6) break;
      RefineRelativePose(x1, x2, in, loss_scale, 10, &p);
    }
    const int s = support(p);
    if (s < min_support_ratio * best_support || !DistinctModels(p, best)) continue;
    if (std::any_of(out.begin(), out.end(), [&](const CompetingModel& m) { return !DistinctModels(m.pose, p); }))
      continue;
    out.push_back({p, s * static_cast<int>(stride)});
    if (out.size() >= static_cast<size_t>(max_models)) break;
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.inliers > b.inliers; });
  if (near) {
    std::sort(near->begin(), near->end(), [](const auto& a, const auto& b) { return a.inliers > b.inliers; });
    if (near->size() > 8) near->resize(8);
    for (auto& m : *near) m.inliers *= static_cast<int>(stride);
  }
  return out;
}

}  // namespace freeloc::geometry
