// bench/relpose — robust relative pose on synthetic two-view problems (points 1–10 m in front of both cameras,
// 0.5 px noise, uniform outliers), N ∈ {1000, 5000} × outliers ∈ {25, 50, 75} %, 30 trials per cell, the same data
// for every method: freeloc (5-point LO-RANSAC + final refinement), OpenCV USAC_MAGSAC (UsacParams, honest
// iteration budget) and OpenCV RANSAC + recoverPose. Columns: median ms, median rotation error (°), median
// translation-direction error (°), failures (rotation error > 5°).
//
//   relpose [--trials T] [--threads N] [--quick]
#include <Eigen/Geometry>
#include <cstdio>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>

#include "bench_util.h"
#include "freeloc/geometry/relative_pose.h"

using namespace freeloc;
using freeloc::bench::Fmt;

namespace {

struct Problem {
  Camera ref{600, 600, 320, 240, 640, 480}, query{600, 600, 320, 240, 640, 480};
  Rigid3d truth;
  std::vector<Eigen::Vector2d> p1, p2;
};

Problem Make(uint32_t seed, int n, double outliers) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
  std::normal_distribution<double> g(0, 0.5);
  Problem p;
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  p.truth = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.25 * u(rng), axis)),
                    Eigen::Vector3d(u(rng), 0.3 * u(rng), 0.3 * u(rng)).normalized());
  const int n_out = static_cast<int>(std::round(outliers * n));
  while (static_cast<int>(p.p1.size()) < n - n_out) {
    Eigen::Vector2d a(320 + 320 * u(rng), 240 + 240 * u(rng));
    const Eigen::Vector3d X = p.ref.Unproject(a.x(), a.y()) * (1 + 9 * u01(rng));
    const Eigen::Vector3d Y = p.truth * X;
    if (Y.z() < 0.1) continue;
    Eigen::Vector2d b = p.query.Project(Y);
    if (b.x() < 0 || b.y() < 0 || b.x() > 640 || b.y() > 480) continue;
    p.p1.push_back(a + Eigen::Vector2d(g(rng), g(rng)));
    p.p2.push_back(b + Eigen::Vector2d(g(rng), g(rng)));
  }
  for (int i = 0; i < n_out; ++i) {
    p.p1.emplace_back(320 + 320 * u(rng), 240 + 240 * u(rng));
    p.p2.emplace_back(320 + 320 * u(rng), 240 + 240 * u(rng));
  }
  // Shuffle so inliers are not first.
  std::vector<int> idx(p.p1.size());
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
  std::shuffle(idx.begin(), idx.end(), rng);
  auto a = p.p1, b = p.p2;
  for (size_t i = 0; i < idx.size(); ++i) {
    p.p1[i] = a[idx[i]];
    p.p2[i] = b[idx[i]];
  }
  return p;
}

double TransAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

struct Outcome {
  double ms, rot, tra;
};

Outcome RunFreeloc(const Problem& p, uint64_t seed) {
  geometry::RelativePoseOptions o;
  o.ransac.seed = seed;
  const double t0 = bench::NowSeconds();
  const auto r = geometry::EstimateRelativePose(p.p1, p.p2, p.ref, p.query, o);
  const double ms = (bench::NowSeconds() - t0) * 1e3;
  if (!r.status.success()) return {ms, 180, 180};
  return {ms, RotationAngleDeg(r.query_from_ref.rotation, p.truth.rotation),
          TransAngle(r.query_from_ref.translation, p.truth.translation)};
}

