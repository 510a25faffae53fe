#include "freeloc/nn/internal/bf16_linear.h"

#include <ATen/record_function.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <oneapi/dnnl/dnnl.hpp>
#include <vector>

#include "freeloc/core/env.h"
#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"

namespace freeloc::nn::internal {

namespace {

using dt = dnnl::memory::data_type;
using tag = dnnl::memory::format_tag;

dnnl::engine& Engine() {
  static dnnl::engine e(dnnl::engine::kind::cpu, 0);
  return e;
}

}  // namespace

struct PackedLinearBf16::Impl {
  int64_t out = 0, in = 0;
  torch::Tensor w;      // fp32 [out, in] until the first packing; another layout is reordered from a packed one
  torch::Tensor shape;  // [out, in] without storage (an expanded scalar): the profiler's and FLOP counter's input
  torch::Tensor bias;   // fp32 [1, out] or undefined
  struct Kernel {
    dnnl::matmul prim;
    dnnl::matmul::primitive_desc pd;
    std::shared_ptr<dnnl::memory> weights;  // packed bf16 in pd.weights_desc()
  };
  mutable std::mutex mu;
  // By (rows, GELU + 2·bf16 output).
  mutable std::map<std::pair<int64_t, int>, std::shared_ptr<const Kernel>> kernels;
  mutable std::vector<std::shared_ptr<dnnl::memory>> packed;  // distinct packed layouts

  std::shared_ptr<const Kernel> For(int64_t rows, bool gelu, bool bf16_out) const {
    std::lock_guard<std::mutex> lock(mu);
    auto& k = kernels[{rows, (gelu ? 1 : 0) + (bf16_out ? 2 : 0)}];
    if (k) return k;
    const dnnl::memory::desc src({rows, in}, dt::bf16, tag::ab);
    const dnnl::memory::desc wei({in, out}, dt::bf16, tag::any);
    const dnnl::memory::desc dst({rows, out}, bf16_out ? dt::bf16 : dt::f32, tag::ab);
    dnnl::primitive_attr attr;
    if (gelu) {
      dnnl::post_ops ops;
      ops.append_eltwise(1.f, dnnl::algorithm::eltwise_gelu_erf, 0.f, 0.f);
      attr.set_post_ops(ops);
    }
    auto kernel = std::make_shared<Kernel>();
    if (bias.defined()) {
      const dnnl::memory::desc bmd({1, out}, dt::f32, tag::ab);
      kernel->pd = dnnl::matmul::primitive_desc(dnnl::matmul::desc(src, wei, bmd, dst), attr, Engine());
    } else {
      kernel->pd = dnnl::matmul::primitive_desc(dnnl::matmul::desc(src, wei, dst), attr, Engine());
    }
    kernel->prim = dnnl::matmul(kernel->pd);
    for (const auto& m : packed)
      if (m->get_desc() == kernel->pd.weights_desc()) kernel->weights = m;
    if (!kernel->weights) {
      // The first layout from fp32 [out, in] (= {in, out} in layout ba), every other one from the first packed copy
      // (a bf16 → bf16 reorder is exact): the fp32 weights are not kept.
      dnnl::stream s(Engine());
      auto m = std::make_shared<dnnl::memory>(kernel->pd.weights_desc(), Engine());
      if (packed.empty()) {
        dnnl::memory src_w({{in, out}, dt::f32, tag::ba}, Engine(), w.data_ptr());
        dnnl::reorder(src_w, *m).execute(s, src_w, *m);
      } else {
        dnnl::reorder(*packed.front(), *m).execute(s, *packed.front(), *m);
      }
      s.wait();
      packed.push_back(m);
      kernel->weights = m;
    }
    k = kernel;
    return k;
  }
};

PackedLinearBf16::PackedLinearBf16(const torch::Tensor& w, const torch::Tensor& b) : impl_(std::make_unique<Impl>()) {
  FREELOC_CHECK(w.dim() == 2 && w.device().is_cpu(), "bf16 linear: weights must be a 2-D CPU tensor");
  impl_->out = w.size(0);
  impl_->in = w.size(1);
  impl_->w = w.to(torch::kFloat32).contiguous();
  if (b.defined()) impl_->bias = b.to(torch::kFloat32).reshape({1, impl_->out}).contiguous();
  // Pack now, at model load: the kernels for other row counts mostly share this layout, so a query never pays the
  // reorder of a layer's weights. Then the fp32 copy goes: a bf16 model holds its weights once.
  impl_->For(256, false, false);
  impl_->w = torch::Tensor();
  impl_->shape = torch::zeros({1, 1}, torch::kBFloat16).expand({impl_->out, impl_->in});
}

PackedLinearBf16::~PackedLinearBf16() = default;

torch::Tensor PackedLinearBf16::Forward(const torch::Tensor& x, bool gelu, bool bf16_out) const {
  const Impl& m = *impl_;
  const int64_t rows = x.numel() / m.in;
  const torch::Tensor xb = x.to(torch::kBFloat16).reshape({rows, m.in}).contiguous();
  torch::Tensor y = torch::empty({rows, m.out}, bf16_out ? torch::kBFloat16 : torch::kFloat32);
  if (rows > 0) {
    // Visible to LibTorch's profiler and FLOP counters (bench/bench_torch.h), like the aten matmuls it replaces.
    RECORD_FUNCTION("freeloc::bf16_linear", std::vector<c10::IValue>({xb, m.shape}));
    const auto k = m.For(rows, gelu, bf16_out);
    dnnl::stream s(Engine());
    dnnl::memory src({{rows, m.in}, dt::bf16, tag::ab}, Engine(), xb.data_ptr());
    dnnl::memory dst({{rows, m.out}, bf16_out ? dt::bf16 : dt::f32, tag::ab}, Engine(), y.data_ptr());
    std::unordered_map<int, dnnl::memory> args = {
        {DNNL_ARG_SRC, src}, {DNNL_ARG_WEIGHTS, *k->weights}, {DNNL_ARG_DST, dst}};
    if (m.bias.defined())
      args.emplace(DNNL_ARG_BIAS, dnnl::memory({{1, m.out}, dt::f32, tag::ab}, Engine(), m.bias.data_ptr()));
    k->prim.execute(s, args);
    s.wait();
  }
  std::vector<int64_t> shape = x.sizes().vec();
  shape.back() = m.out;
  return y.reshape(shape);
}

std::string PackedLinearBf16::Kernel(int64_t rows) const { return impl_->For(rows, false, false)->pd.impl_info_str(); }

int PackedLinearBf16::PackedCopies() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return static_cast<int>(impl_->packed.size());
}

