// Fixture-free checks of the hand-written kernels in nn/internal against naive loops (ggml style: each kernel
// against a reference implementation, random shapes with odd sizes): row-blocked attention and RoPE2D.
#include "freeloc/nn/internal/layers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace freeloc::nn::internal {
namespace {

// softmax(q·kᵀ·scale)·v, one head at a time, in double.
std::vector<double> NaiveAttention(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v,
                                   double scale) {
  const auto qa = q.accessor<float, 4>(), ka = k.accessor<float, 4>(), va = v.accessor<float, 4>();
  const int64_t B = q.size(0), H = q.size(1), Nq = q.size(2), Nk = k.size(2), D = q.size(3), Dv = v.size(3);
  std::vector<double> out;
  std::vector<double> logits(static_cast<size_t>(Nk));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t h = 0; h < H; ++h)
      for (int64_t i = 0; i < Nq; ++i) {
        double mx = -1e300, sum = 0;
        for (int64_t j = 0; j < Nk; ++j) {
          double s = 0;
          for (int64_t d = 0; d < D; ++d) s += static_cast<double>(qa[b][h][i][d]) * ka[b][h][j][d];
          logits[j] = s * scale;
          mx = std::max(mx, logits[j]);
        }
        for (int64_t j = 0; j < Nk; ++j) sum += (logits[j] = std::exp(logits[j] - mx));
        for (int64_t e = 0; e < Dv; ++e) {
          double o = 0;
          for (int64_t j = 0; j < Nk; ++j) o += logits[j] / sum * va[b][h][j][e];
          out.push_back(o);
        }
      }
  return out;
}

TEST(Kernels, RowBlockedAttentionMatchesNaiveOnOddShapes) {
  torch::manual_seed(11);
  std::mt19937 rng(5);
  struct Shape {
    int64_t B, H, Nq, Nk, D, Dv, block;
  };
  const Shape shapes[] = {{1, 1, 1, 1, 1, 1, 128}, {1, 3, 7, 13, 5, 5, 4},      {2, 2, 129, 17, 16, 16, 128},
                          {1, 4, 33, 65, 9, 3, 1}, {1, 2, 200, 31, 24, 24, 64}, {2, 1, 5, 300, 8, 12, 3}};
  for (const Shape& s : shapes) {
    SCOPED_TRACE(::testing::Message() << "B" << s.B << " H" << s.H << " Nq" << s.Nq << " Nk" << s.Nk << " D" << s.D
                                      << " Dv" << s.Dv << " block" << s.block);
    const torch::Tensor q = torch::randn({s.B, s.H, s.Nq, s.D}) * 2, k = torch::randn({s.B, s.H, s.Nk, s.D}),
                        v = torch::randn({s.B, s.H, s.Nk, s.Dv});
    const double scale = 1.0 / std::sqrt(static_cast<double>(s.D));
    const torch::Tensor got = ScaledDotProduct(q, k, v, scale, PrecisionPolicy{}, s.block).contiguous();
    ASSERT_EQ(got.sizes(), torch::IntArrayRef({s.B, s.H, s.Nq, s.Dv}));
    const std::vector<double> want = NaiveAttention(q, k, v, scale);
    const float* g = got.data_ptr<float>();
    double max_err = 0;
    for (size_t i = 0; i < want.size(); ++i) max_err = std::max(max_err, std::abs(g[i] - want[i]));
    EXPECT_LT(max_err, 2e-5);
    // The whole-tensor reference form agrees too (the bench's comparison).
    EXPECT_TRUE(torch::allclose(ScaledDotProductReference(q, k, v, scale), got, 1e-5, 2e-5));
  }
}

// croco RoPE2D, written out: the first half of each head by the y position, the second by x; within each half
// rotate_half pairs (i, i + D/2) with cos/sin of pos · inv_freq[i mod D/2], inv_freq = 1/base^(2j/D) in float32.
std::vector<float> NaiveRope(const torch::Tensor& t, int64_t h, int64_t w, double base) {
  const auto a = t.accessor<float, 4>();
  const int64_t B = t.size(0), H = t.size(1), N = t.size(2), dh = t.size(3), D = dh / 2, half = D / 2;
  std::vector<float> out;
  for (int64_t b = 0; b < B; ++b)
    for (int64_t hd = 0; hd < H; ++hd)
      for (int64_t n = 0; n < N; ++n)
        for (int64_t c = 0; c < dh; ++c) {
          const int64_t part = c / D, i = c % D, j = i % half;
          const float pos = static_cast<float>(part == 0 ? n / w : n % w);
          const float inv =
              1.0f / std::pow(static_cast<float>(base), static_cast<float>(2 * j) / static_cast<float>(D));
          const float ang = pos * inv;
          const float x = a[b][hd][n][c];
          const float rot = i < half ? -a[b][hd][n][part * D + i + half] : a[b][hd][n][part * D + i - half];
          out.push_back(x * std::cos(ang) + rot * std::sin(ang));
        }
  (void)h;
  return out;
}

