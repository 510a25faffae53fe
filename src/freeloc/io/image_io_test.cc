#include "freeloc/io/image_io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "freeloc/core/error.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/safetensors.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

// 64×32 (W×H): left half red, right half blue (RGB).
cv::Mat TwoColourBgr() {
  cv::Mat m(32, 64, CV_8UC3, cv::Scalar(0, 0, 255));  // BGR red
  m(cv::Rect(32, 0, 32, 32)).setTo(cv::Scalar(255, 0, 0));
  return m;
}

std::string Encode(const cv::Mat& m, const char* ext) {
  std::vector<uint8_t> buf;
  cv::imencode(ext, m, buf);
  return std::string(buf.begin(), buf.end());
}

// Inserts an APP1 Exif segment carrying only an Orientation tag right after the JPEG SOI marker.
std::string WithExifOrientation(const std::string& jpeg, int orientation) {
  const char tiff[] = {'M',  'M',
                       0,    42,
                       0,    0,
                       0,    8,  // big-endian TIFF header, IFD at 8
                       0,    1,  // one entry
                       0x01, 0x12,
                       0,    3,
                       0,    0,
                       0,    1,  // tag 0x0112 SHORT count 1
                       0,    static_cast<char>(orientation),
                       0,    0,  // value
                       0,    0,
                       0,    0};  // no next IFD
  std::string seg = "\xFF\xE1";
  const int len = 2 + 6 + static_cast<int>(sizeof(tiff));
  seg += static_cast<char>(len >> 8);
  seg += static_cast<char>(len & 0xFF);
  seg += std::string("Exif\0\0", 6);
  seg += std::string(tiff, sizeof(tiff));
  return jpeg.substr(0, 2) + seg + jpeg.substr(2);
}

Image DecodeString(const std::string& s, const std::string& what = "mem") {
  return DecodeImage(std::vector<uint8_t>(s.begin(), s.end()), what);
}

bool IsRed(const Image& im, int x, int y) { return im.at(x, y, 0) > 200 && im.at(x, y, 2) < 60; }
bool IsBlue(const Image& im, int x, int y) { return im.at(x, y, 2) > 200 && im.at(x, y, 0) < 60; }

TEST(ImageIo, DecodesRgbOrder) {
  const Image im = DecodeString(Encode(TwoColourBgr(), ".png"));
  ASSERT_EQ(im.width, 64);
  ASSERT_EQ(im.height, 32);
  EXPECT_EQ(im.at(0, 0, 0), 255);
  EXPECT_EQ(im.at(0, 0, 2), 0);
  EXPECT_EQ(im.at(63, 31, 2), 255);
}

TEST(ImageIo, HonoursExifOrientation) {
  const std::string jpeg = Encode(TwoColourBgr(), ".jpg");
  {  // no tag: as stored
    const Image im = DecodeString(jpeg);
    EXPECT_EQ(im.width, 64);
    EXPECT_TRUE(IsRed(im, 4, 16));
  }
  {  // 6: rotate 90° clockwise to display → 32×64, red on top
    const Image im = DecodeString(WithExifOrientation(jpeg, 6));
    ASSERT_EQ(im.width, 32);
    ASSERT_EQ(im.height, 64);
    EXPECT_TRUE(IsRed(im, 16, 4));
    EXPECT_TRUE(IsBlue(im, 16, 60));
  }
  {  // 3: rotate 180° → blue on the left
    const Image im = DecodeString(WithExifOrientation(jpeg, 3));
    ASSERT_EQ(im.width, 64);
    EXPECT_TRUE(IsBlue(im, 4, 16));
    EXPECT_TRUE(IsRed(im, 60, 16));
  }
  {  // 8: rotate 90° counter-clockwise → red at the bottom
    const Image im = DecodeString(WithExifOrientation(jpeg, 8));
    ASSERT_EQ(im.width, 32);
    EXPECT_TRUE(IsBlue(im, 16, 4));
    EXPECT_TRUE(IsRed(im, 16, 60));
  }
}