size_t PackedLinearBf16::PackedBytes() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  size_t n = 0;
  for (const auto& m : impl_->packed) n += m->get_desc().get_size();
  return n;
}

bool RunBf16(const RuntimeOptions& rt) {
  if (rt.precision != Precision::kBf16) return false;
  return rt.device == Device::kCuda || CpuBf16Decision().use;
}

bool ChooseBf16(bool native, double fp32_seconds, double bf16_seconds, bool force) {
  if (force) return true;
  return native && bf16_seconds > 0 && fp32_seconds > 0 && bf16_seconds < 0.9 * fp32_seconds;
}

const Bf16Decision& CpuBf16Decision() {
  static const Bf16Decision d = [] {
    Bf16Decision r;
    const auto isa = dnnl::get_effective_cpu_isa();
    r.native = isa == dnnl::cpu_isa::avx512_core_bf16 || isa == dnnl::cpu_isa::avx512_core_amx;
    const char* env = EnvSwitch("FREELOC_BF16");
    const bool force = env && std::strcmp(env, "force") == 0;
    torch::InferenceMode guard;
    const int64_t M = 768, K = 1024, N = 1024;
    const torch::Tensor x = torch::randn({M, K}), w = torch::randn({N, K}) * 0.03, b = torch::zeros({N});
    const PackedLinearBf16 lin(w, b);
    r.kernel = lin.Kernel(M);
    if (!force) {
      const auto best = [](const auto& f) {
        f();  // warm-up (packing, thread pool)
        double t = 1e30;
        for (int i = 0; i < 3; ++i) {
          const auto t0 = std::chrono::steady_clock::now();
          f();
          t = std::min(t, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        }
        return t;
      };
      const double t32 = best([&] { (void)torch::linear(x, w, b); });
      const double t16 = best([&] { (void)lin(x); });
      r.fp32_gflops = 2.0 * M * K * N / t32 / 1e9;
      r.bf16_gflops = 2.0 * M * K * N / t16 / 1e9;
      r.use = ChooseBf16(r.native, t32, t16, false);
    } else {
      r.use = true;
    }
    char buf[400];
    if (force)
      std::snprintf(buf, sizeof(buf), "bf16: forced by FREELOC_BF16=force (oneDNN %s, prepacked weights)",
                    r.kernel.c_str());
    else if (r.use)
      std::snprintf(buf, sizeof(buf),
                    "bf16: oneDNN %s with prepacked weights, %.0f GFLOP/s against %.0f in fp32 on this CPU",
                    r.kernel.c_str(), r.bf16_gflops, r.fp32_gflops);
    else if (!r.native)
      std::snprintf(buf, sizeof(buf),
                    "bf16 requested, but this CPU has no native bf16 arithmetic (AVX512-BF16 or AMX; oneDNN would "
                    "emulate it, %.0f GFLOP/s against %.0f in fp32): running fp32",
                    r.bf16_gflops, r.fp32_gflops);
    else
      std::snprintf(buf, sizeof(buf),
                    "bf16 requested, but it measures slower than fp32 on this CPU (%.0f against %.0f GFLOP/s, oneDNN "
                    "%s): running fp32",
                    r.bf16_gflops, r.fp32_gflops, r.kernel.c_str());
    r.reason = buf;
    if (r.use)
      FREELOC_LOG(INFO) << r.reason;
    else
      FREELOC_LOG(WARNING) << r.reason;
    return r;
  }();
  return d;
}

}  // namespace freeloc::nn::internal