// OpenCV on normalised coordinates with identity K, as the map-free baseline calls it.
Outcome RunOpenCv(const Problem& p, bool magsac) {
  std::vector<cv::Point2d> a, b;
  for (size_t i = 0; i < p.p1.size(); ++i) {
    const Eigen::Vector3d x = p.ref.Unproject(p.p1[i].x(), p.p1[i].y());
    const Eigen::Vector3d y = p.query.Unproject(p.p2[i].x(), p.p2[i].y());
    a.emplace_back(x.x(), x.y());
    b.emplace_back(y.x(), y.y());
  }
  const double th = 1.0 / 600.0;
  const double t0 = bench::NowSeconds();
  cv::Mat mask, E;
  if (magsac) {
    cv::UsacParams up;
    up.sampler = cv::SAMPLING_UNIFORM;
    up.score = cv::SCORE_METHOD_MAGSAC;
    up.loMethod = cv::LOCAL_OPTIM_SIGMA;
    up.loIterations = 10;
    up.loSampleSize = 50;
    up.confidence = 0.9999;
    up.maxIterations = 100000;  // honest budget (the findEssentialMat(USAC_MAGSAC) overload caps at 1000)
    up.threshold = th;
    up.isParallel = false;
    E = cv::findEssentialMat(a, b, cv::Mat::eye(3, 3, CV_64F), cv::Mat::eye(3, 3, CV_64F), cv::Mat(), cv::Mat(), mask,
                             up);
  } else {
    E = cv::findEssentialMat(a, b, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.9999, th, 1000, mask);
  }
  Outcome o{0, 180, 180};
  if (E.empty()) {
    o.ms = (bench::NowSeconds() - t0) * 1e3;
    return o;
  }
  int best = -1;
  cv::Mat bestR, bestt;
  for (int k = 0; k + 3 <= E.rows; k += 3) {
    cv::Mat R, t, m = mask.clone();
    const int n = cv::recoverPose(E.rowRange(k, k + 3), a, b, cv::Mat::eye(3, 3, CV_64F), R, t, m);
    if (n > best) {
      best = n;
      bestR = R;
      bestt = t;
    }
  }
  o.ms = (bench::NowSeconds() - t0) * 1e3;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  cv::cv2eigen(bestR, R);
  cv::cv2eigen(bestt, t);
  o.rot = RotationAngleDeg(Eigen::Quaterniond(R), p.truth.rotation);
  o.tra = TransAngle(t, p.truth.translation);
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  int trials = 30;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--trials") && i + 1 < argc)
      trials = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--quick"))
      quick = true;
    else {
      std::fprintf(stderr, "usage: relpose [--trials T] [--quick]\n");
      return 2;
    }
  }
  cv::setNumThreads(1);
  std::printf("## bench/relpose — synthetic two-view, 0.5 px noise, %d trials per cell, 1 thread\n\n", trials);
  bench::MarkdownTable t(
      {"N", "outliers", "method", "median ms", "median rot err (°)", "median t-dir err (°)", "failures"});
  const std::vector<int> ns = quick ? std::vector<int>{1000} : std::vector<int>{1000, 5000};
  for (int n : ns) {
    for (double out : {0.25, 0.5, 0.75}) {
      std::vector<Outcome> res[3];
      for (int trial = 0; trial < trials; ++trial) {
        const Problem p = Make(1000u * n + 100u * static_cast<uint32_t>(out * 100) + trial, n, out);
        res[0].push_back(RunFreeloc(p, trial));
        res[1].push_back(RunOpenCv(p, true));
        res[2].push_back(RunOpenCv(p, false));
      }
      const char* names[3] = {"freeloc", "OpenCV USAC_MAGSAC", "OpenCV RANSAC + recoverPose"};
      for (int m = 0; m < 3; ++m) {
        std::vector<double> ms, rot, tra;
        int fail = 0;
        for (const auto& o : res[m]) {
          ms.push_back(o.ms);
          rot.push_back(o.rot);
          tra.push_back(o.tra);
          fail += o.rot > 5;
        }
        t.Row({std::to_string(n), Fmt("%.0f %%", out * 100), names[m], Fmt("%.1f", bench::Median(ms)),
               Fmt("%.3f", bench::Median(rot)), Fmt("%.3f", bench::Median(tra)),
               Fmt("%.0f %%", 100.0 * fail / trials)});
      }
    }
  }
  t.Print();
  return 0;
}
