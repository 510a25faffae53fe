#include "freeloc/nn/internal/fused_attention.h"

#include <ATen/Parallel.h>
#include <ATen/record_function.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <oneapi/dnnl/dnnl.hpp>
#include <vector>

#include "freeloc/core/env.h"
#include "freeloc/core/error.h"
#include "freeloc/nn/internal/fused_attention_kernel.h"

namespace freeloc::nn::internal {

namespace ak = attention_kernel;

namespace attention_kernel {
Layout LayoutFor(const Problem& p, bool bf16) {
  Layout L;
  L.key_blocks = (p.Nk + kKeyBlock - 1) / kKeyBlock;
  L.d_pad = bf16 ? (p.D + 1) / 2 * 2 : p.D;
  L.dv_pad = (p.Dv + 15) / 16 * 16;
  const int64_t per_word = bf16 ? 2 : 1;  // product operands per 4-byte word
  L.packed_k_words = L.key_blocks * kKeyBlock * L.d_pad / per_word;
  L.packed_v_words = L.key_blocks * kKeyBlock * L.dv_pad / per_word;
  L.scratch_words =
      kQueryBlock * L.d_pad + 2 * kQueryBlock * kKeyBlock + kQueryBlock * L.dv_pad + 17 * kQueryBlock + 2 * L.d_pad;
  if (p.rel_h)  // each row's rel_h and padded rel_w, and one key block's bias with a padded segment either side
    L.scratch_words += kQueryBlock * (p.key_h + p.key_w + 16) + 2 * (p.key_w + 16) + kKeyBlock + 16;
  return L;
}
}  // namespace attention_kernel

namespace {

const ak::Entry& EntryFor(AttentionIsa isa) {
  switch (isa) {
    case AttentionIsa::kAvx512Bf16: return ak::kAvx512Bf16;
    case AttentionIsa::kAvx512: return ak::kAvx512;
    case AttentionIsa::kAvx2: return ak::kAvx2;
    default: return ak::kGeneric;
  }
}

}  // namespace

bool UseFusedAttention(const torch::Device& device) {
  static const bool unfused = [] {
    const char* env = EnvSwitch("FREELOC_ATTENTION");
    return env && std::strcmp(env, "unfused") == 0;
  }();
  return device.is_cpu() && !unfused;
}

bool AttentionIsaAvailable(AttentionIsa isa) {
  const auto cpu = dnnl::get_effective_cpu_isa();
  switch (isa) {
    case AttentionIsa::kAuto:
    case AttentionIsa::kGeneric: return true;
    case AttentionIsa::kAvx2: return cpu >= dnnl::cpu_isa::avx2;
    case AttentionIsa::kAvx512:
      return cpu == dnnl::cpu_isa::avx512_core || cpu == dnnl::cpu_isa::avx512_core_vnni ||
             cpu == dnnl::cpu_isa::avx512_core_bf16 || cpu == dnnl::cpu_isa::avx512_core_amx;
    case AttentionIsa::kAvx512Bf16:
      return cpu == dnnl::cpu_isa::avx512_core_bf16 || cpu == dnnl::cpu_isa::avx512_core_amx;
  }
  return false;
}

const char* AttentionIsaName(AttentionIsa isa) { return isa == AttentionIsa::kAuto ? "auto" : EntryFor(isa).name; }

AttentionIsa AutoAttentionIsa(bool bf16) {
  static const AttentionIsa fp32 = AttentionIsaAvailable(AttentionIsa::kAvx512) ? AttentionIsa::kAvx512
                                   : AttentionIsaAvailable(AttentionIsa::kAvx2) ? AttentionIsa::kAvx2
                                                                                : AttentionIsa::kGeneric;
  static const bool has_bf16 = AttentionIsaAvailable(AttentionIsa::kAvx512Bf16);
  return bf16 && has_bf16 ? AttentionIsa::kAvx512Bf16 : fp32;
}

torch::Tensor FusedAttention(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v, double scale,
                             const AttentionExtras& x, bool bf16, AttentionIsa isa, bool bf16_out) {
  FREELOC_CHECK(q.dim() == 4 && k.dim() == 4 && v.dim() == 4, "fused attention: q, k, v must be [B, H, N, D]");
  FREELOC_CHECK(q.device().is_cpu() && k.device().is_cpu() && v.device().is_cpu(), "fused attention: CPU tensors only");
  const auto dtype = q.scalar_type();
  FREELOC_CHECK(
      (dtype == torch::kFloat32 || dtype == torch::kBFloat16) && k.scalar_type() == dtype && v.scalar_type() == dtype,
      "fused attention: q, k, v must all be fp32 or all bf16");
  ak::Problem p;
  p.B = q.size(0);
  p.H = q.size(1);
  p.Nq = q.size(2);
  p.D = q.size(3);
  p.Nk = k.size(2);
  p.Dv = v.size(3);
  FREELOC_CHECK(k.size(0) == p.B && v.size(0) == p.B && k.size(1) == p.H && v.size(1) == p.H && k.size(3) == p.D &&
                    v.size(2) == p.Nk,
                "fused attention: q " << q.sizes() << ", k " << k.sizes() << ", v " << v.sizes() << " do not agree");
  FREELOC_CHECK(p.D >= 1 && p.D <= 1024 && p.Dv >= 1 && p.Dv <= 1024,
                "fused attention: head dims " << p.D << ", " << p.Dv << " outside 1…1024");
  FREELOC_CHECK(q.stride(3) == 1 && k.stride(3) == 1 && v.stride(3) == 1,
                "fused attention: the last dim of q, k, v must be contiguous");
  torch::Tensor out = torch::empty({p.B, p.Nq, p.H, p.Dv}, bf16_out ? torch::kBFloat16 : torch::kFloat32);
  if (out.numel() == 0) return out;
  if (p.Nk == 0) return out.zero_();
  p.q = q.data_ptr();
  p.k = k.data_ptr();
  p.v = v.data_ptr();
  p.q_sb = q.stride(0), p.q_sh = q.stride(1), p.q_sn = q.stride(2);
  p.k_sb = k.stride(0), p.k_sh = k.stride(1), p.k_sn = k.stride(2);
  p.v_sb = v.stride(0), p.v_sh = v.stride(1), p.v_sn = v.stride(2);
  p.inputs_bf16 = dtype == torch::kBFloat16;
  p.scale = static_cast<float>(scale);
  torch::Tensor rope[4];
  auto table = [&](const torch::Tensor& t, int64_t n, int i) {
    FREELOC_CHECK(t.defined() && t.dim() == 2 && t.size(0) == n && t.size(1) == p.D,
                  "fused attention: a RoPE table must be [" << n << ", " << p.D << "]");
    rope[i] = t.to(torch::kCPU, torch::kFloat32).contiguous();
    return rope[i].data_ptr<float>();
  };
  if (x.rope_q) {
    FREELOC_CHECK(p.D % 4 == 0, "fused attention: RoPE needs a head dim divisible by 4, not " << p.D);
    p.rope_q_cos = table(x.rope_q->first, p.Nq, 0);
    p.rope_q_sin = table(x.rope_q->second, p.Nq, 1);
  }
  if (x.rope_k) {
    FREELOC_CHECK(p.D % 4 == 0, "fused attention: RoPE needs a head dim divisible by 4, not " << p.D);
    p.rope_k_cos = table(x.rope_k->first, p.Nk, 2);
    p.rope_k_sin = table(x.rope_k->second, p.Nk, 3);
  }
  torch::Tensor rel_h, rel_w, mask;
  if (x.rel_h.defined() || x.rel_w.defined()) {
    FREELOC_CHECK(x.rel_h.defined() && x.rel_w.defined() && x.rel_h.dim() == 3 && x.rel_w.dim() == 3,
                  "fused attention: relative-position terms come as rel_h and rel_w, each [B·H, Nq, n]");
    if (x.rel_by_offset) {
      FREELOC_CHECK(x.rel_key_w >= 1 && p.Nk % x.rel_key_w == 0 && p.Nq == p.Nk,
                    "fused attention: relative terms by offset need Nq = Nk on a grid "
                        << x.rel_key_w << " keys wide, not Nq = " << p.Nq << ", Nk = " << p.Nk);
      p.key_w = x.rel_key_w;
      p.key_h = p.Nk / p.key_w;
      p.rel_by_offset = true;
    } else {
      p.key_h = x.rel_h.size(2);
      p.key_w = x.rel_w.size(2);
    }
    const int64_t nh = p.rel_by_offset ? 2 * p.key_h - 1 : p.key_h, nw = p.rel_by_offset ? 2 * p.key_w - 1 : p.key_w;
    FREELOC_CHECK(x.rel_h.size(0) == p.B * p.H && x.rel_w.size(0) == p.B * p.H && x.rel_h.size(1) == p.Nq &&
                      x.rel_w.size(1) == p.Nq && x.rel_h.size(2) == nh && x.rel_w.size(2) == nw &&
                      p.key_h * p.key_w == p.Nk,
                  "fused attention: rel_h " << x.rel_h.sizes() << " and rel_w " << x.rel_w.sizes()
                                            << " do not fit B·H = " << p.B * p.H << ", Nq = " << p.Nq
                                            << ", Nk = " << p.Nk << (p.rel_by_offset ? " (by offset)" : ""));
    rel_h = x.rel_h.to(torch::kFloat32).contiguous();
    rel_w = x.rel_w.to(torch::kFloat32).contiguous();
    p.rel_h = rel_h.data_ptr<float>();
    p.rel_w = rel_w.data_ptr<float>();
  }
  if (x.mask.defined()) {
    FREELOC_CHECK(x.mask.dim() == 2 && x.mask.size(0) == p.Nq && x.mask.size(1) == p.Nk,
                  "fused attention: the mask must be [" << p.Nq << ", " << p.Nk << "], not " << x.mask.sizes());
    mask = x.mask.to(torch::kFloat32).contiguous();
    p.mask = mask.data_ptr<float>();
  }
  if (bf16_out) {
    p.out_bf16 = reinterpret_cast<uint16_t*>(out.data_ptr());
  } else {
    p.out = out.data_ptr<float>();
  }
  if (isa == AttentionIsa::kAuto) isa = AutoAttentionIsa(bf16);
  FREELOC_CHECK(AttentionIsaAvailable(isa),
                "fused attention: this CPU cannot run the " << AttentionIsaName(isa) << " kernel");
  const ak::Entry& entry = EntryFor(isa);
  const ak::Layout L = ak::LayoutFor(p, entry.bf16);

  // Visible to LibTorch's profiler and FLOP counters (bench/bench_torch.h) like the matmuls it replaces.
  RECORD_FUNCTION("freeloc::fused_attention", std::vector<c10::IValue>({q, k, v}));
  const int64_t BH = p.B * p.H, qblocks = (p.Nq + ak::kQueryBlock - 1) / ak::kQueryBlock;
  // Uninitialised: pack() zeroes what it packs into, run() writes its scratch before reading it. A tensor, so that
  // the packed K and V (megabytes, every call) come from LibTorch's allocator — the tensor pool during a network pass,
  // which hands back the previous call's block already mapped — rather than pages faulted in anew each call.
  const torch::Tensor kv_buffer = torch::empty({BH * (L.packed_k_words + L.packed_v_words)}, torch::kFloat32);
  float* const kv = kv_buffer.data_ptr<float>();
  at::parallel_for(0, BH, 1, [&](int64_t b0, int64_t b1) { entry.pack(p, L, b0, b1, kv); });
  at::parallel_for(0, BH * qblocks, 1, [&](int64_t i0, int64_t i1) {
    const std::unique_ptr<float[]> scratch(new float[static_cast<size_t>(L.scratch_words)]);
    entry.run(p, L, kv, i0, i1, scratch.get());
  });
  return out;
}

}  // namespace freeloc::nn::internal