// The orientation is applied by freeloc from its own EXIF reading: for every well-formed tag the pixels are those
// OpenCV's own orientation gives (the behaviour before), byte for byte.
TEST(ImageIo, OrientationMatchesOpenCvForAllEight) {
  cv::Mat m(24, 40, CV_8UC3);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) m.at<cv::Vec3b>(y, x) = cv::Vec3b(x * 6, y * 10, (x * 7 + y * 3) % 256);
  const std::string jpeg = Encode(m, ".jpg");
  for (int o = 1; o <= 8; ++o) {
    SCOPED_TRACE(o);
    const std::string bytes = WithExifOrientation(jpeg, o);
    const Image ours = DecodeString(bytes);
    cv::Mat ref = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())),
                               cv::IMREAD_COLOR);
    cv::cvtColor(ref, ref, cv::COLOR_BGR2RGB);
    ASSERT_EQ(ours.width, ref.cols);
    ASSERT_EQ(ours.height, ref.rows);
    EXPECT_EQ(std::memcmp(ours.data.data(), ref.data, ours.data.size()), 0);
  }
}

// Tags OpenCV and freeloc's reader used to read differently — the Orientation as a LONG, with a count of 0, in an
// Exif segment after an XMP one: the image decoded is always turned as the orientation freeloc reports (the depth
// checks and the fx/fy swap rely on it).
TEST(ImageIo, TheReportedOrientationIsTheDecodedOne) {
  const std::string jpeg = Encode(TwoColourBgr(), ".jpg");
  const auto check = [](const std::string& bytes, int expected) {
    const ExifInfo e = ReadExif(std::vector<uint8_t>(bytes.begin(), bytes.end()));
    EXPECT_EQ(e.orientation, expected);
    const Image im = DecodeString(bytes);
    EXPECT_EQ(im.width, e.transposed() ? 32 : 64);
    EXPECT_EQ(im.height, e.transposed() ? 64 : 32);
  };
  std::string as_long = WithExifOrientation(jpeg, 6);  // type SHORT (3) → LONG (4), the value in 4 bytes
  const size_t tiff = 2 + 4 + 6;                       // SOI, APP1 marker + length, "Exif\0\0"
  as_long[tiff + 10 + 3] = 4;
  as_long[tiff + 10 + 8] = 0, as_long[tiff + 10 + 9] = 0, as_long[tiff + 10 + 10] = 0, as_long[tiff + 10 + 11] = 6;
  check(as_long, 6);
  std::string count0 = WithExifOrientation(jpeg, 6);
  count0[tiff + 10 + 7] = 0;  // count 1 → 0
  check(count0, 0);
  const std::string xmp_payload = std::string("http://ns.adobe.com/xap/1.0/\0", 29) + "<x:xmpmeta/>";
  std::string xmp = "\xFF\xE1";
  xmp += static_cast<char>((xmp_payload.size() + 2) >> 8);
  xmp += static_cast<char>((xmp_payload.size() + 2) & 0xFF);
  xmp += xmp_payload;
  const std::string after_xmp = WithExifOrientation(jpeg, 6);
  check(after_xmp.substr(0, 2) + xmp + after_xmp.substr(2), 6);
}

