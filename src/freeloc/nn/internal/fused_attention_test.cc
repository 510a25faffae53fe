// The fused attention kernels (every instruction set this CPU can run) against a naive double-precision reference,
// op by op: odd token counts on both sides of the 64-row/64-key blocks, odd head dims, several heads and batches,
// strided views of a fused qkv projection, bf16 inputs, RoPE in the pass, vitdet relative-position terms, masks
// (rows with every key removed included), and logits large enough to move the running max late.
#include "freeloc/nn/internal/fused_attention.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "freeloc/core/error.h"
#include "freeloc/nn/internal/layers.h"

namespace freeloc::nn::internal {
namespace {

// softmax(q·kᵀ·scale + rel + mask)·v per (batch, head), in double; q, k already rotated. → [B, Nq, H, Dv].
torch::Tensor NaiveAttention(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v, double scale,
                             const torch::Tensor& rel_h, const torch::Tensor& rel_w, const torch::Tensor& mask) {
  const torch::Tensor qd = q.to(torch::kFloat64).contiguous(), kd = k.to(torch::kFloat64).contiguous(),
                      vd = v.to(torch::kFloat64).contiguous();
  const auto qa = qd.accessor<double, 4>(), ka = kd.accessor<double, 4>(), va = vd.accessor<double, 4>();
  const int64_t B = q.size(0), H = q.size(1), Nq = q.size(2), Nk = k.size(2), D = q.size(3), Dv = v.size(3);
  torch::Tensor out = torch::zeros({B, Nq, H, Dv}, torch::kFloat64);
  auto oa = out.accessor<double, 4>();
  std::vector<double> s(static_cast<size_t>(Nk));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t h = 0; h < H; ++h)
      for (int64_t i = 0; i < Nq; ++i) {
        double mx = -INFINITY;
        for (int64_t j = 0; j < Nk; ++j) {
          double d = 0;
          for (int64_t c = 0; c < D; ++c) d += qa[b][h][i][c] * ka[b][h][j][c];
          d *= scale;
          if (rel_h.defined()) {
            const int64_t kw = rel_w.size(2);
            d += rel_h[b * H + h][i][j / kw].item<double>() + rel_w[b * H + h][i][j % kw].item<double>();
          }
          if (mask.defined()) d += mask[i][j].item<double>();
          s[j] = d;
          mx = std::max(mx, d);
        }
        if (mx == -INFINITY) continue;  // every key removed: zeros
        double sum = 0;
        for (int64_t j = 0; j < Nk; ++j) sum += (s[j] = std::exp(s[j] - mx));
        for (int64_t e = 0; e < Dv; ++e) {
          double o = 0;
          for (int64_t j = 0; j < Nk; ++j) o += s[j] * va[b][h][j][e];
          oa[b][i][h][e] = o / sum;
        }
      }
  return out;
}

torch::Tensor RoundBf16(const torch::Tensor& t) { return t.to(torch::kBFloat16).to(torch::kFloat32); }

std::vector<AttentionIsa> Kernels() {
  std::vector<AttentionIsa> r;
  for (AttentionIsa isa :
       {AttentionIsa::kAvx512Bf16, AttentionIsa::kAvx512, AttentionIsa::kAvx2, AttentionIsa::kGeneric})
    if (AttentionIsaAvailable(isa)) r.push_back(isa);
  return r;
}

struct Case {
  int64_t B, H, Nq, Nk, D, Dv;
  bool rope = false, rel = false, mask = false, strided = false, bf16_inputs = false;
  double q_gain = 1;  // large values: logits of tens, the running max moving block after block
};

void Check(const Case& c, AttentionIsa isa, uint64_t seed) {
  SCOPED_TRACE(::testing::Message() << AttentionIsaName(isa) << " B" << c.B << " H" << c.H << " Nq" << c.Nq << " Nk"
                                    << c.Nk << " D" << c.D << " Dv" << c.Dv << (c.rope ? " rope" : "")
                                    << (c.rel ? " rel" : "") << (c.mask ? " mask" : "") << (c.strided ? " strided" : "")
                                    << (c.bf16_inputs ? " bf16-in" : ""));
  torch::manual_seed(seed);
  torch::Tensor q, k, v;
  if (c.strided) {  // views into one [B, N, 3, H, D] projection, as SelfAttention makes them (needs Nq = Nk, D = Dv)
    const torch::Tensor qkv = torch::randn({c.B, c.Nq, 3, c.H, c.D}).permute({2, 0, 3, 1, 4});
    q = qkv[0];
    k = qkv[1];
    v = qkv[2];
    ASSERT_FALSE(k.is_contiguous());
  } else {
    q = torch::randn({c.B, c.H, c.Nq, c.D});
    k = torch::randn({c.B, c.H, c.Nk, c.D});
    v = torch::randn({c.B, c.H, c.Nk, c.Dv});
  }
  if (c.q_gain != 1) q = q * c.q_gain;
  if (c.bf16_inputs) {
    q = q.to(torch::kBFloat16);
    k = k.to(torch::kBFloat16);
    v = v.to(torch::kBFloat16);
  }
  const double scale = 1.0 / std::sqrt(static_cast<double>(c.D));
  AttentionExtras x;
  std::pair<torch::Tensor, torch::Tensor> rq, rk;
  const Rope2D rope(100.0);
  if (c.rope) {  // grids whose token counts are Nq and Nk
    rq = rope.Tables(1, c.Nq, c.D, torch::kCPU);
    rk = rope.Tables(c.Nk % 3 == 0 ? 3 : 1, c.Nk % 3 == 0 ? c.Nk / 3 : c.Nk, c.D, torch::kCPU);
    x.rope_q = &rq;
    x.rope_k = &rk;
  }
  if (c.rel) {
    const int64_t kh = c.Nk % 5 == 0 ? 5 : 1, kw = c.Nk / kh;
    x.rel_h = torch::randn({c.B * c.H, c.Nq, kh});
    x.rel_w = torch::randn({c.B * c.H, c.Nq, kw});
  }
  if (c.mask) {
    x.mask = torch::where(torch::rand({c.Nq, c.Nk}) < 0.3, torch::full({}, -INFINITY), torch::randn({c.Nq, c.Nk}));
    x.mask[0].fill_(-INFINITY);  // a row with every key removed
  }
  const bool bf16 = isa == AttentionIsa::kAvx512Bf16;
  const torch::Tensor got = FusedAttention(q, k, v, scale, x, bf16, isa);
  ASSERT_EQ(got.sizes(), torch::IntArrayRef({c.B, c.Nq, c.H, c.Dv}));
  ASSERT_EQ(got.scalar_type(), torch::kFloat32);

  // The reference sees what the kernel multiplies: RoPE applied, and for the bf16 kernel q·scale, k and v rounded to
  // bf16 (P's rounding is the one approximation left, ≤ 2⁻⁹ relative per weight).
  torch::Tensor qr = q.to(torch::kFloat32), kr = k.to(torch::kFloat32), vr = v.to(torch::kFloat32);
  if (c.rope) {
    qr = Rope2D::Apply(qr, rq);
    kr = Rope2D::Apply(kr, rk);
  }
  double ref_scale = scale;
  if (bf16) {  // the kernel folds log2 e into q's scale (base-2 logits) before rounding
    const double log2e = 1.4426950408889634;
    qr = RoundBf16(qr * (scale * log2e)).to(torch::kFloat64) / log2e;
    kr = RoundBf16(kr);
    vr = RoundBf16(vr);
    ref_scale = 1;
  }
  const torch::Tensor want = NaiveAttention(qr, kr, vr, ref_scale, x.rel_h, x.rel_w, x.mask);
  const double vmax = vr.abs().max().item<double>();
  const double err = (got.to(torch::kFloat64) - want).abs().max().item<double>();
  EXPECT_LT(err, (bf16 ? 6e-3 : 2e-5) * vmax) << "max |error| " << err << " with max |v| " << vmax;
  EXPECT_FALSE(got.isnan().any().item<bool>());
  if (c.mask) {
    EXPECT_EQ(got.select(1, 0).abs().max().item<float>(), 0.0f);  // the fully masked row
  }
}

TEST(FusedAttention, EveryKernelMatchesTheNaiveReference) {
  const std::vector<AttentionIsa> kernels = Kernels();
  ASSERT_FALSE(kernels.empty());
  const Case cases[] = {
      {1, 1, 1, 1, 1, 1},
      {1, 3, 7, 13, 5, 3},
      {2, 2, 65, 63, 16, 16},
      {1, 2, 64, 64, 64, 64},
      {1, 1, 129, 130, 24, 40},
      {2, 3, 31, 200, 8, 17},
      {1, 2, 77, 77, 64, 64, /*rope=*/true},
      {1, 2, 50, 90, 32, 32, true},  // cross-attention: different grids for q and k
      {1, 2, 45, 60, 16, 16, false, /*rel=*/true},
      {1, 2, 70, 280, 16, 16, false, true},  // rel over several key blocks: rows of 56 keys crossing block edges
      {1, 1, 30, 301, 8, 8, false, true},    // one 301-key row of rel_w spanning three key blocks
      {2, 1, 40, 75, 12, 12, false, true, /*mask=*/true},
      {1, 2, 70, 70, 64, 64, true, false, false, /*strided=*/true},
      {1, 3, 33, 33, 20, 20, false, false, false, true, /*bf16_inputs=*/true},
      {2, 2, 41, 129, 24, 17, false, false, false, false, true},  // bf16 V packed in key pairs: an odd Nk and Dv
      {1, 2, 80, 300, 64, 64, false, false, false, false, false, /*q_gain=*/6},
      {1, 1, 20, 1100, 8, 16, false, false, true},
  };
  uint64_t seed = 1;
  for (AttentionIsa isa : kernels) {
    for (const Case& c : cases) Check(c, isa, seed++);
  }
}

// Relative-position terms given by offset (one GEMM per table in SegGPT) are the per-pair terms gathered by vitdet's
// index hq − hk + key_h − 1: the same bias values, so the same outputs bit for bit, on grids of one and of several
// key blocks, in every kernel.
TEST(FusedAttention, RelativeTermsByOffsetAreThePerPairTerms) {
  struct Grid {
    int64_t B, H, kh, kw, D;
  };
  uint64_t seed = 100;
  for (AttentionIsa isa : Kernels())
    for (const Grid g : {Grid{1, 2, 3, 5, 16}, Grid{2, 1, 7, 19, 8}, Grid{1, 2, 6, 40, 32}}) {
      SCOPED_TRACE(::testing::Message() << AttentionIsaName(isa) << " grid " << g.kh << "x" << g.kw);
      torch::manual_seed(seed++);
      const int64_t N = g.kh * g.kw, BH = g.B * g.H;
      const torch::Tensor q = torch::randn({g.B, g.H, N, g.D}), k = torch::randn({g.B, g.H, N, g.D}),
                          v = torch::randn({g.B, g.H, N, g.D});
      AttentionExtras by_offset;
      by_offset.rel_h = torch::randn({BH, N, 2 * g.kh - 1});
      by_offset.rel_w = torch::randn({BH, N, 2 * g.kw - 1});
      by_offset.rel_by_offset = true;
      by_offset.rel_key_w = g.kw;
      AttentionExtras per_pair;
      per_pair.rel_h = torch::empty({BH, N, g.kh});
      per_pair.rel_w = torch::empty({BH, N, g.kw});
      auto oh = by_offset.rel_h.accessor<float, 3>(), ow = by_offset.rel_w.accessor<float, 3>();
      auto ph = per_pair.rel_h.accessor<float, 3>(), pw = per_pair.rel_w.accessor<float, 3>();
      for (int64_t b = 0; b < BH; ++b)
        for (int64_t i = 0; i < N; ++i) {
          const int64_t hq = i / g.kw, wq = i % g.kw;
          for (int64_t hk = 0; hk < g.kh; ++hk) ph[b][i][hk] = oh[b][i][hq - hk + g.kh - 1];
          for (int64_t wk = 0; wk < g.kw; ++wk) pw[b][i][wk] = ow[b][i][wq - wk + g.kw - 1];
        }
      const bool bf16 = isa == AttentionIsa::kAvx512Bf16;
      const torch::Tensor a = FusedAttention(q, k, v, 0.3, by_offset, bf16, isa);
      const torch::Tensor b = FusedAttention(q, k, v, 0.3, per_pair, bf16, isa);
      EXPECT_TRUE(torch::equal(a, b)) << (a - b).abs().max().item<float>();
    }
  // By offset needs one grid for queries and keys.
  AttentionExtras bad;
  bad.rel_h = torch::randn({1, 6, 5});
  bad.rel_w = torch::randn({1, 6, 3});
  bad.rel_by_offset = true;
  bad.rel_key_w = 2;
  const torch::Tensor q6 = torch::randn({1, 1, 6, 8}), k4 = torch::randn({1, 1, 4, 8});
  EXPECT_THROW(FusedAttention(q6, k4, k4, 1.0, bad, false), Error);
  bad.rel_key_w = 4;  // 6 keys are not rows of 4
  EXPECT_THROW(FusedAttention(q6, q6, q6, 1.0, bad, false), Error);
}

// bf16 output: exactly the fp32 output rounded to bf16 (nearest even, as torch's conversion), every kernel, with an
// odd head dim and a masked row (zeros).
TEST(FusedAttention, Bf16OutputIsTheFp32OutputRounded) {
  uint64_t seed = 300;
  for (AttentionIsa isa : Kernels())
    for (const int64_t Dv : {8, 13, 64}) {
      SCOPED_TRACE(::testing::Message() << AttentionIsaName(isa) << " Dv " << Dv);
      torch::manual_seed(seed++);
      const torch::Tensor q = torch::randn({2, 3, 70, 16}), k = torch::randn({2, 3, 131, 16}),
                          v = torch::randn({2, 3, 131, Dv}) * 5;
      AttentionExtras x;
      x.mask = torch::zeros({70, 131});
      x.mask[4].fill_(-INFINITY);
      const bool bf16 = isa == AttentionIsa::kAvx512Bf16;
      const torch::Tensor f = FusedAttention(q, k, v, 0.25, x, bf16, isa);
      const torch::Tensor h = FusedAttention(q, k, v, 0.25, x, bf16, isa, /*bf16_out=*/true);
      ASSERT_EQ(h.scalar_type(), torch::kBFloat16);
      ASSERT_EQ(h.sizes(), f.sizes());
      EXPECT_TRUE(torch::equal(h, f.to(torch::kBFloat16)));
    }
}

// The auto choice runs bf16 products only where the CPU has them, and every CPU gets some kernel.
TEST(FusedAttention, AutoPicksARunnableKernel) {
  EXPECT_TRUE(AttentionIsaAvailable(AutoAttentionIsa(false)));
  EXPECT_TRUE(AttentionIsaAvailable(AutoAttentionIsa(true)));
  EXPECT_NE(AutoAttentionIsa(false), AttentionIsa::kAvx512Bf16);
}

TEST(FusedAttention, RefusesShapesItCannotTake) {
  const torch::Tensor q = torch::randn({1, 2, 5, 6}), v = torch::randn({1, 2, 5, 6});
  const Rope2D rope(100.0);
  const auto t = rope.Tables(1, 5, 6, torch::kCPU);
  AttentionExtras x;
  x.rope_q = &t;
  EXPECT_THROW(FusedAttention(q, q, v, 1.0, x, false), Error);                            // D % 4 != 0 with RoPE
  EXPECT_THROW(FusedAttention(q, torch::randn({1, 2, 5, 7}), v, 1.0, {}, false), Error);  // D mismatch
  EXPECT_THROW(FusedAttention(q, q, torch::randn({1, 2, 4, 6}), 1.0, {}, false), Error);  // Nk mismatch
  AttentionExtras m;
  m.mask = torch::zeros({5, 4});
  EXPECT_THROW(FusedAttention(q, q, v, 1.0, m, false), Error);
  EXPECT_THROW(FusedAttention(q.to(torch::kFloat64), q, v, 1.0, {}, false), Error);
}

}  // namespace
}  // namespace freeloc::nn::internal
