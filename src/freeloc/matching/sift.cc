#include "freeloc/matching/sift.h"

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>
#include <opencv2/imgproc.hpp>

#include "freeloc/core/error.h"

namespace freeloc::matching {

void SiftOptions::Validate() const {
  FREELOC_CHECK(num_features > 0, "SIFT: num_features must be positive");
  FREELOC_CHECK(ratio > 0 && ratio <= 1, "SIFT: the ratio test threshold must be in (0, 1]");
  FREELOC_CHECK(trees > 0 && checks > 0, "SIFT: FLANN trees and checks must be positive");
}

namespace {

cv::Mat Grey(const Image& im) {
  cv::Mat rgb(im.height, im.width, CV_8UC3, const_cast<uint8_t*>(im.data.data()));
  cv::Mat g;
  cv::cvtColor(rgb, g, cv::COLOR_RGB2GRAY);
  return g;
}

void RootSift(cv::Mat* d) {
  constexpr float kEps = 1e-7f;
  for (int r = 0; r < d->rows; ++r) {
    float* p = d->ptr<float>(r);
    float s = 0;
    for (int c = 0; c < d->cols; ++c) s += p[c];
    for (int c = 0; c < d->cols; ++c) p[c] = std::sqrt(p[c] / (s + kEps));
  }
}

}  // namespace

Correspondences MatchSift(const Image& ref, const Image& query, const SiftOptions& o) {
  o.Validate();
  FREELOC_CHECK(!ref.empty() && !query.empty(), "SIFT: empty image");
  auto sift = cv::SIFT::create(o.num_features);
  std::vector<cv::KeyPoint> k0, k1;
  cv::Mat d0, d1;
  sift->detectAndCompute(Grey(ref), cv::noArray(), k0, d0);
  sift->detectAndCompute(Grey(query), cv::noArray(), k1, d1);
  Correspondences out;
  if (k0.size() < 2 || k1.size() < 2) return out;
  if (o.root_sift) {
    RootSift(&d0);
    RootSift(&d1);
  }
  cvflann::seed_random(o.seed);
  cv::FlannBasedMatcher matcher(cv::makePtr<cv::flann::KDTreeIndexParams>(o.trees),
                                cv::makePtr<cv::flann::SearchParams>(o.checks));
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(d0, d1, knn, 2);
  for (const auto& m : knn) {
    if (m.size() < 2) continue;
    if (m[0].distance < o.ratio * m[1].distance) {
      const cv::Point2f a = k0[m[0].queryIdx].pt, b = k1[m[0].trainIdx].pt;
      out.ref.emplace_back(a.x, a.y);
      out.query.emplace_back(b.x, b.y);
    }
  }
  return out;
}

}  // namespace freeloc::matching