// A working resolution (image_io.h): a large JPEG decodes reduced — JPEG's scaled decoding, then an area resize —
// at the size asked, in its displayed orientation, keeping the photo's own size; its pixels are those of the full
// decode reduced. A PNG (no scaled decoding) and a photo already small enough decode as before.
TEST(ImageIo, ReducedDecodeKeepsThePhotoSizeAndOrientation) {
  // 2400×1200 stored: a red left half, a blue right half, a green square near the top left (seeded noise on top).
  cv::Mat m(1200, 2400, CV_8UC3, cv::Scalar(0, 0, 255));
  m(cv::Rect(1200, 0, 1200, 1200)).setTo(cv::Scalar(255, 0, 0));
  m(cv::Rect(200, 200, 400, 400)).setTo(cv::Scalar(0, 255, 0));
  cv::Mat noise(m.size(), CV_8UC3);
  cv::randu(noise, 0, 20);
  m += noise;
  for (int orientation : {1, 6}) {
    SCOPED_TRACE(orientation);
    const std::string jpeg = WithExifOrientation(Encode(m, ".jpg"), orientation);
    const std::vector<uint8_t> bytes(jpeg.begin(), jpeg.end());
    const Image full = DecodeImage(bytes, "mem");
    const Image reduced = DecodeImage(bytes, "mem", 700);
    const bool turned = orientation == 6;
    ASSERT_EQ(reduced.width, turned ? 350 : 700);
    ASSERT_EQ(reduced.height, turned ? 700 : 350);
    EXPECT_EQ(reduced.PhotoWidth(), full.width);
    EXPECT_EQ(reduced.PhotoHeight(), full.height);
    const Image shrunk = ShrinkImage(full, reduced.width, reduced.height);
    double diff = 0;
    for (size_t i = 0; i < reduced.data.size(); ++i) diff += std::abs(reduced.data[i] - shrunk.data[i]);
    EXPECT_LT(diff / reduced.data.size(), 3.0);
    // The green square where the full decode has it, scaled.
    const int gx = turned ? 350 - 1 - 80 : 80, gy = 80;
    EXPECT_GT(reduced.at(gx, gy, 1), 200) << reduced.at(gx, gy, 0) << " " << reduced.at(gx, gy, 2);
  }
  const std::string png = Encode(m, ".png");
  const Image p = DecodeImage(std::vector<uint8_t>(png.begin(), png.end()), "mem", 700);
  EXPECT_EQ(p.width, 700);
  EXPECT_EQ(p.PhotoWidth(), 2400);
  const Image small = DecodeImage(std::vector<uint8_t>(png.begin(), png.end()), "mem", 4000);
  EXPECT_EQ(small.width, 2400);
  EXPECT_EQ(small.photo_width, 0);
}

