// libfreeloc_codecs.so: OpenCV's imgcodecs as the table io/internal/codecs_api.h declares. Depends on OpenCV only.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "freeloc/io/internal/codecs_api.h"

namespace {

bool DecodeRgbReduced(const uint8_t* bytes, size_t size, int reduce, freeloc::Image* out, std::string* error) {
  try {
    // The stored pixels: the EXIF orientation is applied by io (image_io.cc) from freeloc's own EXIF reading, so that
    // the orientation it reports and the image it decodes never disagree (OpenCV reads the tag its own way).
    const int flag = (reduce == 8   ? cv::IMREAD_REDUCED_COLOR_8
                      : reduce == 4 ? cv::IMREAD_REDUCED_COLOR_4
                      : reduce == 2 ? cv::IMREAD_REDUCED_COLOR_2
                                    : cv::IMREAD_COLOR) |
                     cv::IMREAD_IGNORE_ORIENTATION;
    const cv::Mat m = cv::imdecode(cv::Mat(1, static_cast<int>(size), CV_8UC1, const_cast<uint8_t*>(bytes)), flag);
    if (m.empty() || m.cols <= 0 || m.rows <= 0 || m.type() != CV_8UC3) {
      *error = m.empty() ? "" : "unexpected decoded pixel type";
      return false;
    }
    *out = freeloc::Image(m.cols, m.rows);
    cv::Mat rgb(m.rows, m.cols, CV_8UC3, out->data.data());
    cv::cvtColor(m, rgb, cv::COLOR_BGR2RGB);
    return true;
  } catch (const cv::Exception& e) {
    *error = e.what();
    return false;
  }
}

bool DecodeRgb(const uint8_t* bytes, size_t size, freeloc::Image* out, std::string* error) {
  return DecodeRgbReduced(bytes, size, 1, out, error);
}

bool ResizeArea(const freeloc::Image& in, int width, int height, freeloc::Image* out, std::string* error) {
  try {
    const cv::Mat src(in.height, in.width, CV_8UC3, const_cast<uint8_t*>(in.data.data()));
    *out = freeloc::Image(width, height);
    cv::Mat dst(height, width, CV_8UC3, out->data.data());
    cv::resize(src, dst, dst.size(), 0, 0, cv::INTER_AREA);
    return true;
  } catch (const cv::Exception& e) {
    *error = e.what();
    return false;
  }
}

bool EncodeJpeg(const freeloc::Image& rgb, int quality, std::vector<uint8_t>* out, std::string* error) {
  try {
    const cv::Mat in(rgb.height, rgb.width, CV_8UC3, const_cast<uint8_t*>(rgb.data.data()));
    cv::Mat bgr;
    cv::cvtColor(in, bgr, cv::COLOR_RGB2BGR);
    if (cv::imencode(".jpg", bgr, *out, {cv::IMWRITE_JPEG_QUALITY, quality})) return true;
    *error = "the encoder refused the image";
  } catch (const cv::Exception& e) {
    *error = e.what();
  }
  return false;
}

const freeloc::io::internal::CodecsApi kApi = {freeloc::io::internal::kCodecsAbi, DecodeRgb, EncodeJpeg,
                                               DecodeRgbReduced, ResizeArea};

}  // namespace

extern "C" __attribute__((visibility("default"))) const freeloc::io::internal::CodecsApi* freeloc_codecs_v1() {
  return &kApi;
}
