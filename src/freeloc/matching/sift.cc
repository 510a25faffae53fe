#include "freeloc/matching/sift.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

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

SiftFeatures ExtractSift(const Image& image, const SiftOptions& o) {
  o.Validate();
  FREELOC_CHECK(!image.empty(), "SIFT: empty image");
  auto sift = cv::SIFT::create(o.num_features);
  std::vector<cv::KeyPoint> k;
  cv::Mat d;
  sift->detectAndCompute(Grey(image), cv::noArray(), k, d);
#if defined(__GLIBC__)
  // SIFT's scale space (about 300 MB for a 1600-pixel photo) is freed into glibc's heap, which keeps it for the
  // process: handed back here, in the stage that used it, rather than when the process ends.
  malloc_trim(0);
#endif
  if (o.root_sift && !k.empty()) RootSift(&d);
  SiftFeatures f;
  for (const auto& kp : k) f.points.emplace_back(kp.pt.x, kp.pt.y);
  if (!k.empty()) {
    f.dim = d.cols;
    f.descriptors.resize(static_cast<size_t>(d.rows) * d.cols);
    for (int r = 0; r < d.rows; ++r)
      std::copy(d.ptr<float>(r), d.ptr<float>(r) + d.cols, f.descriptors.begin() + static_cast<size_t>(r) * d.cols);
  }
  return f;
}

Correspondences MatchSiftFeatures(const SiftFeatures& ref, const SiftFeatures& query, const SiftOptions& o) {
  o.Validate();
  Correspondences out;
  if (ref.size() < 2 || query.size() < 2) return out;
  const cv::Mat d0(static_cast<int>(ref.size()), ref.dim, CV_32F, const_cast<float*>(ref.descriptors.data()));
  const cv::Mat d1(static_cast<int>(query.size()), query.dim, CV_32F, const_cast<float*>(query.descriptors.data()));
  cvflann::seed_random(o.seed);
  cv::FlannBasedMatcher matcher(cv::makePtr<cv::flann::KDTreeIndexParams>(o.trees),
                                cv::makePtr<cv::flann::SearchParams>(o.checks));
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(d0, d1, knn, 2);
  for (const auto& m : knn) {
    if (m.size() < 2) continue;
    if (m[0].distance < o.ratio * m[1].distance) {
      const Eigen::Vector2f& a = ref.points[static_cast<size_t>(m[0].queryIdx)];
      const Eigen::Vector2f& b = query.points[static_cast<size_t>(m[0].trainIdx)];
      out.ref.emplace_back(a.x(), a.y());
      out.query.emplace_back(b.x(), b.y());
    }
  }
  return out;
}

Correspondences MatchSift(const Image& ref, const Image& query, const SiftOptions& o) {
  FREELOC_CHECK(!ref.empty() && !query.empty(), "SIFT: empty image");
  return MatchSiftFeatures(ExtractSift(ref, o), ExtractSift(query, o), o);
}

}  // namespace freeloc::matching
