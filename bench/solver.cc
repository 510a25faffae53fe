// bench/solver — the calibrated 5-point solver alone: µs per call on random generic problems, for the essential
// matrices only and with the decomposition + cheirality that freeloc's RANSAC uses; OpenCV's 5-point
// (findEssentialMat on exactly 5 points, i.e. its minimal solver plus its bookkeeping) in the same run.
//
//   solver [--calls N]
#include <Eigen/Geometry>
#include <cstdio>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <random>

#include "bench_util.h"
#include "freeloc/geometry/five_point.h"

using namespace freeloc::geometry;
using freeloc::bench::Fmt;

int main(int argc, char** argv) {
  int calls = 20000;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--calls") && i + 1 < argc) calls = std::atoi(argv[++i]);
  }
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  struct P {
    Eigen::Vector3d x1[5], x2[5];
  };
  std::vector<P> probs(1000);
  for (auto& p : probs) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(0.3 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    const Eigen::Vector3d t = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    for (int i = 0; i < 5;) {
      const Eigen::Vector3d X(2 * u(rng), 2 * u(rng), 5.5 + 4.5 * u(rng));
      const Eigen::Vector3d Y = R * X + t;
      if (Y.z() < 0.5) continue;
      p.x1[i] = X / X.z();
      p.x2[i] = Y / Y.z();
      ++i;
    }
  }
  size_t sink = 0;
  auto time = [&](auto&& fn) {
    const double t0 = freeloc::bench::NowSeconds();
    for (int c = 0; c < calls; ++c) sink += fn(probs[c % probs.size()]);
    return (freeloc::bench::NowSeconds() - t0) / calls * 1e6;
  };
  const double us_e = time([](const P& p) {
    std::vector<Eigen::Matrix3d> es;
    return static_cast<size_t>(FivePointEssential(p.x1, p.x2, &es));
  });
  const double us_pose = time([](const P& p) {
    std::vector<PoseRt> poses;
    return static_cast<size_t>(FivePointRelativePose(p.x1, p.x2, &poses));
  });
  const int cv_calls = std::min(calls, 2000);
  const double t0 = freeloc::bench::NowSeconds();
  for (int c = 0; c < cv_calls; ++c) {
    const P& p = probs[c % probs.size()];
    std::vector<cv::Point2d> a, b;
    for (int i = 0; i < 5; ++i) {
      a.emplace_back(p.x1[i].x(), p.x1[i].y());
      b.emplace_back(p.x2[i].x(), p.x2[i].y());
    }
    cv::Mat E = cv::findEssentialMat(a, b, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.99, 1e-3, 1);
    sink += static_cast<size_t>(E.rows);
  }
  const double us_cv = (freeloc::bench::NowSeconds() - t0) / cv_calls * 1e6;
  std::printf("## bench/solver — calibrated 5-point, %d calls over 1000 random problems, 1 thread\n\n", calls);
  freeloc::bench::MarkdownTable t({"solver", "µs per call"});
  t.Row({"freeloc FivePointEssential (E only)", Fmt("%.1f", us_e)});
  t.Row({"freeloc FivePointRelativePose (E + decomposition + cheirality)", Fmt("%.1f", us_pose)});
  t.Row({"OpenCV findEssentialMat on 5 points (RANSAC, 1 iteration)", Fmt("%.1f", us_cv)});
  t.Print();
  std::printf("\n(checksum %zu)\n", sink);
  return 0;
}
