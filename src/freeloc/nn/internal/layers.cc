#include "freeloc/nn/internal/layers.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

namespace freeloc::nn::internal {

void Linear::Load(WeightStore& ws, const std::string& prefix, int64_t out, int64_t in, bool bias,
                  const PrecisionPolicy& p) {
  w = ws.Take(prefix + ".weight", {out, in});
  if (bias) b = ws.Take(prefix + ".bias", {out});
  if (p.bf16 && w.defined()) {
    if (w.device().is_cpu()) {
      packed = std::make_shared<PackedLinearBf16>(w, b);
    } else {
      w_lp = w.to(torch::kBFloat16);
      if (b.defined()) b_lp = b.to(torch::kBFloat16);
    }
    w = torch::Tensor();  // held once, in bf16
  }
}

torch::Tensor Linear::operator()(const torch::Tensor& x, const PrecisionPolicy& p) const {
  if (p.bf16 && packed) return (*packed)(x);
  if (p.bf16) return torch::linear(x.to(torch::kBFloat16), w_lp, b_lp).to(torch::kFloat32);
  return torch::linear(x, w, b);
}

torch::Tensor Linear::ForProducts(const torch::Tensor& x, const PrecisionPolicy& p) const {
  if (p.bf16 && packed) return packed->Forward(x, /*gelu=*/false, /*bf16_out=*/true);
  return (*this)(x, p);
}

void LayerNorm::Load(WeightStore& ws, const std::string& prefix, int64_t dim, double e) {
  w = ws.Take(prefix + ".weight", {dim});
  b = ws.Take(prefix + ".bias", {dim});
  eps = e;
}

torch::Tensor LayerNorm::operator()(const torch::Tensor& x) const {
  return torch::layer_norm(x, {x.size(-1)}, w, b, eps);
}

namespace {

// One value as fp32 from fp32 or bf16 (uint16_t), and back: bf16 rounded to nearest even, NaN kept a (quiet) NaN.
inline __attribute__((always_inline)) float Load1(const float* p) { return *p; }
inline __attribute__((always_inline)) float Load1(const uint16_t* p) {
  const uint32_t u = static_cast<uint32_t>(*p) << 16;
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}
inline __attribute__((always_inline)) void Store1(float* p, float v) { *p = v; }
inline __attribute__((always_inline)) void Store1(uint16_t* p, float v) {
  uint32_t u;
  std::memcpy(&u, &v, 4);
  const uint32_t rounded = (u + 0x7FFFu + ((u >> 16) & 1u)) >> 16;
  *p = static_cast<uint16_t>(v != v ? (u >> 16) | 0x40u : rounded);
}

// A row's mean and 1/sqrt(biased variance + eps) in fp32: sums in 16 lanes (vectorised without reassociation flags),
// then across them. Inlined into each target_clones copy.
inline __attribute__((always_inline)) void RowStatistics(const float* src, int64_t c, float eps, float* mean_out,
                                                         float* rstd_out) {
  float acc[16] = {};
  int64_t i0 = 0;
  for (; i0 + 16 <= c; i0 += 16)
    for (int j = 0; j < 16; ++j) acc[j] += src[i0 + j];
  float sum = 0;
  for (int j = 0; j < 16; ++j) sum += acc[j];
  for (int64_t i = i0; i < c; ++i) sum += src[i];
  const float mean = sum / static_cast<float>(c);
  float sq_acc[16] = {};
  for (i0 = 0; i0 + 16 <= c; i0 += 16)
    for (int j = 0; j < 16; ++j) sq_acc[j] += (src[i0 + j] - mean) * (src[i0 + j] - mean);
  float sq = 0;
  for (int j = 0; j < 16; ++j) sq += sq_acc[j];
  for (int64_t i = i0; i < c; ++i) sq += (src[i] - mean) * (src[i] - mean);
  *mean_out = mean;
  *rstd_out = 1.0f / std::sqrt(sq / static_cast<float>(c) + eps);
}

// Rows of `c` values: s = x (+ d), then y = (s − mean)·rstd·w + b rounded to bf16 (nearest even, NaN kept). Compiled
// for AVX-512, AVX2 and the baseline; the loader picks one (GCC target_clones).
__attribute__((target_clones("avx512f", "avx2", "default"))) void AddNormRowsBf16(const float* x, const float* d,
                                                                                  float* s_out, const float* w,
                                                                                  const float* b, float eps, int64_t c,
                                                                                  int64_t r0, int64_t r1, uint16_t* y) {
  for (int64_t r = r0; r < r1; ++r) {
    const float* xr = x + r * c;
    float* sr = s_out ? s_out + r * c : nullptr;
    const float* src = xr;
    if (d) {
      const float* dr = d + r * c;
      for (int64_t i = 0; i < c; ++i) sr[i] = xr[i] + dr[i];
      src = sr;
    }
    float mean, rstd;
    RowStatistics(src, c, eps, &mean, &rstd);
    uint16_t* yr = y + r * c;
    for (int64_t i = 0; i < c; ++i) Store1(yr + i, (src[i] - mean) * rstd * w[i] + b[i]);
  }
}

torch::Tensor AddNormBf16(const torch::Tensor& x, const torch::Tensor* delta, torch::Tensor* sum, const LayerNorm& n) {
  const int64_t c = x.size(-1), rows = x.numel() / c;
  const torch::Tensor xc = x.contiguous();
  const torch::Tensor dc = delta ? delta->contiguous() : torch::Tensor();
  if (delta) *sum = torch::empty_like(xc);
  const torch::Tensor w = n.w.contiguous(), b = n.b.contiguous();
  torch::Tensor y = torch::empty(x.sizes(), x.options().dtype(torch::kBFloat16));
  const float* xp = xc.data_ptr<float>();
  const float* dp = delta ? dc.data_ptr<float>() : nullptr;
  float* sp = delta ? sum->data_ptr<float>() : nullptr;
  uint16_t* yp = reinterpret_cast<uint16_t*>(y.data_ptr());
  at::parallel_for(0, rows, 16, [&](int64_t r0, int64_t r1) {
    AddNormRowsBf16(xp, dp, sp, w.data_ptr<float>(), b.data_ptr<float>(), static_cast<float>(n.eps), c, r0, r1, yp);
  });
  return y;
}

bool NormInBf16(const torch::Tensor& x, const PrecisionPolicy& p) {
  return p.bf16 && x.device().is_cpu() && x.scalar_type() == torch::kFloat32;
}

}  // namespace

torch::Tensor LayerNorm::ForProducts(const torch::Tensor& x, const PrecisionPolicy& p) const {
  if (!NormInBf16(x, p)) return (*this)(x);
  return AddNormBf16(x, nullptr, nullptr, *this);
}

torch::Tensor LayerNorm::AddForProducts(torch::Tensor* x, const torch::Tensor& delta, const PrecisionPolicy& p) const {
  if (!NormInBf16(*x, p) || delta.scalar_type() != torch::kFloat32 || delta.sizes() != x->sizes()) {
    *x = *x + delta;
    return ForProducts(*x, p);
  }
  torch::Tensor sum;
  torch::Tensor y = AddNormBf16(*x, &delta, &sum, *this);
  *x = sum;
  return y;
}

void Mlp::Load(WeightStore& ws, const std::string& prefix, int64_t dim, int64_t hidden, const PrecisionPolicy& p) {
  fc1.Load(ws, prefix + ".fc1", hidden, dim, true, p);
  fc2.Load(ws, prefix + ".fc2", dim, hidden, true, p);
}

torch::Tensor Linear::Gelu(const torch::Tensor& x, const PrecisionPolicy& p) const {
  if (p.bf16 && packed) return packed->Forward(x, /*gelu=*/true, /*bf16_out=*/true);
  return torch::gelu((*this)(x, p));
}

torch::Tensor Mlp::operator()(const torch::Tensor& x, const PrecisionPolicy& p) const { return fc2(fc1.Gelu(x, p), p); }

std::pair<torch::Tensor, torch::Tensor> Rope2D::Tables(int64_t h, int64_t w, int64_t dh, torch::Device device) const {
  const auto key = std::make_tuple(h, w, dh, static_cast<int>(device.type()));
  auto it = cache_.find(key);
  if (it != cache_.end()) return it->second;
  const int64_t D = dh / 2;  // per axis
  auto f32 = torch::TensorOptions().dtype(torch::kFloat32);
  // inv_freq = 1 / base^(arange(0, D, 2) / D), in float32 like the reference.
  const torch::Tensor inv_freq =
      1.0 / torch::pow(torch::full({1}, base_, f32), torch::arange(0, D, 2, f32) / static_cast<float>(D));
  const torch::Tensor ys = torch::arange(h, f32).repeat_interleave(w);  // row-major n = y·w + x
  const torch::Tensor xs = torch::arange(w, f32).repeat({h});
  const torch::Tensor ay = ys.unsqueeze(1) * inv_freq.unsqueeze(0);  // [N, D/2]
  const torch::Tensor ax = xs.unsqueeze(1) * inv_freq.unsqueeze(0);
  const torch::Tensor cy = ay.cos(), sy = ay.sin(), cx = ax.cos(), sx = ax.sin();
  torch::Tensor cos = torch::cat({cy, cy, cx, cx}, 1).to(device);
  torch::Tensor sin = torch::cat({-sy, sy, -sx, sx}, 1).to(device);
  auto r = std::make_pair(cos, sin);
  cache_[key] = r;
  return r;
}

torch::Tensor Rope2D::Apply(const torch::Tensor& t, const std::pair<torch::Tensor, torch::Tensor>& tables) {
  const auto sz = t.sizes();
  const int64_t dh = sz.back();
  // swap(t): exchange the two quarters inside each half (the rotate_half pairing), sign carried by SIN.
  std::vector<int64_t> v(sz.begin(), sz.end() - 1);
  v.insert(v.end(), {2, 2, dh / 4});
  const torch::Tensor swapped = t.reshape(v).flip({-2}).reshape(sz);
  return t * tables.first + swapped * tables.second;
}

torch::Tensor ScaledDotProductReference(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v,
                                        double scale) {
  torch::Tensor a = torch::matmul(q, k.transpose(-2, -1));
  a.mul_(scale);
  return torch::matmul(torch::softmax(a, -1), v);
}

torch::Tensor ScaledDotProduct(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v, double scale,
                               const PrecisionPolicy& p, int64_t block_rows) {
  const int64_t B = q.size(0), H = q.size(1), Nq = q.size(2), Nk = k.size(2), D = q.size(3), Dv = v.size(3);
  if (p.bf16) {
    // bf16 matmuls, fp32 softmax (the autocast policy), heads in 16 MB chunks of logits.
    const int64_t per = std::max<int64_t>(1, (int64_t{16} << 20) / (Nq * Nk * 4));
    const torch::Tensor qf = q.reshape({B * H, Nq, D}), kf = k.reshape({B * H, Nk, D}), vf = v.reshape({B * H, Nk, Dv});
    torch::Tensor o = torch::empty({B * H, Nq, Dv}, q.options());
    for (int64_t h0 = 0; h0 < B * H; h0 += per) {
      const int64_t h1 = std::min(B * H, h0 + per);
      const torch::Tensor a = torch::matmul(qf.slice(0, h0, h1).to(torch::kBFloat16),
                                            kf.slice(0, h0, h1).to(torch::kBFloat16).transpose(-2, -1));
      const torch::Tensor s = torch::softmax(a.to(torch::kFloat32) * scale, -1);
      o.slice(0, h0, h1).copy_(
          torch::matmul(s.to(torch::kBFloat16), vf.slice(0, h0, h1).to(torch::kBFloat16)).to(torch::kFloat32));
    }
    return o.view({B, H, Nq, Dv});
  }
  // fp32: row-blocked. For each (head, block of query rows) the logits block (rows × Nk) is computed, soft-maxed and
  // multiplied by V while it is still in cache, instead of writing and re-reading Nq × Nk logits per head through
  // memory; the scale is folded into Q (Nq × D multiplies instead of Nq × Nk). Work items (head, block) are spread
  // over the threads; each runs single-threaded GEMMs. bench/attention measures it against the unblocked form.
  const int64_t BH = B * H;
  const torch::Tensor qf = (q * scale).reshape({BH, Nq, D}).contiguous();
  const torch::Tensor kf = k.reshape({BH, Nk, D}).contiguous(), vf = v.reshape({BH, Nk, Dv}).contiguous();
  torch::Tensor o = torch::empty({BH, Nq, Dv}, q.options());
  const int64_t rows = std::max<int64_t>(1, std::min(block_rows, Nq));
  const int64_t blocks = (Nq + rows - 1) / rows;
  at::parallel_for(0, BH * blocks, 1, [&](int64_t begin, int64_t end) {
    torch::Tensor s = torch::empty({rows, Nk}, q.options()), pr = torch::empty({rows, Nk}, q.options());
    for (int64_t i = begin; i < end; ++i) {
      const int64_t h = i / blocks, r0 = (i % blocks) * rows, r1 = std::min(Nq, r0 + rows);
      torch::Tensor sb = s.slice(0, 0, r1 - r0), pb = pr.slice(0, 0, r1 - r0), ob = o[h].slice(0, r0, r1);
      at::mm_out(sb, qf[h].slice(0, r0, r1), kf[h].t());
      at::_softmax_out(pb, sb, 1, false);
      at::mm_out(ob, pb, vf[h]);
    }
  });
  return o.view({B, H, Nq, Dv});
}

void SelfAttention::Load(WeightStore& ws, const std::string& prefix, int64_t dim, int64_t h, const PrecisionPolicy& p) {
  qkv.Load(ws, prefix + ".qkv", 3 * dim, dim, true, p);
  proj.Load(ws, prefix + ".proj", dim, dim, true, p);
  heads = h;
}

torch::Tensor SelfAttention::operator()(const torch::Tensor& x, const std::pair<torch::Tensor, torch::Tensor>& rope,
                                        const PrecisionPolicy& p) const {
  const int64_t B = x.size(0), N = x.size(1), C = x.size(2), dh = C / heads;
  const double scale = std::pow(static_cast<double>(dh), -0.5);
  if (UseFusedAttention(x.device())) {  // views into the qkv projection (bf16 when it runs bf16), RoPE in the pass
    const torch::Tensor t = qkv.ForProducts(x, p).reshape({B, N, 3, heads, dh}).permute({2, 0, 3, 1, 4});
    AttentionExtras e;
    e.rope_q = e.rope_k = &rope;
    return proj(
        FusedAttention(t[0], t[1], t[2], scale, e, p.bf16, AttentionIsa::kAuto, proj.TakesBf16(p)).view({B, N, C}), p);
  }
  const torch::Tensor t = qkv(x, p).reshape({B, N, 3, heads, dh}).permute({2, 0, 3, 1, 4});  // 3,B,H,N,dh
  const torch::Tensor q = Rope2D::Apply(t[0], rope), k = Rope2D::Apply(t[1], rope);
  const torch::Tensor o = ScaledDotProduct(q, k, t[2], scale, p);
  return proj(o.transpose(1, 2).reshape({B, N, C}), p);
}

void CrossAttention::Load(WeightStore& ws, const std::string& prefix, int64_t dim, int64_t h,
                          const PrecisionPolicy& p) {
  q.Load(ws, prefix + ".projq", dim, dim, true, p);
  k.Load(ws, prefix + ".projk", dim, dim, true, p);
  v.Load(ws, prefix + ".projv", dim, dim, true, p);
  proj.Load(ws, prefix + ".proj", dim, dim, true, p);
  heads = h;
}

torch::Tensor CrossAttention::operator()(const torch::Tensor& x, const torch::Tensor& y,
                                         const std::pair<torch::Tensor, torch::Tensor>& rope_x,
                                         const std::pair<torch::Tensor, torch::Tensor>& rope_y,
                                         const PrecisionPolicy& p) const {
  const int64_t B = x.size(0), Nq = x.size(1), C = x.size(2), Nk = y.size(1), dh = C / heads;
  const double scale = std::pow(static_cast<double>(dh), -0.5);
  if (UseFusedAttention(x.device())) {
    const torch::Tensor qq = q.ForProducts(x, p).reshape({B, Nq, heads, dh}).transpose(1, 2);
    const torch::Tensor kk = k.ForProducts(y, p).reshape({B, Nk, heads, dh}).transpose(1, 2);
    const torch::Tensor vv = v.ForProducts(y, p).reshape({B, Nk, heads, dh}).transpose(1, 2);
    AttentionExtras e;
    e.rope_q = &rope_x;
    e.rope_k = &rope_y;
    return proj(FusedAttention(qq, kk, vv, scale, e, p.bf16, AttentionIsa::kAuto, proj.TakesBf16(p)).view({B, Nq, C}),
                p);
  }
  const torch::Tensor qq = q(x, p).reshape({B, Nq, heads, dh}).transpose(1, 2);
  const torch::Tensor kk = k(y, p).reshape({B, Nk, heads, dh}).transpose(1, 2);
  const torch::Tensor vv = v(y, p).reshape({B, Nk, heads, dh}).transpose(1, 2);
  const torch::Tensor o = ScaledDotProduct(Rope2D::Apply(qq, rope_x), Rope2D::Apply(kk, rope_y), vv, scale, p);
  return proj(o.transpose(1, 2).reshape({B, Nq, C}), p);
}

void Conv::Load(WeightStore& ws, const std::string& prefix, const std::vector<int64_t>& shape, bool bias, int64_t s,
                int64_t pad, bool tr, const PrecisionPolicy& p) {
  w = ws.Take(prefix + ".weight", shape);
  if (bias) b = ws.Take(prefix + ".bias", {tr ? shape[1] : shape[0]});
  stride = s;
  padding = pad;
  transpose = tr;
  // bf16 keeps the weights once, in bf16 — except LibTorch's CPU transposed convolution, which stays fp32 (below).
  if (p.bf16 && w.defined() && !(tr && w.device().is_cpu())) {
    w_lp = w.to(torch::kBFloat16);
    if (b.defined()) b_lp = b.to(torch::kBFloat16);
    w = torch::Tensor();
    b = torch::Tensor();
  }
}

void Conv::ForChains() {
  if (w_lp.defined() && w_lp.dim() == 4 && w_lp.device().is_cpu())
    w_lp = w_lp.contiguous(torch::MemoryFormat::ChannelsLast);
}

namespace {

// A transposed convolution whose kernel equals its stride (no padding) on the CPU in fp32: the kernel windows do not
// overlap, so it is one matmul — [pixels, Cin] · [Cin, s·s·Cout] — and a rearrangement into the s×s blocks of each
// input pixel, written channels-last (what a chain converts next). LibTorch 1.13 runs it as slow_conv_transpose2d
// (DPT's act_postprocess: 4.7 and 2.8 ms, where the matmul is ≈ 1).
bool NonOverlappingTranspose(const torch::Tensor& x, const torch::Tensor& w, int64_t stride, int64_t padding) {
  return x.dim() == 4 && w.dim() == 4 && x.device().is_cpu() && x.scalar_type() == torch::kFloat32 &&
         w.scalar_type() == torch::kFloat32 && padding == 0 && w.size(2) == stride && w.size(3) == stride &&
         x.size(1) == w.size(0);
}
torch::Tensor NonOverlappingTransposeConv(const torch::Tensor& x, const torch::Tensor& w, const torch::Tensor& b,
                                          int64_t s) {
  const int64_t B = x.size(0), cin = x.size(1), H = x.size(2), W = x.size(3), cout = w.size(1);
  const torch::Tensor rows = x.permute({0, 2, 3, 1}).reshape({B * H * W, cin});
  const torch::Tensor wm = w.permute({0, 2, 3, 1}).reshape({cin, s * s * cout});  // [Cin, ky, kx, Cout]
  torch::Tensor y = torch::matmul(rows, wm).view({B, H, W, s, s, cout});
  if (b.defined()) y.add_(b);
  // [B, H, ky, W, kx, Cout] is [B, H·s, W·s, Cout]: channels-last NCHW.
  return y.permute({0, 1, 3, 2, 4, 5}).reshape({B, H * s, W * s, cout}).permute({0, 3, 1, 2});
}

}  // namespace

torch::Tensor Conv::operator()(const torch::Tensor& x, const PrecisionPolicy& p) const {
  // LibTorch 1.13's CPU conv_transpose2d in bf16 sends the transposed weight down the plain convolution path and
  // fails on its channel check; transposed convolutions (a small share of the FLOPs) stay fp32. The policy was
  // applied at load: the weights are in bf16 exactly when it runs in bf16.
  (void)p;
  if (transpose && !w_lp.defined() && NonOverlappingTranspose(x, w, stride, padding))
    return NonOverlappingTransposeConv(x, w, b, stride);
  const bool lp = w_lp.defined();
  const torch::Tensor in = lp ? x.to(torch::kBFloat16) : x;
  const torch::Tensor& ww = lp ? w_lp : w;
  const torch::Tensor& bb = lp ? b_lp : b;
  torch::Tensor y =
      transpose ? torch::conv_transpose2d(in, ww, bb, stride, padding) : torch::conv2d(in, ww, bb, stride, padding);
  return lp ? y.to(torch::kFloat32) : y;
}

torch::Tensor Conv::Chain(const torch::Tensor& x) const {
  if (!w_lp.defined()) return (*this)(x.scalar_type() == torch::kFloat32 ? x : x.to(torch::kFloat32), {});
  const torch::Tensor in =
      x.to(torch::kBFloat16, /*non_blocking=*/false, /*copy=*/false, torch::MemoryFormat::ChannelsLast);
  return torch::conv2d(in, w_lp, b_lp, stride, padding);
}

torch::Tensor ChainOut(const torch::Tensor& x) { return x.to(torch::kFloat32).contiguous(); }

void PointwiseOut::Load(WeightStore& ws, const std::string& prefix, int64_t o, int64_t in, bool bias,
                        const PrecisionPolicy& p) {
  out = o;
  conv.Load(ws, prefix, {o, in, 1, 1}, bias, 1, 0, false, PrecisionPolicy{});
  if (!p.bf16 || !conv.w.device().is_cpu()) return;
  const torch::Tensor w = conv.w.reshape({o, in});
  const torch::Tensor hi = w.to(torch::kBFloat16).to(torch::kFloat32);
  const torch::Tensor b = conv.b.defined() ? torch::cat({conv.b, torch::zeros_like(conv.b)}) : torch::Tensor();
  packed = std::make_shared<PackedLinearBf16>(torch::cat({hi, w - hi}), b);
  conv = Conv();  // held once, as the two bf16 parts
}

torch::Tensor PointwiseOut::operator()(const torch::Tensor& x) const {
  if (!packed) return ChainOut(conv.Chain(x));
  // Channels-last bf16 [B, C, H, W] is [B, H, W, C] in memory: rows of channels.
  const torch::Tensor rows =
      x.to(torch::kBFloat16, /*non_blocking=*/false, /*copy=*/false, torch::MemoryFormat::ChannelsLast)
          .permute({0, 2, 3, 1});
  const torch::Tensor y = (*packed)(rows);  // [B, H, W, 2·out] fp32
  return (y.slice(3, 0, out) + y.slice(3, out, 2 * out)).permute({0, 3, 1, 2}).contiguous();
}

namespace {

// One output row of a channels-last bilinear resize: out[ow][c] = x0[iw0][c]·w00 + x0[iw1][c]·w01 + x1[iw0][c]·w10 +
// x1[iw1][c]·w11, the weights products of the row's and the column's lambdas (LibTorch's channels-last kernel's
// terms), computed in fp32. `T` is float or uint16_t (bf16, rounded to nearest even, NaN kept).
template <typename T>
inline void ResizeRow(const T* x0, const T* x1, float h0, float h1, const int64_t* iw, const float* lw, int64_t ow,
                      int64_t c, T* out) {
  for (int64_t o = 0; o < ow; ++o) {
    const float w0 = lw[2 * o], w1 = lw[2 * o + 1];
    const float w00 = h0 * w0, w01 = h0 * w1, w10 = h1 * w0, w11 = h1 * w1;
    const T *a = x0 + iw[2 * o] * c, *b = x0 + iw[2 * o + 1] * c, *d = x1 + iw[2 * o] * c, *e = x1 + iw[2 * o + 1] * c;
    T* y = out + o * c;
    for (int64_t i = 0; i < c; ++i)
      Store1(y + i, Load1(a + i) * w00 + Load1(b + i) * w01 + Load1(d + i) * w10 + Load1(e + i) * w11);
  }
}
__attribute__((target_clones("avx512f", "avx2", "default"))) void ResizeRowF32(const float* x0, const float* x1,
                                                                               float h0, float h1, const int64_t* iw,
                                                                               const float* lw, int64_t ow, int64_t c,
                                                                               float* out) {
  ResizeRow(x0, x1, h0, h1, iw, lw, ow, c, out);
}
__attribute__((target_clones("avx512f", "avx2", "default"))) void ResizeRowBf16(const uint16_t* x0, const uint16_t* x1,
                                                                                float h0, float h1, const int64_t* iw,
                                                                                const float* lw, int64_t ow, int64_t c,
                                                                                uint16_t* out) {
  ResizeRow(x0, x1, h0, h1, iw, lw, ow, c, out);
}

// e^x for x ≤ 0 in fp32 (branch-free, so that the loops below vectorise): 2^n·e^r, |r| ≤ ln2/2, r's series to degree
// 6 (≤ 2e-7 relative); below −87 it is e^−87 (≈ 1.6e-38: nothing next to the 1 it is subtracted from).
inline __attribute__((always_inline)) float ExpNonPositive(float x) {
  x = x < -87.0f ? -87.0f : x;
  const float n = (x * 1.44269504f + 12582912.0f) - 12582912.0f;  // rounded to the nearest integer
  const float r = (x - n * 0.693145751953125f) - n * 1.428606765330187e-6f;
  const float e =
      1.0f + r * (1.0f + r * (0.5f + r * (1.0f / 6 + r * (1.0f / 24 + r * (1.0f / 120 + r * (1.0f / 720))))));
  const int32_t bits = (static_cast<int32_t>(n) + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, 4);
  return e * scale;
}
// GELU_erf(y) = y/2·(1 + erf(y/√2)), erf by Abramowitz & Stegun 7.1.26 (|error| ≤ 1.5e-7); NaN stays NaN.
inline __attribute__((always_inline)) float GeluErf(float y) {
  const float z = y * 0.70710678118654752f, a = z < 0 ? -z : z;
  const float t = 1.0f / (1.0f + 0.3275911f * a);
  const float poly =
      t * (0.254829592f + t * (-0.284496736f + t * (1.421413741f + t * (-1.453152027f + t * 1.061405429f))));
  const float e = 1.0f - poly * ExpNonPositive(-a * a);
  return 0.5f * y * (1.0f + (z < 0 ? -e : e));
}
template <typename T>  // always inlined: each target_clones copy compiles it for its own instruction set
inline __attribute__((always_inline)) void NormGeluRows(const T* x, const float* w, const float* b, float eps,
                                                        int64_t c, int64_t r0, int64_t r1, uint16_t* y) {
  std::vector<float> row(static_cast<size_t>(c));
  for (int64_t r = r0; r < r1; ++r) {
    const T* xr = x + r * c;
    for (int64_t i = 0; i < c; ++i) row[i] = Load1(xr + i);
    float mean, rstd;
    RowStatistics(row.data(), c, eps, &mean, &rstd);
    uint16_t* yr = y + r * c;
    for (int64_t i = 0; i < c; ++i) row[i] = GeluErf((row[i] - mean) * rstd * w[i] + b[i]);
    for (int64_t i = 0; i < c; ++i) Store1(yr + i, row[i]);
  }
}
__attribute__((target_clones("avx512f", "avx2", "default"))) void NormGeluRowsF32(const float* x, const float* w,
                                                                                  const float* b, float eps, int64_t c,
                                                                                  int64_t r0, int64_t r1, uint16_t* y) {
  NormGeluRows(x, w, b, eps, c, r0, r1, y);
}
__attribute__((target_clones("avx512f", "avx2", "default"))) void NormGeluRowsBf16(const uint16_t* x, const float* w,
                                                                                   const float* b, float eps, int64_t c,
                                                                                   int64_t r0, int64_t r1,
                                                                                   uint16_t* y) {
  NormGeluRows(x, w, b, eps, c, r0, r1, y);
}

// LibTorch's align_corners source index and lambdas (compute_source_index_and_lambda): src = o·(in − 1)/(out − 1)
// in fp32, i0 = ⌊src⌋, i1 = i0 + 1 unless i0 is the last, λ1 = src − i0, λ0 = 1 − λ1.
void SourceIndex(int64_t in, int64_t out, int64_t o, int64_t* i0, int64_t* i1, float* l0, float* l1) {
  const float ratio = out > 1 ? static_cast<float>(in - 1) / static_cast<float>(out - 1) : 0.0f;
  const float src = ratio * static_cast<float>(o);
  *i0 = std::min(static_cast<int64_t>(src), in - 1);
  *i1 = *i0 + (*i0 < in - 1 ? 1 : 0);
  *l1 = std::min(std::max(src - static_cast<float>(*i0), 0.0f), 1.0f);
  *l0 = 1.0f - *l1;
}

}  // namespace

torch::Tensor LayerNorm::GeluForProducts(const torch::Tensor& x, const PrecisionPolicy& p) const {
  const bool own = p.bf16 && x.device().is_cpu() && x.numel() > 0 &&
                   (x.scalar_type() == torch::kFloat32 || x.scalar_type() == torch::kBFloat16);
  if (!own) return torch::gelu(torch::layer_norm(x.to(torch::kFloat32), {x.size(-1)}, w, b, eps));
  const int64_t c = x.size(-1), rows = x.numel() / c;
  const torch::Tensor xc = x.contiguous();  // a channels-last map's [N, H, W, C] view: no copy
  const torch::Tensor wc = w.contiguous(), bc = b.contiguous();
  torch::Tensor y = torch::empty(x.sizes(), x.options().dtype(torch::kBFloat16));
  uint16_t* yp = reinterpret_cast<uint16_t*>(y.data_ptr());
  const bool bf16 = x.scalar_type() == torch::kBFloat16;
  at::parallel_for(0, rows, 256, [&](int64_t r0, int64_t r1) {
    if (bf16) {
      NormGeluRowsBf16(reinterpret_cast<const uint16_t*>(xc.data_ptr()), wc.data_ptr<float>(), bc.data_ptr<float>(),
                       static_cast<float>(eps), c, r0, r1, yp);
    } else {
      NormGeluRowsF32(xc.data_ptr<float>(), wc.data_ptr<float>(), bc.data_ptr<float>(), static_cast<float>(eps), c, r0,
                      r1, yp);
    }
  });
  return y;
}

torch::Tensor Upsample2xAlignCorners(const torch::Tensor& x) {
  const int64_t B = x.dim() == 4 ? x.size(0) : 0, C = x.dim() == 4 ? x.size(1) : 0;
  const bool own = x.dim() == 4 && x.device().is_cpu() && x.numel() > 0 &&
                   (x.scalar_type() == torch::kFloat32 || x.scalar_type() == torch::kBFloat16) &&
                   x.is_contiguous(torch::MemoryFormat::ChannelsLast);
  if (!own) return torch::upsample_bilinear2d(x, {2 * x.size(2), 2 * x.size(3)}, /*align_corners=*/true);
  // Channels-last (every activation of the DPT heads): rows of channels, each output pixel a weighted sum of four
  // input pixels' channel rows — whole vectors, where LibTorch's kernel ran at 2.4 GB/s on a bf16 map.
  const int64_t H = x.size(2), W = x.size(3), OH = 2 * H, OW = 2 * W;
  torch::Tensor y = torch::empty({B, C, OH, OW}, x.options().memory_format(torch::MemoryFormat::ChannelsLast));
  std::vector<int64_t> iw(static_cast<size_t>(2 * OW));
  std::vector<float> lw(static_cast<size_t>(2 * OW));
  for (int64_t o = 0; o < OW; ++o) SourceIndex(W, OW, o, &iw[2 * o], &iw[2 * o + 1], &lw[2 * o], &lw[2 * o + 1]);
  const bool bf16 = x.scalar_type() == torch::kBFloat16;
  const char* src = static_cast<const char*>(x.data_ptr());
  char* dst = static_cast<char*>(y.data_ptr());
  const int64_t elem = bf16 ? 2 : 4, in_row = W * C * elem, out_row = OW * C * elem;
  at::parallel_for(0, B * OH, 4, [&](int64_t r0, int64_t r1) {
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t b = r / OH, oh = r % OH;
      int64_t h0, h1;
      float l0, l1;
      SourceIndex(H, OH, oh, &h0, &h1, &l0, &l1);
      const char* x0 = src + (b * H + h0) * in_row;
      const char* x1 = src + (b * H + h1) * in_row;
      char* out = dst + r * out_row;
      if (bf16) {
        ResizeRowBf16(reinterpret_cast<const uint16_t*>(x0), reinterpret_cast<const uint16_t*>(x1), l0, l1, iw.data(),
                      lw.data(), OW, C, reinterpret_cast<uint16_t*>(out));
      } else {
        ResizeRowF32(reinterpret_cast<const float*>(x0), reinterpret_cast<const float*>(x1), l0, l1, iw.data(),
                     lw.data(), OW, C, reinterpret_cast<float*>(out));
      }
    }
  });
  return y;
}

}  // namespace freeloc::nn::internal
