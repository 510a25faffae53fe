// MASt3R's fast reciprocal NN against upstream (../shared/fixtures/mast3r: every array of every case, exact) and
// against its own exhaustive reference on seeded random descriptors (odd sizes, ties, NaN pixels, every kernel and
// thread count), plus the 10-round limit (naver/mast3r mast3r/fast_nn.py).
#include "freeloc/matching/fast_nn.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "freeloc/core/error.h"
#include "freeloc/io/safetensors.h"
#include "testing/testing.h"

namespace freeloc::matching {
namespace {

using testing::SharedPath;

std::vector<NnKernel> Kernels() {
  std::vector<NnKernel> k = {NnKernel::kFloat32};
  if (CpuHasVnni()) k.push_back(NnKernel::kInt8Vnni);
  return k;
}

DescriptorView ViewOf(const io::TensorView& desc, const io::TensorView& conf) {
  return {desc.as<float>(), conf.as<float>(), static_cast<int>(desc.shape[1]), static_cast<int>(desc.shape[2]),
          static_cast<int>(desc.shape[3])};
}

template <typename T>
std::vector<T> Values(const io::TensorView& t) {
  return std::vector<T>(t.as<T>(), t.as<T>() + t.numel());
}

TEST(FastNn, EqualsUpstreamOnEveryFixtureList) {
  FREELOC_REQUIRE_SHARED("fixtures/mast3r/cases/land_s128.safetensors");
  int lists = 0;
  for (const char* name : {"land_s128", "mixed_s80", "odd_s112"}) {
    const io::SafetensorsFile f =
        io::SafetensorsFile::Open(SharedPath(std::string("fixtures/mast3r/cases/") + name + ".safetensors"));
    const DescriptorView a = ViewOf(f.Get("pred1.desc"), f.Get("pred1.desc_conf"));
    const DescriptorView b = ViewOf(f.Get("pred2.desc"), f.Get("pred2.desc_conf"));
    for (int S : {8, 4}) {
      const std::string p = "fnn_s" + std::to_string(S) + ".";
      if (std::find(f.names.begin(), f.names.end(), p + "seeds") == f.names.end()) continue;
      for (NnKernel k : Kernels())
        for (int threads : {1, 2}) {
          SCOPED_TRACE(std::string(name) + " S=" + std::to_string(S) + " threads " + std::to_string(threads));
          FastNnOptions o;
          o.subsample = S;
          o.kernel = k;
          o.threads = threads;
          FastNnStats st;
          const auto m = FastReciprocalNN(a, b, o, &st);
          EXPECT_EQ(st.seeds, Values<int32_t>(f.Get(p + "seeds")));
          EXPECT_EQ(st.query_sizes, Values<int64_t>(f.Get(p + "query_sizes")));
          const auto x0 = Values<int32_t>(f.Get(p + "xy_im0")), x1 = Values<int32_t>(f.Get(p + "xy_im1"));
          ASSERT_EQ(m.size() * 2, x0.size());
          const auto conf_min = Values<float>(f.Get(p + "conf_min"));
          for (size_t i = 0; i < m.size(); ++i) {
            EXPECT_EQ(m[i].x1, x0[2 * i]);
            EXPECT_EQ(m[i].y1, x0[2 * i + 1]);
            EXPECT_EQ(m[i].x2, x1[2 * i]);
            EXPECT_EQ(m[i].y2, x1[2 * i + 1]);
            EXPECT_EQ(std::min(m[i].conf1, m[i].conf2), conf_min[i]);
          }
          const auto kept = FilterDescriptorMatches(m, a.width, a.height, b.width, b.height, {});
          const auto b0 = Values<int32_t>(f.Get(p + "border.xy_im0")), b1 = Values<int32_t>(f.Get(p + "border.xy_im1"));
          ASSERT_EQ(kept.size() * 2, b0.size());
          for (size_t i = 0; i < kept.size(); ++i) {
            EXPECT_EQ(kept[i].x1, b0[2 * i]);
            EXPECT_EQ(kept[i].y1, b0[2 * i + 1]);
            EXPECT_EQ(kept[i].x2, b1[2 * i]);
            EXPECT_EQ(kept[i].y2, b1[2 * i + 1]);
          }
          ++lists;
        }
    }
  }
  EXPECT_GE(lists, 10);
}

// Random descriptors: unit vectors (MASt3R's) and unnormalised ones, odd grids, duplicated descriptors (exact
// ties), NaN pixels; the fast path equals the exhaustive one for every kernel and thread count.
TEST(FastNn, EqualsExhaustiveReferenceOnRandomDescriptors) {
  std::mt19937 rng(20261124);
  std::normal_distribution<float> g;
  struct Case {
    int h1, w1, h2, w2, d, s;
    bool unit, smooth;
    bool opposed = false;  // view 2 points away from view 1: every similarity negative (padding must never win)
  };
  for (const Case& c : {Case{37, 53, 41, 29, 24, 4, true, false}, Case{64, 48, 48, 64, 24, 8, true, true},
                        Case{23, 31, 23, 31, 7, 3, false, false}, Case{80, 112, 96, 64, 8, 5, true, true},
                        Case{16, 16, 300, 2, 33, 2, true, false}, Case{45, 61, 43, 58, 24, 4, true, true, true},
                        Case{96, 128, 96, 128, 24, 8, true, true}}) {
    SCOPED_TRACE(::testing::Message() << c.h1 << "x" << c.w1 << " / " << c.h2 << "x" << c.w2 << " D=" << c.d);
    auto make = [&](int h, int w, float phase) {
      std::vector<float> v(static_cast<size_t>(h) * w * c.d);
      std::vector<float> base(static_cast<size_t>(c.d) * 3);
      for (auto& x : base) x = g(rng);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          float* p = &v[(static_cast<size_t>(y) * w + x) * c.d];
          double n = 0;
          for (int d = 0; d < c.d; ++d) {
            p[d] = c.smooth ? base[d] * std::sin(0.07f * x + phase) + base[c.d + d] * std::cos(0.05f * y) +
                                  0.3f * base[2 * c.d + d] + 0.05f * g(rng)
                            : g(rng);
            n += static_cast<double>(p[d]) * p[d];
          }
          if (c.unit)
            for (int d = 0; d < c.d; ++d) p[d] = static_cast<float>(p[d] / std::sqrt(n));
        }
      // Exact duplicates (ties) and a few NaN pixels.
      for (int k = 0; k < 20; ++k) {
        const size_t a = rng() % (static_cast<size_t>(h) * w), b = rng() % (static_cast<size_t>(h) * w);
        std::copy_n(&v[a * c.d], c.d, &v[b * c.d]);
      }
      for (int k = 0; k < 3; ++k) v[(rng() % (static_cast<size_t>(h) * w)) * c.d] = std::nanf("");
      return v;
    };
    const auto d1 = make(c.h1, c.w1, 0.f);
    auto d2 = make(c.h2, c.w2, 0.3f);
    if (c.opposed) {
      // Shift every view-2 descriptor into the half-space opposite the view-1 mean direction.
      std::vector<double> mean(static_cast<size_t>(c.d), 0.0);
      for (size_t i = 0; i < d1.size(); ++i)
        if (std::isfinite(d1[i])) mean[i % c.d] += d1[i];
      double n = 0;
      for (double m : mean) n += m * m;
      for (size_t i = 0; i < d2.size(); ++i)
        d2[i] = static_cast<float>(-2.0 * mean[i % c.d] / std::sqrt(n) + 0.1 * d2[i]);
    }
    const DescriptorView a{d1.data(), nullptr, c.h1, c.w1, c.d}, b{d2.data(), nullptr, c.h2, c.w2, c.d};
    FastNnOptions o;
    o.subsample = c.s;
    FastNnStats ref_st;
    const auto ref = FastReciprocalNNBruteForce(a, b, o, &ref_st);
    EXPECT_GT(ref.size(), 0u);
    EXPECT_EQ(ref_st.invalid_pixels, 6);
    for (NnKernel k : Kernels())
      for (int threads : {1, 2, 3}) {
        o.kernel = k;
        o.threads = threads;
        FastNnStats st;
        const auto m = FastReciprocalNN(a, b, o, &st);
        ASSERT_EQ(m.size(), ref.size()) << st.kernel << " threads " << threads;
        for (size_t i = 0; i < m.size(); ++i)
          EXPECT_TRUE(m[i].x1 == ref[i].x1 && m[i].y1 == ref[i].y1 && m[i].x2 == ref[i].x2 && m[i].y2 == ref[i].y2)
              << st.kernel << " row " << i;
        EXPECT_EQ(st.query_sizes, ref_st.query_sizes);
        EXPECT_EQ(st.dropped, ref_st.dropped);
        EXPECT_LE(st.lookups, ref_st.lookups);
      }
  }
}

// naver/mast3r mast3r/fast_nn.py: a chain of K links after the seed converges in round K + 1; K = 10 exceeds the limit
// and the seed is dropped.
TEST(FastNn, TenRoundLimitDropsTheSeed) {
  for (int K : {9, 10}) {
    const int H = 33, W = 64, D = 3;
    std::vector<float> d1(static_cast<size_t>(H) * W * D, 0.f), d2(d1.size(), 0.f);
    for (int i = 0; i < H * W; ++i) {
      d1[static_cast<size_t>(i) * D + 2] = 1.f;
      d2[static_cast<size_t>(i) * D + 2] = -1.f;
    }
    // a_0 = seed (32, 32) of view 1; the chain alternates a_k (view 1), b_k (view 2) at increasing angles.
    double angle = 0, gap = 0.05;
    auto put = [&](std::vector<float>& v, int idx) {
      v[static_cast<size_t>(idx) * D + 0] = static_cast<float>(std::cos(angle));
      v[static_cast<size_t>(idx) * D + 1] = static_cast<float>(std::sin(angle));
      v[static_cast<size_t>(idx) * D + 2] = 0.f;
      angle += gap;
      gap *= 0.93;
    };
    int last_a = 32 * W + 32, last_b = -1;
    put(d1, last_a);
    for (int k = 0; k <= K; ++k) {
      last_b = k + 1;  // view-2 pixels (1, 0), (2, 0), …
      put(d2, last_b);
      if (k == K) break;
      last_a = k + 1;  // view-1 pixels (1, 0), (2, 0), … (not the seed)
      put(d1, last_a);
    }
    FastNnOptions o;
    o.subsample = 64;
    FastNnStats st;
    const DescriptorView a{d1.data(), nullptr, H, W, D}, b{d2.data(), nullptr, H, W, D};
    const auto m = FastReciprocalNN(a, b, o, &st);
    EXPECT_EQ(st.seeds, std::vector<int32_t>{32 * W + 32});
    if (K == 9) {
      ASSERT_EQ(m.size(), 1u);
      EXPECT_EQ(m[0].y1 * W + m[0].x1, last_a);
      EXPECT_EQ(m[0].y2 * W + m[0].x2, last_b);
      EXPECT_EQ(st.query_sizes, std::vector<int64_t>(20, 1));
    } else {
      EXPECT_TRUE(m.empty());
      EXPECT_EQ(st.dropped, 1);
    }
  }
}

TEST(FastNn, BadInputsAreErrors) {
  std::vector<float> d(8 * 8 * 4, 0.5f);
  const DescriptorView a{d.data(), nullptr, 8, 8, 4}, b{d.data(), nullptr, 8, 8, 3};
  EXPECT_THROW(FastReciprocalNN(a, b), Error);  // different D
  FastNnOptions o;
  o.subsample = 0;
  EXPECT_THROW(FastReciprocalNN(a, a, o), Error);
  const DescriptorView empty{nullptr, nullptr, 0, 0, 4};
  EXPECT_THROW(FastReciprocalNN(empty, a), Error);
  DescriptorMatchFilter f;
  f.border = -1;
  EXPECT_THROW(FilterDescriptorMatches({}, 8, 8, 8, 8, f), Error);
}

}  // namespace
}  // namespace freeloc::matching
