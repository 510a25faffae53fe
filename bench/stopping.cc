// bench/stopping — when the robust solvers stop. Synthetic two-view problems like the pipeline's dense sets (points
// 1–10 m in front of both 640×480 cameras, 0.5 px noise; depths with 2 % noise for the hybrid solver), with a share
// of uniform outlier pairs (random depths too) — 100 % is a set with no consensus, as from non-overlapping or
// textureless pairs. Each cell runs the same problems with the search's rule for dense sets (the sequential
// probability ratio test and the give-up share, ransac.h) and without it (every hypothesis scored on every match,
// the search runs to its budget). The 500-match cells are sparse sets (MASt3R's or SIFT's few hundred matches), below
// the dense rule's minimum: both rows run the plain search, whose cost is the 5-point solver's. Columns: median and
// worst ms, outcomes, median rotation and translation-direction
// error of the answers, failures (an "ok" answer more than 5° off).
//
//   stopping [--trials T] [--quick]
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <map>
#include <random>

#include "bench_util.h"
#include "freeloc/geometry/hybrid_pose.h"
#include "freeloc/geometry/relative_pose.h"

using namespace freeloc;
using freeloc::bench::Fmt;

namespace {

struct Problem {
  Camera cam{600, 600, 320, 240, 640, 480};
  Rigid3d truth;
  std::vector<Eigen::Vector2d> p1, p2;
  std::vector<double> d1, d2;
};

Problem Make(uint32_t seed, int n, double outliers) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
  std::normal_distribution<double> g(0, 0.5), gd(0, 0.02);
  Problem p;
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  p.truth = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.25 * u(rng), axis)),
                    Eigen::Vector3d(u(rng), 0.3 * u(rng), 0.3 * u(rng)).normalized() * (0.5 + u01(rng)));
  const int n_out = static_cast<int>(std::round(outliers * n));
  while (static_cast<int>(p.p1.size()) < n - n_out) {
    const Eigen::Vector2d a(320 + 320 * u(rng), 240 + 240 * u(rng));
    const Eigen::Vector3d X = p.cam.Unproject(a.x(), a.y()) * (1 + 9 * u01(rng));
    const Eigen::Vector3d Y = p.truth * X;
    if (Y.z() < 0.1) continue;
    const Eigen::Vector2d b = p.cam.Project(Y);
    if (b.x() < 0 || b.y() < 0 || b.x() > 640 || b.y() > 480) continue;
    p.p1.push_back(a + Eigen::Vector2d(g(rng), g(rng)));
    p.p2.push_back(b + Eigen::Vector2d(g(rng), g(rng)));
    p.d1.push_back(X.z() * (1 + gd(rng)));
    p.d2.push_back(Y.z() * (1 + gd(rng)));
  }
  for (int i = 0; i < n_out; ++i) {
    p.p1.emplace_back(320 + 320 * u(rng), 240 + 240 * u(rng));
    p.p2.emplace_back(320 + 320 * u(rng), 240 + 240 * u(rng));
    p.d1.push_back(1 + 9 * u01(rng));
    p.d2.push_back(1 + 9 * u01(rng));
  }
  std::vector<int> idx(p.p1.size());
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
  std::shuffle(idx.begin(), idx.end(), rng);
  Problem q = p;
  for (size_t i = 0; i < idx.size(); ++i) {
    q.p1[i] = p.p1[idx[i]];
    q.p2[i] = p.p2[idx[i]];
    q.d1[i] = p.d1[idx[i]];
    q.d2[i] = p.d2[idx[i]];
  }
  return q;
}

double TransAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

struct Outcome {
  double ms = 0, rot = 180, tra = 180;
  std::string outcome, stop;
};

