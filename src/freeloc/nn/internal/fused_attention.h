// Fused attention for every ViT in freeloc (DUSt3R/MASt3R encoder, decoder and cross-attention, SegGPT, Metric3D's
// DINOv2) on the CPU: softmax(scale·q·kᵀ + bias)·v computed one block of query rows against one block of keys at a time
// with an online softmax, so no tokens × tokens matrix is ever materialised; RoPE, the decomposed relative-position
// terms or a mask applied in the same pass. bf16 products with fp32 accumulation where the CPU has AVX512-BF16, fp32
// otherwise (AVX512, AVX2 or generic code). The kernels themselves are in fused_attention_kernel.inc; this file owns
// the checks, the threads and the buffers. nn/ .cc files only.
#pragma once

#include <torch/torch.h>

#include <utility>

namespace freeloc::nn::internal {

// Additive terms and position encodings applied inside the pass.
struct AttentionExtras {
  // RoPE2D tables (Rope2D::Tables: COS and signed SIN, each [N, D]) for q and for k, or null.
  const std::pair<torch::Tensor, torch::Tensor>* rope_q = nullptr;
  const std::pair<torch::Tensor, torch::Tensor>* rope_k = nullptr;
  // vitdet decomposed relative position: logit[i][j] += rel_h[bh][i][j / key_w] + rel_w[bh][i][j % key_w];
  // [B·H, Nq, key_h] and [B·H, Nq, key_w] fp32 with key_h·key_w = Nk. Undefined: none.
  // With rel_by_offset (self-attention on one key_h × key_w grid, Nq = Nk): [B·H, Nq, 2·key_h − 1] and
  // [B·H, Nq, 2·key_w − 1] by relative offset, the term of query (hq, wq) for key row hk at hq − hk + key_h − 1 —
  // q times the relative table once (one GEMM), where the per-pair form needs the table gathered per query row.
  // key_w is then given (key_h = Nk / key_w).
  torch::Tensor rel_h, rel_w;
  bool rel_by_offset = false;
  int64_t rel_key_w = 0;
  // Additive mask [Nq, Nk] fp32 shared by every head (−inf removes a pair). Undefined: none.
  torch::Tensor mask;
};

// Which kernel runs. kAuto: avx512-bf16 for bf16 where the CPU has it, else the widest fp32 kernel it has (oneDNN's
// view of the CPU, so DNNL_MAX_CPU_ISA=AVX512_CORE forces a CPU without bf16).
enum class AttentionIsa { kAuto, kAvx512Bf16, kAvx512, kAvx2, kGeneric };

// Whether the networks run FusedAttention for tensors on `device`: on the CPU, unless FREELOC_ATTENTION=unfused (read
// once; for before/after measurements: the LibTorch-op attention of earlier releases).
bool UseFusedAttention(const torch::Device& device);

// Whether `isa` can run on this CPU, and its name ("avx512-bf16", …).
bool AttentionIsaAvailable(AttentionIsa isa);
const char* AttentionIsaName(AttentionIsa isa);
// The kernel kAuto picks for bf16 or fp32 products.
AttentionIsa AutoAttentionIsa(bool bf16);

// q [B,H,Nq,D], k [B,H,Nk,D], v [B,H,Nk,Dv]: CPU, fp32 or bf16 (all three alike), any strides with a contiguous last
// dim (views into a fused qkv projection need no copy). Returns [B, Nq, H, Dv] fp32 — the output projection's input —
// or with `bf16_out` the same values rounded to bf16 (for a bf16 projection: its own conversion, one pass less).
// D, Dv ≤ 1024; with RoPE D % 4 == 0. Throws freeloc::Error on shapes it cannot take.
torch::Tensor FusedAttention(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v, double scale,
                             const AttentionExtras& extras, bool bf16, AttentionIsa isa = AttentionIsa::kAuto,
                             bool bf16_out = false);

}  // namespace freeloc::nn::internal