TEST(Kernels, Rope2DMatchesTheReferenceFormula) {
  torch::manual_seed(3);
  struct Shape {
    int64_t B, H, h, w, dh;
    double base;
  };
  const Shape shapes[] = {{1, 1, 1, 1, 4, 100}, {1, 2, 3, 5, 8, 100}, {2, 3, 7, 9, 12, 100}, {1, 4, 14, 11, 64, 10}};
  for (const Shape& s : shapes) {
    SCOPED_TRACE(::testing::Message() << "grid " << s.h << "x" << s.w << " dh " << s.dh);
    const Rope2D rope(s.base);
    const torch::Tensor t = torch::randn({s.B, s.H, s.h * s.w, s.dh});
    const torch::Tensor got = Rope2D::Apply(t, rope.Tables(s.h, s.w, s.dh, torch::kCPU)).contiguous();
    const std::vector<float> want = NaiveRope(t, s.h, s.w, s.base);
    const float* g = got.data_ptr<float>();
    double max_err = 0;
    for (size_t i = 0; i < want.size(); ++i) max_err = std::max(max_err, static_cast<double>(std::abs(g[i] - want[i])));
    EXPECT_LT(max_err, 5e-5);
    // A second call hits the table cache and gives the same tables.
    EXPECT_TRUE(
        torch::equal(rope.Tables(s.h, s.w, s.dh, torch::kCPU).first, rope.Tables(s.h, s.w, s.dh, torch::kCPU).first));
  }
}

// The fused residual step + LayerNorm in bf16 (LayerNorm::AddForProducts / ForProducts) against a naive double
// LayerNorm rounded to bf16: the sum exact, the norm within one bf16 step everywhere (and equal nearly everywhere),
// odd widths and a NaN kept; without bf16 (or with a bf16 input) the plain fp32 path.
TEST(Kernels, FusedAddLayerNormInBf16MatchesTheNaiveNorm) {
  torch::manual_seed(9);
  PrecisionPolicy bf16;
  bf16.bf16 = true;
  for (const int64_t c : {1, 7, 16, 33, 768, 1031}) {
    LayerNorm n;
    n.w = torch::randn({c});
    n.b = torch::randn({c});
    n.eps = 1e-6;
    const torch::Tensor x = torch::randn({2, 5, c}) * 3 + 1, d = torch::randn({2, 5, c});
    torch::Tensor s = x;
    const torch::Tensor y = n.AddForProducts(&s, d, bf16);
    ASSERT_EQ(y.scalar_type(), torch::kBFloat16);
    ASSERT_EQ(y.sizes(), x.sizes());
    EXPECT_TRUE(torch::equal(s, x + d));
    EXPECT_FALSE(s.is_same(x));  // a new tensor: the input is left alone
    // Naive reference in double.
    const torch::Tensor sd = (x + d).to(torch::kFloat64);
    const torch::Tensor mean = sd.mean(-1, true), var = (sd - mean).pow(2).mean(-1, true);
    const torch::Tensor ref = ((sd - mean) / (var + n.eps).sqrt() * n.w.to(torch::kFloat64) + n.b.to(torch::kFloat64));
    const torch::Tensor err = (y.to(torch::kFloat64) - ref).abs();
    // One bf16 step at the value's magnitude (2⁻⁷ relative), plus a little for the fp32 statistics.
    EXPECT_TRUE((err <= ref.abs() * (1.0 / 128) + 1e-6).all().item<bool>()) << "c = " << c;
    const torch::Tensor ref16 = ref.to(torch::kFloat32).to(torch::kBFloat16);
    EXPECT_LE((y != ref16).sum().item<int64_t>(), std::max<int64_t>(1, y.numel() / 100)) << "c = " << c;
    // ForProducts alone: the same norm of s.
    EXPECT_TRUE(torch::equal(n.ForProducts(s, bf16), y));
  }
  // A NaN stays NaN; the fp32 policy gives torch's fp32 norm.
  LayerNorm n;
  n.w = torch::ones({8});
  n.b = torch::zeros({8});
  torch::Tensor x = torch::randn({1, 8});
  x[0][3] = std::nan("");
  EXPECT_TRUE(torch::isnan(n.ForProducts(x, bf16).to(torch::kFloat32)).all().item<bool>());
  const torch::Tensor xf = torch::randn({3, 8});
  const torch::Tensor yf = n.ForProducts(xf, PrecisionPolicy{});
  EXPECT_EQ(yf.scalar_type(), torch::kFloat32);
  EXPECT_TRUE(torch::allclose(yf, torch::layer_norm(xf, {8}, n.w, n.b, n.eps)));
}

