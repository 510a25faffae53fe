#include "freeloc/vision/metric3d_preprocess.h"

#include <algorithm>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "freeloc/core/error.h"

namespace freeloc::vision {

Metric3dInput PrepareMetric3dInput(const Image& image, int H, int W) {
  FREELOC_CHECK(!image.empty(), "Metric3D: empty image");
  FREELOC_CHECK(H > 0 && W > 0 && H % 28 == 0 && W % 28 == 0,
                "Metric3D: input size " << H << "x" << W << " must be multiples of 28");
  Metric3dInput in;
  in.height = H;
  in.width = W;
  in.scale = std::min(static_cast<double>(H) / image.height, static_cast<double>(W) / image.width);
  in.resized_h = static_cast<int>(image.height * in.scale);
  in.resized_w = static_cast<int>(image.width * in.scale);
  FREELOC_CHECK(in.resized_h > 0 && in.resized_w > 0,
                "Metric3D: image " << image.width << "x" << image.height << " is too elongated for the input size");
  const cv::Mat src(image.height, image.width, CV_8UC3, const_cast<uint8_t*>(image.data.data()));
  cv::Mat resized;
  cv::resize(src, resized, cv::Size(in.resized_w, in.resized_h), 0, 0, cv::INTER_LINEAR);
  const int ph = H - in.resized_h, pw = W - in.resized_w;
  in.pad = {ph / 2, ph - ph / 2, pw / 2, pw - pw / 2};
  cv::Mat padded;
  cv::copyMakeBorder(resized, padded, in.pad[0], in.pad[1], in.pad[2], in.pad[3], cv::BORDER_CONSTANT,
                     cv::Scalar(123.675, 116.28, 103.53));
  in.resized = Image(in.resized_w, in.resized_h);
  std::copy(resized.data, resized.data + in.resized.data.size(), in.resized.data.begin());
  in.padded = Image(W, H);
  std::copy(padded.data, padded.data + in.padded.data.size(), in.padded.data.begin());
  const float mean[3] = {123.675f, 116.28f, 103.53f}, std[3] = {58.395f, 57.12f, 57.375f};
  in.input.resize(static_cast<size_t>(3) * H * W);
  for (size_t p = 0; p < static_cast<size_t>(H) * W; ++p)
    for (int c = 0; c < 3; ++c)
      in.input[c * static_cast<size_t>(H) * W + p] = (static_cast<float>(in.padded.data[3 * p + c]) - mean[c]) / std[c];
  return in;
}

}  // namespace freeloc::vision
