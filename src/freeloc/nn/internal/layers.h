// ViT building blocks shared by DUSt3R, SegGPT and Metric3D (nn/ .cc files only). Each block names the upstream
// function it reproduces. `PrecisionPolicy` implements the autocast-style policy: matmuls and convolutions in bf16 when
// asked, norms, softmax and everything else in fp32.
#pragma once

#include <torch/torch.h>

#include <map>
#include <string>
#include <tuple>

#include "freeloc/nn/internal/bf16_linear.h"
#include "freeloc/nn/internal/fused_attention.h"
#include "freeloc/nn/internal/torch_util.h"

namespace freeloc::nn::internal {

struct PrecisionPolicy {
  bool bf16 = false;
};

// torch.nn.Linear.
struct Linear {
  // w, b: fp32 (w dropped once packed or converted: a bf16 model holds its weights once); *_lp: bf16 on CUDA.
  torch::Tensor w, b, w_lp, b_lp;
  std::shared_ptr<PackedLinearBf16> packed;  // bf16 on the CPU: oneDNN with prepacked weights
  void Load(WeightStore& ws, const std::string& prefix, int64_t out, int64_t in, bool bias, const PrecisionPolicy& p);
  torch::Tensor operator()(const torch::Tensor& x, const PrecisionPolicy& p) const;
  // For an output that only feeds bf16 products (attention's q/k/v): in bf16 when the layer runs prepacked bf16 (half
  // the bytes, the rounding those products apply anyway), else as operator().
  torch::Tensor ForProducts(const torch::Tensor& x, const PrecisionPolicy& p) const;
  // GELU_erf(this(x)): in bf16 from the prepacked layer's fused epilogue (bf16 output, which a following bf16 layer
  // reads as is), else GELU of operator().
  torch::Tensor Gelu(const torch::Tensor& x, const PrecisionPolicy& p) const;
  // Whether this layer reads a bf16 input as is (prepacked bf16): a producer may then write bf16 for it.
  bool TakesBf16(const PrecisionPolicy& p) const { return p.bf16 && packed != nullptr; }
};

// torch.nn.LayerNorm over the last dimension (biased variance).
struct LayerNorm {
  torch::Tensor w, b;
  double eps = 1e-6;
  void Load(WeightStore& ws, const std::string& prefix, int64_t dim, double eps);
  torch::Tensor operator()(const torch::Tensor& x) const;
  // For an output that only feeds bf16 products (the next layer runs prepacked bf16: p.bf16 on the CPU): the norm
  // written in bf16 by one pass over x (fp32 statistics, round to nearest even — what the layer's own conversion
  // would do), instead of an fp32 norm and a conversion; else operator().
  torch::Tensor ForProducts(const torch::Tensor& x, const PrecisionPolicy& p) const;
  // The residual step and the next norm in one pass: *x = *x + delta (a new tensor; the old one is left alone), and
  // returns ForProducts(*x).
  torch::Tensor AddForProducts(torch::Tensor* x, const torch::Tensor& delta, const PrecisionPolicy& p) const;
  // GELU_erf(norm(x)) for an output that only feeds bf16 products: with p.bf16 on the CPU one pass over x (fp32 or
  // bf16; fp32 statistics, erf to 1.5e-7 by Abramowitz & Stegun 7.1.26, one rounding to bf16) — else
  // torch::gelu(operator()(x)). SegGPT's decoder tail: LibTorch 1.13's fp32 gelu alone took 52 ms on its 64 × 896 × 448
  // map.
  torch::Tensor GeluForProducts(const torch::Tensor& x, const PrecisionPolicy& p) const;
};

// croco/models/blocks.py Mlp: fc2(GELU_erf(fc1(x))).
struct Mlp {
  Linear fc1, fc2;
  void Load(WeightStore& ws, const std::string& prefix, int64_t dim, int64_t hidden, const PrecisionPolicy& p);
  torch::Tensor operator()(const torch::Tensor& x, const PrecisionPolicy& p) const;
};

// croco/models/pos_embed.py RoPE2D (and its CUDA kernel curope): the first half of each head rotated by the y
// position, the second half by x, rotate_half pairing (i, i + D/2), inv_freq = 1/base^(2i/D) in float32. Applied
// as t·COS + swap(t)·SIN with the sign folded into SIN — no cat/neg chains.
class Rope2D {
 public:
  explicit Rope2D(double base = 100.0) : base_(base) {}
  // Tables for a row-major grid of h×w tokens (pos = (y, x)), head dim `dh`: COS and signed SIN, each [N, dh].
  std::pair<torch::Tensor, torch::Tensor> Tables(int64_t h, int64_t w, int64_t dh, torch::Device device) const;
  // t: [B, heads, N, dh].
  static torch::Tensor Apply(const torch::Tensor& t, const std::pair<torch::Tensor, torch::Tensor>& tables);

