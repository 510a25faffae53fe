// The fused attention kernel's torch-free interface (nn/internal). One problem description, one entry per instruction
// set; each entry is fused_attention_kernel.inc compiled with that set's flags in its own translation unit, so no
// LibTorch or standard-library inline code is ever built with wider instructions than the caller's CPU has.
// fused_attention.cc picks the entry at run time and owns threads and buffers.
#pragma once

#include <cstdint>

namespace freeloc::nn::internal::attention_kernel {

// softmax(scale·q·kᵀ + bias)·v for every (batch, head), with the logits of one block of query rows against one block
// of keys at a time (online softmax: running max and sum per row, the output rescaled when the max grows).
struct Problem {
  int64_t B = 1, H = 1, Nq = 0, Nk = 0, D = 0, Dv = 0;
  // q [B,H,Nq,D], k [B,H,Nk,D], v [B,H,Nk,Dv]: element strides for (batch, head, token); the last dim is contiguous.
  const void *q = nullptr, *k = nullptr, *v = nullptr;
  int64_t q_sb = 0, q_sh = 0, q_sn = 0, k_sb = 0, k_sh = 0, k_sn = 0, v_sb = 0, v_sh = 0, v_sn = 0;
  bool inputs_bf16 = false;  // q, k, v hold bf16 (uint16) instead of fp32
  float scale = 1;
  // RoPE2D in the pass (croco's rotate-half pairing with the sign folded into SIN): t'[d] = t[d]·cos[n][d] +
  // t[swap(d)]·sin[n][d], swap exchanging the two quarters of each half. [Nq or Nk][D] fp32, or null. D % 4 == 0.
  const float *rope_q_cos = nullptr, *rope_q_sin = nullptr, *rope_k_cos = nullptr, *rope_k_sin = nullptr;
  // Decomposed relative position (vitdet): logit[i][j] += rel_h[bh][i][j / key_w] + rel_w[bh][i][j % key_w], with
  // key_h·key_w = Nk; [B·H][Nq][key_h] and [B·H][Nq][key_w] fp32, or null.
  const float *rel_h = nullptr, *rel_w = nullptr;
  int64_t key_h = 0, key_w = 0;
  // The same terms given by relative offset (queries on the keys' key_h × key_w grid, as in self-attention): rel_h
  // [B·H][Nq][2·key_h − 1] and rel_w [B·H][Nq][2·key_w − 1], the term of query i = (hq, wq) for key row hk being
  // rel_h[bh][i][hq − hk + key_h − 1] (vitdet's get_rel_pos index for equal sizes), likewise for wk.
  bool rel_by_offset = false;
  // Additive mask shared by every head, [Nq][Nk] fp32 (−inf removes a pair), or null. A row with every key removed
  // gives zeros.
  const float* mask = nullptr;
  float* out = nullptr;  // [B][Nq][H][Dv] fp32: the output projection's input without a transpose
  // Instead of `out`: the same values rounded to bf16 (nearest even), for a bf16 output projection.
  uint16_t* out_bf16 = nullptr;
};

// The blocking every entry uses; the buffers below are sized from it.
constexpr int64_t kQueryBlock = 64;  // query rows per work item
constexpr int64_t kKeyBlock = 128;   // keys per step of the online softmax

// Sizes (in 4-byte words) of the packed K and V of one (batch, head) and of one thread's scratch.
struct Layout {
  int64_t key_blocks = 0, d_pad = 0, dv_pad = 0;
  int64_t packed_k_words = 0, packed_v_words = 0, scratch_words = 0;
};
Layout LayoutFor(const Problem& p, bool bf16);

// One instruction set's kernels: pack K and V of heads [bh0, bh1) into `kv` (per head packed_k_words + packed_v_words
// words), then run work items [i0, i1) (item = bh · query_blocks + block) with `scratch`.
struct Entry {
  const char* name;  // "avx512-bf16", "avx512", "avx2", "generic"
  bool bf16;         // bf16 products with fp32 accumulation (else fp32 throughout)
  void (*pack)(const Problem&, const Layout&, int64_t bh0, int64_t bh1, float* kv);
  void (*run)(const Problem&, const Layout&, const float* kv, int64_t i0, int64_t i1, float* scratch);
};

extern const Entry kAvx512Bf16, kAvx512, kAvx2, kGeneric;

}  // namespace freeloc::nn::internal::attention_kernel