TEST(ImageIo, TruncatedFilesAreErrors) {
  const std::string png = Encode(TwoColourBgr(), ".png");
  const std::string jpg = Encode(TwoColourBgr(), ".jpg");
  try {
    DecodeString(png.substr(0, png.size() / 2), "cut.png");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.png: PNG has no IEND chunk"), std::string::npos) << e.what();
  }
  try {
    DecodeString(jpg.substr(0, jpg.size() - 40), "cut.jpg");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.jpg: JPEG ends inside its image data (truncated)"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(DecodeString(png.substr(0, 10)), Error);
  EXPECT_THROW(DecodeString(""), Error);
}

// A JPEG whose APP1 segment carries an EXIF thumbnail (a whole JPEG, with its own end-of-image marker) and that is cut
// right after that segment: an FF D9 sits near the end, but the image has no frame or scan. Pillow refuses it ("image
// file is truncated"); so must we. Cut inside the segment, inside the scan, or missing only the final marker: refused.
TEST(ImageIo, JpegTruncatedAfterAnEarlyMarkerIsRefused) {
  const std::string jpg = Encode(TwoColourBgr(), ".jpg");
  const std::string thumb = Encode(TwoColourBgr()(cv::Rect(0, 0, 8, 8)), ".jpg");
  std::string app1 = "\xFF\xE1";
  const size_t len = 2 + 6 + thumb.size();
  app1 += static_cast<char>(len >> 8);
  app1 += static_cast<char>(len & 0xFF);
  app1 += std::string("Exif\0\0", 6) + thumb;
  const std::string whole = jpg.substr(0, 2) + app1 + jpg.substr(2);
  EXPECT_EQ(DecodeString(whole).width, 64);  // the complete file is fine
  const std::string cut = jpg.substr(0, 2) + app1;
  ASSERT_NE(cut.find("\xFF\xD9", cut.size() - 8), std::string::npos);  // the thumbnail's marker near the end
  const std::string e = testing::ErrorOf([&] { DecodeString(cut, "cut.jpg"); });
  EXPECT_NE(e.find("cut.jpg: JPEG ends before its end-of-image marker"), std::string::npos) << e;
  EXPECT_FALSE(testing::ErrorOf([&] { DecodeString(jpg.substr(0, 2) + app1.substr(0, 30)); }).empty());
  EXPECT_FALSE(testing::ErrorOf([&] { DecodeString(whole.substr(0, whole.size() - 2)); }).empty());
  // Any cut at all of a baseline file is refused.
  for (size_t n = 2; n + 2 < whole.size(); n += 37) EXPECT_THROW(DecodeString(whole.substr(0, n)), Error) << n;
}

// 16-bit greyscale PNGs reach the networks as Pillow's convert("RGB") gives them (mode I;16 → RGB clips each value to
// 255; Pillow's Convert.c I16_RGB), not as OpenCV's high byte: the network input must equal the reference's.
TEST(ImageIo, SixteenBitGreyPngDecodesAsPillowConvertsIt) {
  testing::TempDir tmp;
  const std::vector<uint16_t> v = {0, 1, 200, 255, 256, 1000, 40000, 65535};
  WritePng16(tmp.File("g16.png"), 4, 2, v);
  const Image im = ReadImage(tmp.File("g16.png"));
  ASSERT_EQ(im.width, 4);
  ASSERT_EQ(im.height, 2);
  for (size_t i = 0; i < v.size(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(im.data[3 * i + c], std::min<int>(v[i], 255)) << i;
  // 8-bit grey and 16-bit RGB keep their decoding (Pillow: L → RGB copies; RGB;16 keeps the high byte, as OpenCV).
  WritePng8(tmp.File("g8.png"), 2, 1, {7, 250});
  const Image g8 = ReadImage(tmp.File("g8.png"));
  EXPECT_EQ(g8.data, (std::vector<uint8_t>{7, 7, 7, 250, 250, 250}));
}

TEST(ImageIo, ContentDecidesNotTheExtension) {
  testing::TempDir tmp;
  const std::string png = Encode(TwoColourBgr(), ".png");
  testing::WriteBytes(tmp.File("a.png"), png);
  testing::WriteBytes(tmp.File("really_png.jpg"), png);
  EXPECT_EQ(ReadImage(tmp.File("a.png")), ReadImage(tmp.File("really_png.jpg")));
  testing::WriteText(tmp.File("notes.png"), "these are not pixels");
  try {
    ReadImage(tmp.File("notes.png"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("notes.png: not a supported image"), std::string::npos) << e.what();
  }
  testing::WriteText(tmp.File("anim.gif"), "GIF89a\x01\x00\x01\x00");
  EXPECT_THROW(ReadImage(tmp.File("anim.gif")), Error);
  EXPECT_THROW(ReadImage(tmp.File("missing.png")), Error);
}

TEST(ImageIo, PngRoundTripAndSixteenBit) {
  testing::TempDir tmp;
  Image im(5, 3);
  for (size_t i = 0; i < im.data.size(); ++i) im.data[i] = static_cast<uint8_t>(i * 7);
  WriteImagePng(tmp.File("x.png"), im);
  EXPECT_EQ(ReadImage(tmp.File("x.png")), im);
  std::vector<uint16_t> d = {0, 1, 1000, 65535, 5000, 42};
  WritePng16(tmp.File("d.png"), 3, 2, d);
  int w, h;
  EXPECT_EQ(ReadPng16(tmp.File("d.png"), &w, &h), d);
  EXPECT_EQ(w, 3);
  EXPECT_EQ(h, 2);
}

TEST(ImageIo, FixturePngsDecodeExactly) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/preprocess.safetensors");
  const SafetensorsFile pre = SafetensorsFile::Open(testing::SharedPath("fixtures/dust3r/preprocess.safetensors"));
  for (const char* k : {"img_a", "img_b", "img_c", "img_d"}) {
    SCOPED_TRACE(k);
    const Image im = ReadImage(testing::SharedPath(std::string("fixtures/dust3r/images/") + k + ".png"));
    const TensorView& ref = pre.Get(std::string(k) + ".orig_u8");
    ASSERT_EQ(ref.shape, (std::vector<int64_t>{im.height, im.width, 3}));
    EXPECT_EQ(std::memcmp(ref.data, im.data.data(), ref.nbytes), 0);
  }
}

}  // namespace
}  // namespace freeloc::io

namespace freeloc::io {
namespace {

// Depth and mask PNGs go through libpng directly (no OpenCV codecs at start-up): every grey variant must decode to
// the values OpenCV's IMREAD_UNCHANGED gives, PNGs freeloc writes must read back in OpenCV unchanged, and damaged or
// non-grey files must be one-line errors.
TEST(ImageIo, GreyPngsDecodeAsOpenCvDoes) {
  testing::TempDir tmp;
  cv::Mat g16(37, 53, CV_16UC1), g8(37, 53, CV_8UC1);
  cv::randu(g16, 0, 65535);
  cv::randu(g8, 0, 255);
  for (const cv::Mat* m : {&g16, &g8}) {
    for (int level : {0, 9}) {
      std::vector<uint8_t> buf;
      ASSERT_TRUE(cv::imencode(".png", *m, buf, {cv::IMWRITE_PNG_COMPRESSION, level}));
      WriteFileAtomic(tmp.File("g.png"), buf.data(), buf.size());
      int w = 0, h = 0, bits = 0;
      const std::vector<uint16_t> v = ReadPng16(tmp.File("g.png"), &w, &h, &bits);
      ASSERT_EQ(w, 53);
      ASSERT_EQ(h, 37);
      EXPECT_EQ(bits, m->depth() == CV_16U ? 16 : 8);
      cv::Mat ref;
      m->convertTo(ref, CV_16U);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          ASSERT_EQ(v[static_cast<size_t>(y) * w + x], ref.at<uint16_t>(y, x)) << x << "," << y;
    }
  }
  // freeloc's writers → OpenCV's reader, exactly.
  std::vector<uint16_t> d(53 * 37);
  for (size_t i = 0; i < d.size(); ++i) d[i] = static_cast<uint16_t>(i * 977 % 65536);
  WritePng16(tmp.File("w16.png"), 53, 37, d);
  const cv::Mat back = cv::imread(tmp.File("w16.png"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.type(), CV_16UC1);
  for (size_t i = 0; i < d.size(); ++i)
    ASSERT_EQ(back.at<uint16_t>(static_cast<int>(i / 53), static_cast<int>(i % 53)), d[i]);
  Image rgb(5, 4);
  for (size_t i = 0; i < rgb.data.size(); ++i) rgb.data[i] = static_cast<uint8_t>(i * 37);
  WriteImagePng(tmp.File("rgb.png"), rgb);
  EXPECT_EQ(ReadImage(tmp.File("rgb.png")).data, rgb.data);
  // A colour PNG is not a depth map; a damaged image stream is an error naming the file.
  int w, h;
  EXPECT_NE(
      testing::ErrorOf([&] { ReadPng16(tmp.File("rgb.png"), &w, &h); }).find("expected a single-channel PNG, got 3"),
      std::string::npos);
  std::vector<uint8_t> buf;
  cv::imencode(".png", g16, buf, {cv::IMWRITE_PNG_COMPRESSION, 0});
  for (size_t i = 100; i < 400; ++i) buf[i] ^= 0x5A;  // inside IDAT: CRC and zlib errors
  WriteFileAtomic(tmp.File("bad.png"), buf.data(), buf.size());
  const std::string e = testing::ErrorOf([&] { ReadPng16(tmp.File("bad.png"), &w, &h); });
  EXPECT_NE(e.find("bad.png: cannot decode the PNG"), std::string::npos) << e;
}

}  // namespace
}  // namespace freeloc::io
