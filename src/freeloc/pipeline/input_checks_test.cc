#include "freeloc/inputs/input_checks.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/pipeline/relocalizer.h"
#include "testing/testing.h"

namespace freeloc::pipeline {
namespace {

Camera K(double fx, double fy, double cx, double cy) { return Camera{fx, fy, cx, cy}; }

// The message inputs::CheckIntrinsics throws for `k` on a 640×480 photo ("" when it passes).
std::string IntrinsicsError(const Camera& k, const InputOptions& o = {}, inputs::InputNotes* notes = nullptr) {
  try {
    inputs::CheckIntrinsics(k, 640, 480, o, "query intrinsics", notes);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

bool Has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(InputChecks, IntrinsicsThatFitPass) {
  EXPECT_EQ(IntrinsicsError(K(535.4, 539.2, 320.1, 247.6)), "");
  EXPECT_EQ(IntrinsicsError(K(300, 300, 319.5, 239.5)), "");  // wide
  EXPECT_EQ(IntrinsicsError(K(5000, 5000, 300, 250)), "");    // long lens
  EXPECT_EQ(IntrinsicsError(K(520, 520, 10, 470)), "");       // a crop's principal point, inside
}

TEST(InputChecks, IntrinsicsMistakesAreNamedWithTheirFix) {
  std::string e = IntrinsicsError(K(0.836, 0.842, 0.5, 0.5));
  EXPECT_TRUE(Has(e, "query intrinsics 0.836,0.842,0.5,0.5")) << e;
  EXPECT_TRUE(Has(e, "look normalised: multiply fx and fy by the long side")) << e;
  EXPECT_TRUE(Has(e, "535,538.9,319.5,239.5")) << e;
  e = IntrinsicsError(K(0.8366, 1.1233, 0.5, 0.5));
  EXPECT_TRUE(Has(e, "look normalised: multiply fx and cx by the width")) << e;
  e = IntrinsicsError(K(320.1, 247.6, 535.4, 539.2));
  EXPECT_TRUE(Has(e, "look like cx,cy,fx,fy")) << e;
  EXPECT_TRUE(Has(e, "535.4,539.2,320.1,247.6")) << e;
  e = IntrinsicsError(K(535.4, 320.1, 539.2, 247.6));
  EXPECT_TRUE(Has(e, "look like fx,cx,fy,cy")) << e;
  EXPECT_TRUE(Has(e, "535.4,539.2,320.1,247.6")) << e;
  // The intrinsics of the 4032×3024 original on its 640×480 copy.
  e = IntrinsicsError(K(3373, 3373, 2015.5, 1511.5));
  EXPECT_TRUE(Has(e, "of a 4032x3024 image")) << e;
  // Nothing recognisable: the generic fix, and the bound that would loosen it.
  e = IntrinsicsError(K(535, 535, 900, 240));
  EXPECT_TRUE(Has(e, "principal point (900, 240) is outside the image")) << e;
  EXPECT_TRUE(Has(e, "set principal_point_margin=")) << e;
  e = IntrinsicsError(K(535, 700, 320, 240));
  EXPECT_TRUE(Has(e, "fx/fy is 0.7643")) << e;
  // Non-finite values stay the camera's own error.
  EXPECT_TRUE(Has(IntrinsicsError(K(NAN, 500, 320, 240)), "must be positive and finite"));
}

TEST(InputChecks, ALoosenedBoundIsNotedAndLowersTheConfidence) {
  InputOptions o;
  o.focal_aspect_max = 1.5;
  inputs::InputNotes notes;
  EXPECT_EQ(IntrinsicsError(K(535, 430, 320, 240), o, &notes), "");
  ASSERT_EQ(notes.notes.size(), 1u);
  EXPECT_TRUE(Has(notes.notes[0], "accepted only by a loosened bound")) << notes.notes[0];
  EXPECT_DOUBLE_EQ(notes.confidence_factor, inputs::kLoosenedBoundFactor);
  // Within the default bounds the loosening changes nothing.
  inputs::InputNotes none;
  EXPECT_EQ(IntrinsicsError(K(535, 539, 320, 240), o, &none), "");
  EXPECT_TRUE(none.notes.empty());
}

// A 64×48 map of a scene ~1.5 m away (seeded, a hole in it), stored as integers of `unit_per_m` per metre.
DepthMap StoredDepth(double unit_per_m, uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> z(1.0, 2.0);
  DepthMap d(64, 48);
  for (float& v : d.data) v = static_cast<float>(std::round(z(rng) * unit_per_m) / 1000.0);  // read as mm
  d.at(10, 10) = 0;
  d.storage = DepthStorage::kInteger;
  d.source = "d.png";
  return d;
}

std::string DepthError(DepthMap d, int w, int h, const InputOptions& o = {}, inputs::InputNotes* notes = nullptr,
                       DepthMap* out = nullptr) {
  try {
    DepthMap r = inputs::CheckProvidedDepth(std::move(d), w, h, w, h, o, "query depth", notes);
    if (out) *out = std::move(r);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(InputChecks, DepthInAnotherUnitIsRefusedWithTheUnitThatFitsIt) {
  std::string e = DepthError(StoredDepth(1), 64, 48);  // metres stored as integers: values 1–2
  EXPECT_TRUE(Has(e, "query depth (d.png)")) << e;
  EXPECT_TRUE(Has(e, "read as millimetres; metres stored as integers? set depth_unit=m")) << e;
  e = DepthError(StoredDepth(100), 64, 48);  // centimetres
  EXPECT_TRUE(Has(e, "centimetres stored as integers? set depth_unit=cm")) << e;
  // The unit said: taken, and the values are metres.
  InputOptions o;
  o.depth_unit = DepthUnit::kCentimetre;
  DepthMap out;
  EXPECT_EQ(DepthError(StoredDepth(100), 64, 48, o, nullptr, &out), "");
  EXPECT_NEAR(out.at(5, 5), StoredDepth(100).at(5, 5) * 10, 1e-5);
  EXPECT_EQ(out.storage, DepthStorage::kMetres);
  // Millimetres read as metres (unit m): far beyond the bound.
  o.depth_unit = DepthUnit::kMetre;
  e = DepthError(StoredDepth(1000), 64, 48, o);
  EXPECT_TRUE(Has(e, "millimetres stored as integers? set depth_unit=mm")) << e;
  // A float map is metres: millimetres in it are named as such.
  DepthMap f = StoredDepth(1000);
  f.storage = DepthStorage::kMetres;
  for (float& v : f.data) v *= 1000;
  e = DepthError(f, 64, 48);
  EXPECT_TRUE(Has(e, "float depth is metres; values in millimetres? divide them by 1000")) << e;
  // A scene really that close: the message says how to loosen the bound, and the loosened answer is noted.
  o = InputOptions();
  o.depth_median_min_m = 0.0005;
  inputs::InputNotes notes;
  EXPECT_EQ(DepthError(StoredDepth(1), 64, 48, o, &notes), "");
  EXPECT_EQ(notes.notes.size(), 1u);
}

TEST(InputChecks, DepthOfAnotherShapeIsResampledOrRefused) {
  // Transposed, and in the photo's stored orientation: refused.
  std::string e = DepthError(StoredDepth(1000), 48, 64);
  EXPECT_TRUE(Has(e, "the depth map is 64x48 but the photo is 48x64 as displayed (transposed")) << e;
  // The same aspect ratio at another size: resampled, noted, its values the map's.
  inputs::InputNotes notes;
  DepthMap out;
  const DepthMap small = StoredDepth(1000);
  EXPECT_EQ(DepthError(small, 256, 192, {}, &notes, &out), "");
  ASSERT_EQ(out.width, 256);
  ASSERT_EQ(out.height, 192);
  EXPECT_EQ(notes.notes.size(), 1u);
  EXPECT_TRUE(Has(notes.notes[0], "resampled from 64x48 to 256x192")) << notes.notes[0];
  EXPECT_DOUBLE_EQ(notes.confidence_factor, inputs::kResampledDepthFactor);
  // Pixel centres: output (4k + 1.5) sits on input pixel k's centre; a hole stays a hole (nearest), never blended.
  EXPECT_NEAR(out.at(4 * 5 + 1, 4 * 5 + 1) + out.at(4 * 5 + 2, 4 * 5 + 2), 2 * small.at(5, 5), 0.02);
  EXPECT_EQ(out.at(41, 41), 0.f);
  for (float v : out.data) EXPECT_TRUE(v == 0.f || (v >= 1.0f && v <= 2.0f));
  // Another aspect ratio at another size: refused.
  e = DepthError(StoredDepth(1000), 640, 360);
  EXPECT_TRUE(Has(e, "the depth map is 64x48 but the photo is 640x360")) << e;
}

// The same photo twice: the identity, metric with depth; without depth a status that says why.
TEST(InputChecks, TheSamePhotoTwiceIsTheIdentity) {
  const std::string s = testing::DemoPath("val/s00003/");
  const Image image = io::ReadImage(s + "seq0/frame_00000.png");
  const DepthMap depth = io::ReadDepthPng(s + "seq0/frame_00000.sensor.png");
  const Camera k = K(535.4, 539.2, 320.1, 247.6);
  const PipelineOptions o = ResolvePreset("sift-essential");
  const QueryResult r = RelocalizePair(image, image, k, k, depth, depth, o);
  ASSERT_EQ(ToString(r.status), "ok") << r.StatusText();
  EXPECT_LT(r.query_from_ref.translation.norm(), 1e-3);
  EXPECT_LT(RotationAngleDeg(r.query_from_ref.rotation, Eigen::Quaterniond::Identity()), 0.05);
  EXPECT_TRUE(Has(r.message, "no parallax")) << r.message;
  EXPECT_GT(r.confidence, 0);
  PipelineOptions nd = o;
  nd.depth = DepthSpec::FromString("none");
  const QueryResult u = RelocalizePair(image, image, k, k, {}, {}, nd);
  EXPECT_EQ(ToString(u.status), "degenerate");
  EXPECT_TRUE(Has(u.message, "no parallax")) << u.message;
  EXPECT_TRUE(Has(u.message, "give both depth maps")) << u.message;
}

// A camera turned in place, without depth: every translation direction fits the matches, so no direction is given —
// a status that says why; with a baseline the direction stands. Seeded synthetic points 1.5–5 m away, 0.3 px noise.
TEST(InputChecks, ACameraTurnedInPlaceWithoutDepthHasNoTranslationDirection) {
  const Camera k = K(500, 500, 319.5, 239.5);
  for (const double baseline : {0.0, 0.05}) {
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1, 1);
    std::normal_distribution<double> noise(0, 0.3);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
    matching::Correspondences c;
    while (c.size() < 400) {
      const Eigen::Vector3d X(2 * u(rng), 1.5 * u(rng), 3.25 + 1.75 * u(rng));
      const Eigen::Vector3d Y = R * X + Eigen::Vector3d(baseline, 0, 0);
      const Eigen::Vector2d a = k.Project(X), b = k.Project(Y);
      if (b.x() < 0 || b.x() > 639 || b.y() < 0 || b.y() > 479) continue;
      c.ref.push_back(a);
      c.query.push_back(b + Eigen::Vector2d(noise(rng), noise(rng)));
    }
    const QueryResult r = SolveCorrespondences(c, k, k, {}, {}, CorrespondenceDefaults());
    SCOPED_TRACE(baseline);
    if (baseline == 0) {
      EXPECT_EQ(ToString(r.status), "degenerate");
      EXPECT_TRUE(Has(r.message, "no parallax")) << r.message;
    } else {
      EXPECT_EQ(ToString(r.status), "ok-unit-translation") << r.message;
      EXPECT_GT(r.query_from_ref.translation.x(), 0.95);
    }
  }
}

}  // namespace
}  // namespace freeloc::pipeline