// The DPT heads' ×2 upsampling (align_corners) on channels-last maps is freeloc's own kernel: LibTorch's values up to
// fp32 rounding (the same source indices and lambdas, the four terms summed in another order) and, in bf16, up to one
// step of the rounding on a few values; anything else goes to LibTorch's op unchanged.
TEST(Kernels, Upsample2xAlignCornersMatchesLibTorchsOp) {
  torch::manual_seed(11);
  const std::vector<std::vector<int64_t>> shapes = {{2, 37, 5, 7}, {1, 128, 12, 16}, {1, 3, 1, 9}, {1, 16, 6, 1}};
  for (const auto& shape : shapes) {
    SCOPED_TRACE(::testing::Message() << torch::IntArrayRef(shape));
    const torch::Tensor x = torch::randn(shape).contiguous(torch::MemoryFormat::ChannelsLast);
    const std::vector<int64_t> size = {2 * shape[2], 2 * shape[3]};
    const torch::Tensor ref = torch::upsample_bilinear2d(x.contiguous(), size, true);
    const torch::Tensor y = Upsample2xAlignCorners(x);
    EXPECT_TRUE(y.is_contiguous(torch::MemoryFormat::ChannelsLast));
    ASSERT_EQ(y.sizes(), ref.sizes());
    EXPECT_LE((y - ref).abs().max().item<float>(), 1e-6f * (1.0f + ref.abs().max().item<float>()));
    // bf16: fp32 arithmetic and one rounding — the fp32 op on the bf16 input, rounded (a bf16 step apart at most, on
    // the few values where the order of the four terms decides the rounding) — where LibTorch 1.13's bf16 op rounds its
    // weights and every product to bf16: never further from the fp32 values than that op.
    const torch::Tensor xb = x.to(torch::kBFloat16);
    const torch::Tensor exact = torch::upsample_bilinear2d(xb.to(torch::kFloat32).contiguous(), size, true);
    const torch::Tensor yb = Upsample2xAlignCorners(xb);
    ASSERT_EQ(yb.scalar_type(), torch::kBFloat16);
    const torch::Tensor diff = (yb.to(torch::kFloat32) - exact.to(torch::kBFloat16).to(torch::kFloat32)).abs();
    // (Near a cancellation the fp32 sums themselves differ by their rounding: 1e-6 absolute.)
    EXPECT_TRUE((diff <= exact.abs() * (1.0 / 128) + 1e-6).all().item<bool>());
    EXPECT_LE((diff > 0).to(torch::kFloat32).mean().item<float>(), 0.01f);
    const torch::Tensor torch_bf16 = torch::upsample_bilinear2d(xb, size, true).to(torch::kFloat32);
    EXPECT_LE((yb.to(torch::kFloat32) - exact).abs().max().item<float>(),
              (torch_bf16 - exact).abs().max().item<float>());
    // NCHW goes to LibTorch's op: bit for bit.
    EXPECT_TRUE(torch::equal(Upsample2xAlignCorners(x.contiguous()), ref));
  }
  // A NaN stays a NaN in both precisions.
  torch::Tensor n = torch::ones({1, 4, 3, 3}).contiguous(torch::MemoryFormat::ChannelsLast);
  n.index_put_({0, 2, 1, 1}, NAN);
  EXPECT_TRUE(Upsample2xAlignCorners(n).isnan().any().item<bool>());
  EXPECT_TRUE(Upsample2xAlignCorners(n.to(torch::kBFloat16)).isnan().any().item<bool>());
}

