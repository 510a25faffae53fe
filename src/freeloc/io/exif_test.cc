#include "freeloc/io/exif.h"

#include <gtest/gtest.h>

#include <cmath>

#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"
#include "testing/exif_writer.h"
#include "testing/testing.h"

namespace freeloc::io {
namespace {

using testing::ExifFields;
using testing::Rational;

// A 64 × 48 grey JPEG (what the EXIF rides on; its pixels do not matter here).
std::vector<uint8_t> PlainJpeg(int w = 64, int h = 48) {
  Image im(w, h);
  for (size_t i = 0; i < im.data.size(); ++i) im.data[i] = static_cast<uint8_t>(i * 7);
  return EncodeJpeg(im, 90, "test image");
}

TEST(Exif, NoExifIsAbsent) {
  const ExifInfo e = ReadExif(PlainJpeg());
  EXPECT_FALSE(e.present);
  Camera k;
  std::string why;
  EXPECT_FALSE(CameraFromExif(e, 64, 48, &k, &why));
  EXPECT_EQ(why, "no EXIF");
}

// A phone-like camera: 4.25 mm lens on a sensor of 5.6 mm across the stored width, written in every unit and both
// byte orders; the focal freeloc derives is the truth (f_mm × pixels per mm) to 0.1 %.
TEST(Exif, FocalFromFocalPlaneResolutionInEveryUnit) {
  const int w = 640, h = 480;
  const double f_mm = 4.25, sensor_w_mm = 5.6, truth = f_mm * w / sensor_w_mm;
  for (ExifByteOrder order : {EXIF_BYTE_ORDER_INTEL, EXIF_BYTE_ORDER_MOTOROLA})
    for (int unit : {2, 3, 4, 5}) {
      const double mm_per_unit = unit == 2 ? 25.4 : unit == 3 ? 10 : unit == 4 ? 1 : 1e-3;
      ExifFields f;
      f.order = order;
      f.focal_length = Rational(f_mm, 100);
      f.focal_plane_x = f.focal_plane_y = Rational(w / sensor_w_mm * mm_per_unit, unit == 5 ? 1000000 : 1000);
      f.focal_plane_unit = unit;
      const ExifInfo e = ReadExif(testing::WithExif(PlainJpeg(w, h), f));
      ASSERT_TRUE(e.present);
      EXPECT_TRUE(e.problems.empty()) << e.problems.front();
      Camera k;
      std::string why;
      ASSERT_TRUE(CameraFromExif(e, w, h, &k, &why)) << why;
      EXPECT_NEAR(k.fx / truth, 1.0, 1e-3) << "unit " << unit;
      EXPECT_NEAR(k.fy / truth, 1.0, 1e-3);
      EXPECT_DOUBLE_EQ(k.cx, 319.5);
      EXPECT_DOUBLE_EQ(k.cy, 239.5);
      EXPECT_EQ(k.width, w);
    }
}

// Without a unit tag the EXIF default (inch) applies; a file resized after the camera wrote its tags is scaled by
// PixelXDimension; non-square pixels keep fx != fy.
TEST(Exif, DefaultUnitResizeAndNonSquarePixels) {
  ExifFields f;
  f.focal_length = Rational(5.0);
  f.focal_plane_x = Rational(100 * 25.4);  // 100 px/mm
  f.focal_plane_y = Rational(101 * 25.4);
  f.pixel_x = 1280;  // the camera's image was twice the decoded one
  f.pixel_y = 960;
  const ExifInfo e = ReadExif(testing::WithExif(PlainJpeg(), f));
  Camera k;
  std::string why;
  ASSERT_TRUE(CameraFromExif(e, 640, 480, &k, &why)) << why;
  EXPECT_NEAR(k.fx, 5.0 * 100 * 0.5, 0.5 * 1e-3 * k.fx);
  EXPECT_NEAR(k.fy, 5.0 * 101 * 0.5, 0.5 * 1e-3 * k.fy);
}

// PixelX/YDimension written for the displayed image of a turned photo (some tools do) or for another aspect ratio (a
// crop: no scaling) are told apart by the aspect ratio.
TEST(Exif, PixelDimensionsOfTheDisplayedImageOrACrop) {
  ExifFields f;
  f.orientation = 6;
  f.focal_length = Rational(4.0);
  f.focal_plane_x = f.focal_plane_y = Rational(100);
  f.focal_plane_unit = 4;
  f.pixel_x = 1280;  // the displayed 1280 x 960 (the stored image is 960 x 1280): twice the decoded 640 x 480
  f.pixel_y = 960;
  Camera k;
  std::string why;
  ASSERT_TRUE(CameraFromExif(ReadExif(testing::WithExif(PlainJpeg(), f)), 640, 480, &k, &why)) << why;
  EXPECT_NEAR(k.fx, 200, 1e-6);
  f.orientation = 1;
  f.pixel_x = 700;  // a crop of another aspect ratio: the focal in pixels is unchanged
  f.pixel_y = 300;
  ASSERT_TRUE(CameraFromExif(ReadExif(testing::WithExif(PlainJpeg(), f)), 640, 480, &k, &why)) << why;
  EXPECT_NEAR(k.fx, 400, 1e-6);
}

// Only the 35 mm equivalent: 36 mm across the long side, in either orientation of the image.
TEST(Exif, FocalFrom35mmEquivalent) {
  ExifFields f;
  f.focal_35mm = 26;
  f.focal_length = Rational(4.2);  // no focal-plane resolution: the real focal alone says nothing in pixels
  const ExifInfo e = ReadExif(testing::WithExif(PlainJpeg(), f));
  EXPECT_EQ(e.focal_length_35mm, 26);
  for (auto [w, h] : {std::pair{640, 480}, std::pair{480, 640}, std::pair{600, 400}}) {
    Camera k;
    std::string why;
    ASSERT_TRUE(CameraFromExif(e, w, h, &k, &why));
    EXPECT_NEAR(k.fx, 26.0 / 36.0 * std::max(w, h), 1e-9);
    EXPECT_EQ(k.fx, k.fy);
    EXPECT_NE(why.find("35"), std::string::npos);
  }
}

// Orientations 5–8 (the decoder transposes): fx and fy swap, and the tags' PixelX/YDimension describe the stored
// (transposed) size.
TEST(Exif, TransposingOrientationsSwapTheFocals) {
  for (int o = 1; o <= 8; ++o) {
    ExifFields f;
    f.orientation = o;
    f.focal_length = Rational(4.0);
    f.focal_plane_x = Rational(150);
    f.focal_plane_y = Rational(160);
    f.focal_plane_unit = 4;
    f.pixel_x = 64;
    f.pixel_y = 48;
    const std::vector<uint8_t> bytes = testing::WithExif(PlainJpeg(64, 48), f);
    const ExifInfo e = ReadExif(bytes);
    ASSERT_EQ(e.orientation, o);
    const testing::TempDir tmp;
    WriteFileAtomic(tmp.File("p.jpg"), bytes.data(), bytes.size());
    ExifInfo read;
    const Image im = ReadImage(tmp.File("p.jpg"), &read);
    EXPECT_EQ(read.orientation, o);
    EXPECT_EQ(im.width, o >= 5 ? 48 : 64) << "orientation " << o;
    Camera k;
    std::string why;
    ASSERT_TRUE(CameraFromExif(read, im.width, im.height, &k, &why)) << why;
    EXPECT_NEAR(k.fx, o >= 5 ? 640 : 600, 1e-6) << "orientation " << o;
    EXPECT_NEAR(k.fy, o >= 5 ? 600 : 640, 1e-6);
  }
}

// Absurd or damaged values are refused with a reason, and the next source is tried.
TEST(Exif, AbsurdValuesFallThrough) {
  {  // a 5000 mm lens on a phone sensor: absurd; the 35 mm equivalent is used instead
    ExifFields f;
    f.focal_length = Rational(5000);
    f.focal_plane_x = Rational(1000);
    f.focal_plane_unit = 4;
    f.focal_35mm = 28;
    Camera k;
    std::string why;
    ASSERT_TRUE(CameraFromExif(ReadExif(testing::WithExif(PlainJpeg(), f)), 640, 480, &k, &why));
    EXPECT_NEAR(k.fx, 28.0 / 36 * 640, 1e-9);
  }
  {  // zero denominators, an orientation of 9 and a unit of 7: each a problem, nothing used
    ExifFields f;
    f.focal_length = {42, 0};
    f.focal_plane_x = {0, 0};
    f.orientation = 9;
    f.focal_plane_unit = 7;
    const ExifInfo e = ReadExif(testing::WithExif(PlainJpeg(), f));
    EXPECT_EQ(e.orientation, 0);
    EXPECT_EQ(e.focal_length_mm, 0);
    EXPECT_EQ(e.problems.size(), 3u);
    Camera k;
    std::string why;
    EXPECT_FALSE(CameraFromExif(e, 640, 480, &k, &why));
    EXPECT_FALSE(why.empty());
  }
  {  // a 35 mm equivalent of 2 mm (a 0.06× focal): absurd
    ExifFields f;
    f.focal_35mm = 2;
    Camera k;
    std::string why;
    EXPECT_FALSE(CameraFromExif(ReadExif(testing::WithExif(PlainJpeg(), f)), 640, 480, &k, &why));
    EXPECT_NE(why.find("absurd"), std::string::npos);
  }
}

// FocalPlaneResolutionUnit 1 ("no absolute unit") or 65535: the focal plane resolution is in no known length and is
// never read as inches (it gave fx 210.8 for 535.4, and an ok pose 8.9° off): the 35 mm equivalent when there is one,
// else no EXIF intrinsics, the reason named.
TEST(Exif, AFocalPlaneUnitThatIsNoLengthIsNotInches) {
  for (int unit : {1, 65535}) {
    SCOPED_TRACE(unit);
    ExifFields f;
    f.focal_length = Rational(4.2);
    f.focal_plane_x = Rational(1000);
    f.focal_plane_unit = unit;
    ExifInfo e = ReadExif(testing::WithExif(PlainJpeg(), f));
    EXPECT_EQ(e.focal_plane_unit, -1);
    Camera k;
    std::string why, refused;
    EXPECT_FALSE(CameraFromExif(e, 640, 480, &k, &why));
    EXPECT_NE(why.find("no known length unit"), std::string::npos) << why;
    f.focal_35mm = 28;
    e = ReadExif(testing::WithExif(PlainJpeg(), f));
    ASSERT_TRUE(CameraFromExif(e, 640, 480, &k, &why, &refused));
    EXPECT_NEAR(k.fx, 28.0 / 36 * 640, 1e-9);
    EXPECT_NE(refused.find("no known length unit"), std::string::npos) << refused;
  }
}

// Hostile segments: a length past the end of the file, a payload of garbage, a segment cut short — never a crash,
// never an invented value.
TEST(Exif, HostileSegments) {
  const std::vector<uint8_t> jpeg = PlainJpeg();
  std::vector<uint8_t> garbage(600);
  for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<uint8_t>(i * 131 + 7);
  std::memcpy(garbage.data(), "Exif\0\0", 6);
  ExifInfo e = ReadExif(testing::WithApp1(jpeg, garbage));
  EXPECT_EQ(e.orientation, 0);
  EXPECT_EQ(e.focal_length_mm, 0);
  ExifFields f;
  f.focal_35mm = 26;
  f.orientation = 6;
  std::vector<uint8_t> bytes = testing::WithExif(jpeg, f);
  bytes[4] = 0xFF;  // the segment claims 65 000 bytes
  bytes[5] = 0xE8;
  bytes.resize(40);
  e = ReadExif(bytes);
  EXPECT_FALSE(e.present);
  for (size_t cut = 0; cut < 120; cut += 3) {
    const std::vector<uint8_t> cut_bytes(bytes.begin(), bytes.begin() + std::min(cut, bytes.size()));
    EXPECT_NO_THROW(ReadExif(cut_bytes));
  }
  EXPECT_FALSE(ReadExif(nullptr, 0).present);
}

}  // namespace
}  // namespace freeloc::io
