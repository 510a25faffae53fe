#include "freeloc/matching/instance.h"

#include <gtest/gtest.h>

#include "freeloc/core/error.h"

namespace freeloc::matching {
namespace {

// An image whose colour encodes the pixel position (R = x, G = y), and a stand-in "model" whose pointmap is that
// decoded position: identical images then match pixel to pixel, wherever the crops and resizes put them.
Image Ramp(int w, int h) {
  Image im(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      im.pixel(x, y)[0] = static_cast<uint8_t>(x);
      im.pixel(x, y)[1] = static_cast<uint8_t>(y);
      im.pixel(x, y)[2] = 100;
    }
  return im;
}

PairPointmaps FakeModel(const vision::Dust3rInput& a, const vision::Dust3rInput& b) {
  PairPointmaps p;
  auto fill = [](const vision::Dust3rInput& in, std::vector<float>* pts, std::vector<float>* conf) {
    for (size_t i = 0; i < in.image.num_pixels(); ++i) {
      pts->push_back(in.image.data[3 * i]);
      pts->push_back(in.image.data[3 * i + 1]);
      pts->push_back(1.f);
      conf->push_back(2.f);
    }
  };
  fill(a, &p.pts1, &p.conf1);
  fill(b, &p.pts2, &p.conf2);
  p.h1 = a.height();
  p.w1 = a.width();
  p.h2 = b.height();
  p.w2 = b.width();
  return p;
}

std::vector<uint8_t> Rect(int w, int h, int x0, int y0, int x1, int y1) {
  std::vector<uint8_t> m(static_cast<size_t>(w) * h, 0);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) m[static_cast<size_t>(y) * w + x] = 1;
  return m;
}

TEST(Instance, MaskAndCropModesMatchInsideTheMasks) {
  const Image im = Ramp(240, 180);
  InstanceMasks masks{7, Rect(240, 180, 40, 30, 120, 110), Rect(240, 180, 40, 30, 120, 110)};
  InstanceOptions o;
  o.preprocess.size = 128;
  size_t n_mask = 0;
  for (InstanceMode mode : {InstanceMode::kMask, InstanceMode::kCrop}) {
    o.mode = mode;
    const InstanceResult r = MatchInstance(im, im, masks, FakeModel, o);
    ASSERT_TRUE(r.used) << r.reason;
    for (const Correspondence& c : r.matches) {
      EXPECT_EQ(c.source, 7);
      EXPECT_GE(c.ref.x(), 39.0);
      EXPECT_LE(c.ref.x(), 120.5);
      EXPECT_LE((c.ref - c.query).norm(), 1.5);  // identical images: matched where they are
    }
    if (mode == InstanceMode::kMask) {
      n_mask = r.matches.size();
    } else {
      EXPECT_GT(r.matches.size(), 2 * n_mask);  // the crop gives the object more network pixels
    }
  }
}

TEST(Instance, SkipsSmallMasksAndRejectsWrongSizes) {
  const Image im = Ramp(240, 180);
  InstanceOptions o;
  o.preprocess.size = 128;
  const InstanceResult empty =
      MatchInstance(im, im, {1, Rect(240, 180, 0, 0, 0, 0), Rect(240, 180, 0, 0, 0, 0)}, FakeModel, o);
  EXPECT_FALSE(empty.used);
  EXPECT_NE(empty.reason.find("mask too small"), std::string::npos);
  // A mask covering everything works like the global pass.
  const InstanceResult all =
      MatchInstance(im, im, {2, Rect(240, 180, 0, 0, 240, 180), Rect(240, 180, 0, 0, 240, 180)}, FakeModel, o);
  EXPECT_TRUE(all.used);
  try {
    MatchInstance(im, im, {3, Rect(100, 100, 0, 0, 50, 50), Rect(240, 180, 0, 0, 50, 50)}, FakeModel, o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("instance 3: the reference mask has 10000 pixels but the image is 240x180"),
              std::string::npos);
  }
}

TEST(Instance, MergeReplacesGlobalMatchesInsideUsedInstances) {
  const int w = 100, h = 80;
  std::vector<Correspondence> global;
  for (int x = 5; x < 100; x += 10) global.push_back({Eigen::Vector2d(x, 40), Eigen::Vector2d(x + 1, 40), 1.f, -1});
  // Instance 1 (used) covers x < 30; instance 2 (skipped) covers x ≥ 70.
  std::vector<InstanceMasks> masks = {{1, Rect(w, h, 0, 0, 30, 80), Rect(w, h, 0, 0, 30, 80)},
                                      {2, Rect(w, h, 70, 0, 100, 80), Rect(w, h, 70, 0, 100, 80)}};
  InstanceResult r1{1, true, "", {{Eigen::Vector2d(12, 12), Eigen::Vector2d(13, 12), 2.f, 1}}};
  InstanceResult r2{2, false, "too few matches (3)", {}};
  const auto merged = MergeMatches(global, {r1, r2}, masks, w, h);
  // Global at x = 5, 15, 25 replaced; 35…95 kept (including those inside the skipped instance); one instance match.
  ASSERT_EQ(merged.size(), 7u + 1u);
  int from_instance = 0;
  for (const auto& c : merged) {
    if (c.source == 1) ++from_instance;
    if (c.source == -1) {
      EXPECT_GE(c.ref.x(), 30);
    }
  }
  EXPECT_EQ(from_instance, 1);
}

TEST(Instance, SplitLabels) {
  const std::vector<uint16_t> labels = {0, 3, 3, 1, 0, 1};
  const auto s = SplitLabels(labels);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].first, 1);
  EXPECT_EQ(s[0].second, (std::vector<uint8_t>{0, 0, 0, 1, 0, 1}));
  EXPECT_EQ(s[1].first, 3);
  EXPECT_THROW(ParseEnum<InstanceMode>("bbox"), Error);
}

}  // namespace
}  // namespace freeloc::matching