// A transposed convolution whose kernel is its stride is one matmul and a rearrangement: LibTorch's
// conv_transpose2d's values up to fp32 rounding, on odd sizes, with and without bias; other transposed convolutions
// (overlapping windows, padding) are LibTorch's op itself.
TEST(Kernels, NonOverlappingTransposedConvolutionIsLibTorchs) {
  torch::manual_seed(5);
  struct C {
    int64_t B, cin, cout, H, W, k, s, pad;
    bool bias;
  };
  for (const C& c :
       {C{1, 96, 96, 24, 32, 4, 4, 0, true}, C{2, 7, 5, 3, 5, 2, 2, 0, false}, C{1, 3, 4, 1, 1, 3, 3, 0, true},
        C{1, 6, 4, 5, 4, 3, 2, 1, true}, C{1, 6, 4, 5, 4, 4, 2, 0, true}}) {
    SCOPED_TRACE(::testing::Message() << "B" << c.B << " " << c.cin << "->" << c.cout << " " << c.H << "x" << c.W
                                      << " k" << c.k << " s" << c.s << " pad" << c.pad);
    Conv conv;
    conv.w = torch::randn({c.cin, c.cout, c.k, c.k});
    if (c.bias) conv.b = torch::randn({c.cout});
    conv.stride = c.s;
    conv.padding = c.pad;
    conv.transpose = true;
    const torch::Tensor x = torch::randn({c.B, c.cin, c.H, c.W});
    const torch::Tensor ref = torch::conv_transpose2d(x, conv.w, conv.b, c.s, c.pad);
    const torch::Tensor y = conv(x, PrecisionPolicy{});
    ASSERT_EQ(y.sizes(), ref.sizes());
    EXPECT_LE((y - ref).abs().max().item<float>(), 1e-5f * (1.0f + ref.abs().max().item<float>()));
    if (c.k != c.s || c.pad != 0) {
      EXPECT_TRUE(torch::equal(y, ref));  // LibTorch's op
    }
  }
}

// A chain-only convolution's bf16 weights kept channels-last (Conv::ForChains): the layout changes, the values the
// chain computes do not; fp32 weights are left alone.
TEST(Kernels, ChainWeightsChannelsLastGiveTheSameValues) {
  torch::manual_seed(3);
  Conv conv;
  conv.w_lp = torch::randn({24, 40, 3, 3}).to(torch::kBFloat16);
  conv.b_lp = torch::randn({24}).to(torch::kBFloat16);
  conv.padding = 1;
  const torch::Tensor x = torch::randn({1, 40, 13, 17});
  const torch::Tensor before = conv.Chain(x);
  EXPECT_FALSE(conv.w_lp.is_contiguous(torch::MemoryFormat::ChannelsLast));
  conv.ForChains();
  EXPECT_TRUE(conv.w_lp.is_contiguous(torch::MemoryFormat::ChannelsLast));
  EXPECT_TRUE(torch::equal(conv.Chain(x), before));
  Conv fp32;
  fp32.w = torch::randn({4, 3, 3, 3});
  fp32.ForChains();
  EXPECT_FALSE(fp32.w_lp.defined());
  EXPECT_TRUE(fp32.w.is_contiguous());
}

// Norm + GELU_erf in one pass, written in bf16 (SegGPT's decoder tail): the fp32 LibTorch ops' values rounded to bf16
// (one bf16 step apart at most, where the 1.5e-7 erf or the order of the sums decides the rounding), from fp32 and
// bf16 inputs, odd widths; NaN kept; without bf16 it is LibTorch's ops.
TEST(Kernels, NormGeluInBf16IsLibTorchsRounded) {
  torch::manual_seed(9);
  PrecisionPolicy bf16;
  bf16.bf16 = true;
  for (const int64_t c : {64, 37, 3}) {
    SCOPED_TRACE(c);
    LayerNorm n;
    n.w = torch::randn({c}) * 2;
    n.b = torch::randn({c});
    n.eps = 1e-6;
    for (const bool bf16_in : {false, true}) {
      torch::Tensor x = torch::randn({2, 9, 7, c}) * 3 + 0.5;
      if (bf16_in) x = x.to(torch::kBFloat16);
      const torch::Tensor ref = torch::gelu(torch::layer_norm(x.to(torch::kFloat32), {c}, n.w, n.b, n.eps));
      const torch::Tensor y = n.GeluForProducts(x, bf16);
      ASSERT_EQ(y.scalar_type(), torch::kBFloat16);
      const torch::Tensor diff = (y.to(torch::kFloat32) - ref.to(torch::kBFloat16).to(torch::kFloat32)).abs();
      EXPECT_TRUE((diff <= ref.abs() * (1.0 / 128) + 1e-6).all().item<bool>());
      EXPECT_LE((diff > 0).to(torch::kFloat32).mean().item<float>(), 0.01f);
    }
    const torch::Tensor x = torch::randn({5, c});
    EXPECT_TRUE(
        torch::equal(n.GeluForProducts(x, PrecisionPolicy{}), torch::gelu(torch::layer_norm(x, {c}, n.w, n.b, n.eps))));
  }
  LayerNorm n;
  n.w = torch::ones({4});
  n.b = torch::zeros({4});
  torch::Tensor x = torch::randn({3, 4});
  x.index_put_({1, 2}, NAN);
  const torch::Tensor y = n.GeluForProducts(x, bf16).to(torch::kFloat32);
  EXPECT_TRUE(y[1].isnan().all().item<bool>());  // the row's statistics are NaN
  EXPECT_FALSE(y[0].isnan().any().item<bool>());
}

}  // namespace
}  // namespace freeloc::nn::internal
