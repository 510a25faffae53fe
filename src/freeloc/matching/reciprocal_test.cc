#include "freeloc/matching/reciprocal.h"

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "freeloc/core/error.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/matching/pixel_mapping.h"
#include "testing/testing.h"

namespace freeloc::matching {
namespace {

// The fixture's matches were computed by dust3r's own find_reciprocal_matches on the stored pointmaps: ours must
// be identical (the same pairs in the same order), for all pixels and with the conf ≥ 2 masks.
TEST(Reciprocal, IdenticalToFixtureMatches) {
  FREELOC_REQUIRE_SHARED("fixtures/dust3r/cases/png_s80.safetensors");
  for (const char* name : {"png_s80", "png_s80_mixed"}) {
    const io::SafetensorsFile f =
        io::SafetensorsFile::Open(testing::SharedPath(std::string("fixtures/dust3r/cases/") + name + ".safetensors"));
    const io::TensorView& p1 = f.Get("pred1.pts3d");
    const io::TensorView& p2 = f.Get("pred2.pts3d_in_other_view");
    const PointmapView v1{p1.as<float>(), f.Get("pred1.conf").as<float>(), nullptr, static_cast<int>(p1.shape[1]),
                          static_cast<int>(p1.shape[2])};
    const PointmapView v2{p2.as<float>(), f.Get("pred2.conf").as<float>(), nullptr, static_cast<int>(p2.shape[1]),
                          static_cast<int>(p2.shape[2])};
    for (const char* prefix : {"match_all", "match_conf"}) {
      SCOPED_TRACE(std::string(name) + " " + prefix);
      ReciprocalOptions o;
      o.conf_threshold = std::string(prefix) == "match_conf" ? f.Get("match_conf.thr").as<float>()[0] : 0.0;
      const auto m = ReciprocalMatches(v1, v2, o);
      const io::TensorView& a = f.Get(std::string(prefix) + ".xy_im0");
      const io::TensorView& b = f.Get(std::string(prefix) + ".xy_im1");
      ASSERT_EQ(static_cast<int64_t>(m.size()), a.shape[0]);
      EXPECT_EQ(static_cast<int64_t>(m.size()),
                // ToDouble, not as<int64_t>: the fixture's bytes need not be 8-byte aligned (UBSan).
                static_cast<int64_t>(f.Get(std::string(prefix) + ".num_matches").ToDouble()[0]));
      const std::vector<double> av = a.ToDouble(), bv = b.ToDouble();  // unaligned-safe copies
      for (size_t i = 0; i < m.size(); ++i) {
        ASSERT_EQ(m[i].x1, av[2 * i]) << i;
        ASSERT_EQ(m[i].y1, av[2 * i + 1]) << i;
        ASSERT_EQ(m[i].x2, bv[2 * i]) << i;
        ASSERT_EQ(m[i].y2, bv[2 * i + 1]) << i;
      }
      const auto bf = ReciprocalMatchesBruteForce(v1, v2, o);
      ASSERT_EQ(bf.size(), m.size());
    }
  }
}

TEST(Reciprocal, AgreesWithBruteForceOnRandomClouds) {
  std::mt19937 rng(5);
  std::normal_distribution<float> g(0, 1);
  for (int trial = 0; trial < 5; ++trial) {
    const int h1 = 23, w1 = 31, h2 = 19, w2 = 37;
    std::vector<float> a(3 * h1 * w1), b(3 * h2 * w2), ca(h1 * w1), cb(h2 * w2);
    for (auto& v : a) v = g(rng);
    for (auto& v : b) v = g(rng);
    for (auto& v : ca) v = 1 + std::abs(g(rng));
    for (auto& v : cb) v = 1 + std::abs(g(rng));
    const PointmapView v1{a.data(), ca.data(), nullptr, h1, w1}, v2{b.data(), cb.data(), nullptr, h2, w2};
    ReciprocalOptions o;
    o.conf_threshold = trial % 2 ? 1.5 : 0.0;
    o.subsample = trial == 4 ? 2 : 1;
    const auto k = ReciprocalMatches(v1, v2, o);
    const auto bf = ReciprocalMatchesBruteForce(v1, v2, o);
    ASSERT_EQ(k.size(), bf.size());
    for (size_t i = 0; i < k.size(); ++i) {
      EXPECT_EQ(k[i].x1, bf[i].x1);
      EXPECT_EQ(k[i].y2, bf[i].y2);
      if (o.subsample == 2) {
        EXPECT_EQ(k[i].x2 % 2, 0);
      }
    }
    EXPECT_GT(k.size(), 10u);
  }
}

TEST(Reciprocal, MasksRestrictBothSides) {
  const int h = 8, w = 8;
  std::vector<float> p(3 * h * w);
  for (int i = 0; i < h * w; ++i) {
    p[3 * i] = static_cast<float>(i % w);
    p[3 * i + 1] = static_cast<float>(i / w);
    p[3 * i + 2] = 1;
  }
  std::vector<uint8_t> m1(h * w, 0), m2(h * w, 0);
  for (int y = 2; y < 5; ++y)
    for (int x = 2; x < 5; ++x) m1[y * w + x] = m2[y * w + x] = 1;
  const auto all = ReciprocalMatches({p.data(), nullptr, nullptr, h, w}, {p.data(), nullptr, nullptr, h, w});
  EXPECT_EQ(all.size(), static_cast<size_t>(h * w));  // identical clouds: every pixel matches itself
  const auto in = ReciprocalMatches({p.data(), nullptr, m1.data(), h, w}, {p.data(), nullptr, m2.data(), h, w});
  EXPECT_EQ(in.size(), 9u);
  for (const auto& m : in) EXPECT_TRUE(m.x1 >= 2 && m.x1 < 5 && m.x1 == m.x2 && m.y1 == m.y2);
  std::vector<uint8_t> empty(h * w, 0);
  EXPECT_TRUE(ReciprocalMatches({p.data(), nullptr, empty.data(), h, w}, {p.data(), nullptr, m2.data(), h, w}).empty());
  EXPECT_THROW(ReciprocalMatches({nullptr, nullptr, nullptr, 0, 0}, {p.data(), nullptr, nullptr, h, w}), Error);
}

// A point at a known original pixel survives resize + crop + match + map back.
TEST(Reciprocal, PixelMappingBackToOriginal) {
  const Image img(1000, 700);
  const vision::Dust3rInput in = vision::PreprocessForDust3r(img);  // 512×352 after resize to 512×358 and a 3-row crop
  const int h = in.height(), w = in.width();
  // Both views see the same plane; each network pixel's point is its original pixel coordinate.
  std::vector<float> p(3 * h * w);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double xo, yo;
      in.ToOriginal(x, y, &xo, &yo);
      p[3 * (y * w + x)] = static_cast<float>(xo);
      p[3 * (y * w + x) + 1] = static_cast<float>(yo);
      p[3 * (y * w + x) + 2] = 5.f;
    }
  const auto m = ReciprocalMatches({p.data(), nullptr, nullptr, h, w}, {p.data(), nullptr, nullptr, h, w});
  ASSERT_EQ(m.size(), static_cast<size_t>(h * w));
  const Correspondences c = ToOriginalPixels(m, in, in);
  for (size_t i = 0; i < c.size(); i += 997) {
    // Back in original pixels, and consistent with the network → original → network round trip.
    double xn, yn;
    in.ToNetwork(c.ref[i].x(), c.ref[i].y(), &xn, &yn);
    EXPECT_NEAR(xn, m[i].x1, 1e-9);
    EXPECT_NEAR(yn, m[i].y1, 1e-9);
    EXPECT_NEAR((c.ref[i] - c.query[i]).norm(), 0, 1e-9);
  }
  // A known original pixel: its nearest network pixel maps back to within half a network pixel (in original units).
  const double xo = 612.3, yo = 401.7;
  double xn, yn;
  in.ToNetwork(xo, yo, &xn, &yn);
  double xb, yb;
  in.ToOriginal(std::round(xn), std::round(yn), &xb, &yb);
  const double scale = 1000.0 / 512.0;
  EXPECT_LE(std::abs(xb - xo), 0.5 * scale + 1e-9);
  EXPECT_LE(std::abs(yb - yo), 0.5 * 700.0 / 358.0 + 1e-9);
}

}  // namespace
}  // namespace freeloc::matching