 private:
  double base_;
  mutable std::map<std::tuple<int64_t, int64_t, int64_t, int>, std::pair<torch::Tensor, torch::Tensor>> cache_;
};

// softmax(q·kᵀ·scale)·v for [B, heads, N, dh] tensors in LibTorch ops: the attention off the CPU (on the CPU every
// ViT runs FusedAttention) and the row-blocked comparison in bench/attention.
torch::Tensor ScaledDotProduct(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v, double scale,
                               const PrecisionPolicy& p, int64_t block_rows = 128);
// softmax(q·kᵀ·scale)·v in three whole-tensor ops (the upstream formulation): the reference for bench/attention.
torch::Tensor ScaledDotProductReference(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v,
                                        double scale);

// croco/models/blocks.py Attention (self-attention with RoPE; FusedAttention on the CPU).
struct SelfAttention {
  Linear qkv, proj;
  int64_t heads = 1;
  void Load(WeightStore& ws, const std::string& prefix, int64_t dim, int64_t heads, const PrecisionPolicy& p);
  torch::Tensor operator()(const torch::Tensor& x, const std::pair<torch::Tensor, torch::Tensor>& rope,
                           const PrecisionPolicy& p) const;
};

// croco/models/blocks.py CrossAttention (projq/projk/projv, RoPE on q and k with their own positions).
struct CrossAttention {
  Linear q, k, v, proj;
  int64_t heads = 1;
  void Load(WeightStore& ws, const std::string& prefix, int64_t dim, int64_t heads, const PrecisionPolicy& p);
  torch::Tensor operator()(const torch::Tensor& x, const torch::Tensor& y,
                           const std::pair<torch::Tensor, torch::Tensor>& rope_x,
                           const std::pair<torch::Tensor, torch::Tensor>& rope_y, const PrecisionPolicy& p) const;
};

// torch.nn.Conv2d / ConvTranspose2d with bf16 policy.
struct Conv {
  torch::Tensor w, b, w_lp, b_lp;  // fp32, or bf16 (*_lp) alone when the policy runs it in bf16
  int64_t stride = 1, padding = 0;
  bool transpose = false;
  void Load(WeightStore& ws, const std::string& prefix, const std::vector<int64_t>& shape, bool bias, int64_t stride,
            int64_t padding, bool transpose, const PrecisionPolicy& p);
  torch::Tensor operator()(const torch::Tensor& x, const PrecisionPolicy& p) const;
  // One link of a chain of convolutions that stays in bf16: with bf16 weights the input is taken to bf16
  // channels-last (a no-op when the previous link made it) and the output stays so — oneDNN's bf16 kernels run at
  // 2.5× the fp32 rate on channels-last activations, and the chain converts once in and once out. With fp32 weights
  // (fp32 policy, transposed convolutions) it is operator() on an fp32 input.
  torch::Tensor Chain(const torch::Tensor& x) const;
  // For a convolution that runs only through Chain: its bf16 weights are kept channels-last, the layout oneDNN's
  // channels-last kernels read. LibTorch 1.13 otherwise copies them into it at every call, inside the convolution's
  // time and slowly: 17 ms of a MASt3R query; in a Metric3D ViT-L pass (its GRU, DPT and head convolutions) the
  // convolutions at 300–316 GFLOP/s instead of ≈ 450 — 17.4 → 15.2 s for the pass in LibTorch's profiler.
  // Not for one that operator() runs on NCHW inputs: channels-last weights take LibTorch's input into that layout.
  void ForChains();
};

// A chain's activation back in fp32, contiguous (NCHW): the one conversion out.
torch::Tensor ChainOut(const torch::Tensor& x);

// The 1×1 convolution that ends a bf16 chain with fp32 output and fp32-exact weights (the DPT head's last layer:
// its raw output feeds exp()). In bf16 on the CPU it reads the chain's bf16 channels-last activation as rows of
// channels — a prepacked bf16 matmul whose weights are each split into two bf16 parts (hi + lo: 16 significant bits,
// 2⁻¹⁷ relative, against 2⁻⁹ for plain bf16) and summed in fp32 — instead of converting the whole activation to an
// fp32 copy (100 MB at 128 × 384 × 512) for an fp32 convolution. Otherwise the fp32 convolution. Output: fp32 NCHW,
// contiguous.
struct PointwiseOut {
  Conv conv;                                 // fp32 weights (not bf16, or not on the CPU)
  std::shared_ptr<PackedLinearBf16> packed;  // [hi; lo] rows, bias on the hi rows
  int64_t out = 0;
  void Load(WeightStore& ws, const std::string& prefix, int64_t out, int64_t in, bool bias, const PrecisionPolicy& p);
  torch::Tensor operator()(const torch::Tensor& x) const;
};

// F.interpolate(x, scale_factor=2, mode='bilinear', align_corners=True).
torch::Tensor Upsample2xAlignCorners(const torch::Tensor& x);

}  // namespace freeloc::nn::internal