Outcome Run(const Problem& p, bool hybrid, bool dense_rule, uint64_t seed) {
  Outcome o;
  const double t0 = bench::NowSeconds();
  geometry::EstimatorStatus status;
  Rigid3d pose;
  if (hybrid) {
    geometry::HybridPoseOptions opt;
    opt.ransac.seed = seed;
    if (!dense_rule) opt.ransac.sprt_min_data = 0;
    const auto r = geometry::EstimateHybridPose(p.p1, p.p2, p.d1, p.d2, p.cam, p.cam, opt);
    status = r.status;
    pose = Rigid3d(Eigen::Quaterniond(r.model.R), r.model.t);
  } else {
    geometry::RelativePoseOptions opt;
    opt.ransac.seed = seed;
    if (!dense_rule) opt.ransac.sprt_min_data = 0;
    const auto r = geometry::EstimateRelativePose(p.p1, p.p2, p.cam, p.cam, opt);
    status = r.status;
    pose = r.query_from_ref;
  }
  o.ms = (bench::NowSeconds() - t0) * 1e3;
  o.outcome = ToString(status.outcome);
  o.stop = ToString(status.stop);
  if (status.outcome == geometry::EstimatorOutcome::kOk || status.outcome == geometry::EstimatorOutcome::kWeakSupport) {
    o.rot = RotationAngleDeg(pose.rotation, p.truth.rotation);
    o.tra = TransAngle(pose.translation, p.truth.translation);
  }
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  int trials = 5;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--trials") && i + 1 < argc)
      trials = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--quick"))
      quick = true;
    else {
      std::fprintf(stderr, "usage: stopping [--trials T] [--quick]\n");
      return 2;
    }
  }
  std::printf("## bench/stopping — robust solvers on dense sets, %d trials per cell, 1 thread\n\n%s\n\n", trials,
              bench::MachineLine().c_str());
  bench::MarkdownTable t({"solver", "N", "outliers", "rule", "median ms", "worst ms", "outcomes (stop)",
                          "median rot err (°)", "median t-dir err (°)", "failures"});
  struct Cell {
    int n;
    double outliers;
  };
  const std::vector<Cell> cells =
      quick ? std::vector<Cell>{{40000, 1.0}, {40000, 0.5}, {500, 1.0}}
            : std::vector<Cell>{{40000, 1.0},  {5000, 1.0},  {40000, 0.25}, {40000, 0.5}, {40000, 0.75}, {5000, 0.75},
                                {40000, 0.85}, {5000, 0.85}, {500, 1.0},    {500, 0.5},   {500, 0.8}};
  for (const bool hybrid : {false, true}) {
    for (const Cell& c : cells) {
      for (const bool dense_rule : {false, true}) {
        std::vector<double> ms, rot, tra;
        std::map<std::string, int> outcomes;
        int failures = 0;
        for (int k = 0; k < trials; ++k) {
          const Problem p = Make(1000 + 17 * k + static_cast<uint32_t>(c.n) + static_cast<uint32_t>(100 * c.outliers),
                                 c.n, c.outliers);
          const Outcome o = Run(p, hybrid, dense_rule, 7 + k);
          ms.push_back(o.ms);
          ++outcomes[o.outcome + " (" + o.stop + ")"];
          if (o.outcome == "ok" || o.outcome == "weak-support") {
            rot.push_back(o.rot);
            tra.push_back(o.tra);
          }
          failures += o.outcome == "ok" && o.rot > 5;
        }
        std::string oc;
        for (const auto& [name, count] : outcomes) oc += (oc.empty() ? "" : ", ") + std::to_string(count) + "× " + name;
        t.Row({hybrid ? "hybrid" : "relative", std::to_string(c.n), Fmt("%.0f %%", 100 * c.outliers),
               dense_rule ? "SPRT + give-up" : "to the budget", Fmt("%.0f", bench::Median(ms)),
               Fmt("%.0f", *std::max_element(ms.begin(), ms.end())), oc,
               rot.empty() ? "–" : Fmt("%.3f", bench::Median(rot)), tra.empty() ? "–" : Fmt("%.3f", bench::Median(tra)),
               std::to_string(failures)});
      }
    }
  }
  t.Print();
  return 0;
}
