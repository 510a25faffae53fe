// Metric3D v2 forward pass. Blocks cite the upstream code they reproduce (YvanYin/Metric3D eb5b6fa:
// mono/model/backbones/ViT_DINO_reg.py, mono/model/decode_heads/RAFTDepthNormalDPTDecoder5.py, hubconf.py).
#include "freeloc/nn/metric3d.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/io/checkpoint.h"
#include "freeloc/nn/internal/layers.h"
#include "freeloc/nn/internal/torch_util.h"

namespace freeloc::nn {

using namespace internal;  // NOLINT

std::string Metric3dConfig::Summary() const {
  std::ostringstream os;
  os << "Metric3D " << variant << ": ViT " << depth << "×" << embed_dim << " (" << heads << " heads, "
     << (swiglu ? "SwiGLU " : "MLP ") << ffn_hidden << "), "
     << (multi_output ? "intermediate features" : "final norm ×4") << ", GRU hidden " << hidden << " × " << iters
     << " iterations, input " << input_h << "×" << input_w;
  return os.str();
}

namespace {

// LayerNorm over the channels of an NCHW tensor (RAFT LayerNorm2d).
torch::Tensor Ln2d(const torch::Tensor& x, const torch::Tensor& w, const torch::Tensor& b, double eps) {
  return torch::layer_norm(x.permute({0, 2, 3, 1}), {x.size(1)}, w, b, eps).permute({0, 3, 1, 2});
}

// ViT_DINO_reg.Block: x + ls1·attn(norm1 x), x + ls2·ffn(norm2 x).
struct VitBlock {
  LayerNorm n1, n2;
  Linear qkv, proj, fc1, fc2;  // fc1/fc2 = w12/w3 for SwiGLU
  torch::Tensor ls1, ls2;
  bool swiglu = false;
  int64_t heads = 1;
  torch::Tensor operator()(torch::Tensor x, const PrecisionPolicy& p) const {
    const int64_t B = x.size(0), T = x.size(1), C = x.size(2), hd = C / heads;
    const bool fused = UseFusedAttention(x.device());
    const torch::Tensor t = (fused ? qkv.ForProducts(n1.ForProducts(x, p), p) : qkv(n1(x), p))
                                .reshape({B, T, 3, heads, hd})
                                .permute({2, 0, 3, 1, 4});
    const double scale = std::pow(static_cast<double>(hd), -0.5);
    const torch::Tensor a =
        fused ? FusedAttention(t[0], t[1], t[2], scale, {}, p.bf16, AttentionIsa::kAuto, proj.TakesBf16(p))
                    .view({B, T, C})
              : ScaledDotProduct(t[0], t[1], t[2], scale, p).transpose(1, 2).reshape({B, T, C});
    x = torch::addcmul(x, ls1, proj(a, p));  // x + ls1·proj(a): one pass, the same roundings
    torch::Tensor h;
    if (swiglu) {
      const auto ch = fc1(n2.ForProducts(x, p), p).chunk(2, -1);
      h = torch::silu(ch[0]) * ch[1];
    } else {
      h = fc1.Gelu(n2.ForProducts(x, p), p);  // bf16: GELU in the GEMM's epilogue, the hidden activations stay bf16
    }
    return torch::addcmul(x, ls2, fc2(h, p));
  }
};

// Readout (project_patch on the patch tokens + project_learn on [cls, r1..r4], GELU), then the resampler.
struct Readout {
  Linear patch, learn;
  Conv sample;   // read_1: ConvTranspose 2/2; read_0: 1×1 after nearest ×3.5; none for read_2/3
  int kind = 0;  // 0: identity, 1: convT ×2, 2: nearest ×3.5 + conv1×1
};

// DPT ConvBlock with the in-place ReLU of the input: relu(x) + conv2(relu(conv1(relu(x)))).
struct ConvBlock {
  Conv c1, c2;
  torch::Tensor operator()(const torch::Tensor& x, const PrecisionPolicy& p) const {
    (void)p;  // the weights carry the policy (Conv::Chain); in bf16 the sum promotes c2's output to fp32
    const torch::Tensor r = torch::relu(x);
    return r + c2.Chain(torch::relu(c1.Chain(r)));
  }
};

struct FuseBlock {
  ConvBlock trunk, branch;
  bool has_branch = false;
  double scale = 0;  // 0: no upsampling
  Conv out;
  torch::Tensor operator()(torch::Tensor x, const torch::Tensor* skip, const PrecisionPolicy& p) const {
    if (skip) x = x + branch(*skip, p);
    x = trunk(x, p);
    if (scale > 0) {
      x = torch::upsample_bilinear2d(
          x, {static_cast<int64_t>(std::floor(x.size(2) * scale)), static_cast<int64_t>(std::floor(x.size(3) * scale))},
          true);
    }
    return out(x, p);
  }
};

// RAFT ResidualBlock(norm_fn='layer') followed by a 3×3 conv: one head of the context feature encoder.
struct ContextHead {
  Conv c1, c2, down, post;
  torch::Tensor n1w, n1b, n2w, n2b, ndw, ndb;
  bool has_down = false;
  torch::Tensor operator()(const torch::Tensor& x, const PrecisionPolicy& p) const {
    constexpr double eps = 1e-5;
    torch::Tensor y = torch::relu(Ln2d(c1(x, p), n1w, n1b, eps));
    y = torch::relu(Ln2d(c2(y, p), n2w, n2b, eps));
    const torch::Tensor sc = has_down ? Ln2d(down(x, p), ndw, ndb, eps) : x;
    return post(torch::relu(sc + y), p);
  }
};

struct ConvGru {
  Conv z, r, q;
  torch::Tensor operator()(const torch::Tensor& h, const std::vector<torch::Tensor>& cx,
                           const std::vector<torch::Tensor>& xs, const PrecisionPolicy& p) const {
    (void)p;  // the weights carry the policy (Conv::Chain)
    // [h, x…] is written once, channels-last in the convolutions' type (bf16 in bf16: one conversion per value, no
    // fp32 concatenation first); z and r read it, then its h channels are overwritten by r·h for q — the x channels
    // are the same in both inputs. The values are those of cat + conversion.
    const bool lp = z.w_lp.defined();
    const int64_t ch = h.size(1);
    int64_t channels = ch;
    for (const auto& x : xs) channels += x.size(1);
    const torch::Tensor hx = torch::empty(
        {h.size(0), channels, h.size(2), h.size(3)},
        h.options().dtype(lp ? torch::kBFloat16 : torch::kFloat32).memory_format(torch::MemoryFormat::ChannelsLast));
    hx.narrow(1, 0, ch).copy_(h);
    int64_t at = ch;
    for (const auto& x : xs) {
      hx.narrow(1, at, x.size(1)).copy_(x);
      at += x.size(1);
    }
    // In bf16 the convolutions' bf16 outputs go into the fp32 sums as they are (type promotion): the values
    // Conv::operator() gives, without an fp32 copy of each output.
    const torch::Tensor zz = torch::add(z.Chain(hx), cx[0]).sigmoid_();
    const torch::Tensor rr = torch::add(r.Chain(hx), cx[1]).sigmoid_();
    hx.narrow(1, 0, ch).copy_(rr * h);
    const torch::Tensor qq = torch::add(q.Chain(hx), cx[2]).tanh_();
    // (1 − z)·h + z·q as h + z·(q − h): two passes over the state instead of four (a rounding apart).
    return torch::addcmul(h, zz, qq - h);
  }
};

torch::Tensor Pool2x(const torch::Tensor& x) { return torch::avg_pool2d(x, 3, 2, 1, false, true); }
torch::Tensor Interp(const torch::Tensor& x, const torch::Tensor& like) {
  return torch::upsample_bilinear2d(x, {like.size(2), like.size(3)}, true);
}
// relu(x − min) + min, then max − relu(max − y): the upstream clamp (low values become 200 − fl(199.9)).
torch::Tensor Clamp(const torch::Tensor& x, double lo, double hi) {
  const torch::Tensor y = torch::relu(x - lo) + lo;
  return hi - torch::relu(hi - y);
}
// norm_normalize: xyz / (‖xyz‖ + 1e-10), kappa = elu(k) + 1 + 0.01.
torch::Tensor NormNormalize(const torch::Tensor& n) {
  const torch::Tensor xyz = n.slice(1, 0, 3);
  const torch::Tensor norm = torch::sqrt((xyz * xyz).sum(1, true)) + 1e-10;
  return torch::cat({xyz / norm, torch::elu(n.slice(1, 3, 4)) + 1.0 + 0.01}, 1);
}

}  // namespace

struct Metric3dModel::Impl {
  Metric3dConfig cfg;
  std::string source;
  RuntimeOptions rt;
  torch::Device device = torch::kCPU;
  PrecisionPolicy prec;
  Conv patch;
  torch::Tensor cls, regs, pos_embed;
  std::vector<VitBlock> blocks;
  LayerNorm norm;
  Readout read[4];
  FuseBlock up3, up2, up1;
  Conv dr0, dr2;            // depth_regressor.{0,2}
  Conv np0, np2, np4, np6;  // normal_predictor
  ContextHead ctx[3][2];    // levels 04, 08, 16 × (hidden, context)
  Conv zqr[3];
  ConvGru gru08, gru16, gru32;
  Conv fh1d, fh2d, fh1n, fh2n, mask0, mask2;
  torch::Tensor bins;
  mutable std::map<std::string, io::TensorView>* taps = nullptr;
  void LoadEncoder(WeightStore& ws);
  void LoadDecoder(WeightStore& ws);
  void LoadRefiner(WeightStore& ws);
  void Tap(const std::string& n, const torch::Tensor& t) const {
    if (taps) (*taps)[n] = ToView(t);
  }

  std::vector<torch::Tensor> Encode(const torch::Tensor& img) const {
    const int64_t C = cfg.embed_dim, H = img.size(2), W = img.size(3), h14 = H / cfg.patch, w14 = W / cfg.patch;
    torch::Tensor x = patch(img, prec).flatten(2).transpose(1, 2);  // [1, N, C]
    Tap("patch_embed_out", x);
    // interpolate_pos_encoding: bicubic with the given scale factors ((h14 + 0.1)/37, (w14 + 0.1)/37).
    const int64_t G = cfg.pos_grid;
    const torch::Tensor grid = pos_embed.slice(1, 1, 1 + G * G).reshape({1, G, G, C}).permute({0, 3, 1, 2});
    const double sh = (h14 + 0.1) / G, sw = (w14 + 0.1) / G;
    const torch::Tensor pe =
        torch::upsample_bicubic2d(grid, {h14, w14}, false, sh, sw).permute({0, 2, 3, 1}).reshape({1, h14 * w14, C});
    const torch::Tensor pos = torch::cat({pos_embed.slice(1, 0, 1), pe}, 1);
    Tap("pos_embed_interp", pos);
    x = torch::cat({cls, x}, 1) + pos;
    x = torch::cat({x.slice(1, 0, 1), regs, x.slice(1, 1, x.size(1))}, 1);
    Tap("tokens_prepared", x);
    std::vector<torch::Tensor> feats;
    for (size_t i = 0; i < blocks.size(); ++i) {
      x = blocks[i](x, prec);
      if (cfg.multi_output && std::find(cfg.feature_blocks.begin(), cfg.feature_blocks.end(), static_cast<int>(i)) !=
                                  cfg.feature_blocks.end())
        feats.push_back(x);
    }
    if (!cfg.multi_output) {
      const torch::Tensor n = norm(x);
      feats = {n, n, n, n};
    }
    if (taps) Tap("encoder_features", torch::stack(feats, 0));
    return feats;
  }

  torch::Tensor RunReadout(int k, const torch::Tensor& f, int64_t h14, int64_t w14) const {
    const Readout& r = read[k];
    const int64_t C = cfg.embed_dim, nl = 1 + cfg.registers;
    const torch::Tensor tokens = f.slice(1, nl, f.size(1)).reshape({f.size(0), h14, w14, C});
    const torch::Tensor learn = f.slice(1, 0, nl).reshape({f.size(0), 1, 1, nl * C});
    torch::Tensor o = torch::gelu(r.patch(tokens, prec) + r.learn(learn, prec)).permute({0, 3, 1, 2});
    if (r.kind == 1) o = r.sample(o, prec);
    if (r.kind == 2) {
      // Upstream upsamples (nearest, ×3.5) and then applies the 1×1 convolution. A 1×1 convolution acts on each
      // pixel alone and nearest upsampling copies pixels, so the two commute: convolving first gives the same values
      // at 1/12 of the pixels (E·C channels at full size were the decoder's largest transient).
      o = torch::upsample_nearest2d(
          r.sample(o, prec), {static_cast<int64_t>(std::floor(h14 * 3.5)), static_cast<int64_t>(std::floor(w14 * 3.5))},
          3.5, 3.5);
    }
    return o;
  }

  void Decode(const std::vector<torch::Tensor>& feats, int64_t h14, int64_t w14, torch::Tensor* depth,
              torch::Tensor* conf, torch::Tensor* normal) const {
    const PrecisionPolicy& p = prec;
    const char* names[3] = {"04", "08", "16"};
    // The refinement below reads only its state, hidden states and context terms: everything before it (readouts,
    // the decoder's features, the bin probabilities — ≈ 0.2 GB at the released size) lives in this scope and is gone
    // before the loop, whose working set is the pass's memory peak.
    torch::Tensor state, net[3];
    std::vector<torch::Tensor> cz[3];
    {
      torch::Tensor r[4];
      for (int k = 0; k < 4; ++k) {
        r[k] = RunReadout(k, feats[static_cast<size_t>(k)], h14, w14);
        // NHWC from here on: oneDNN runs the decoder's many narrow convolutions faster channels-last.
        r[k] = r[k].contiguous(torch::MemoryFormat::ChannelsLast);
        Tap("readout_" + std::to_string(k), r[k]);
      }
      // decoder_mono: upconv_3(read_3), upconv_2(·, read_2) ×2, upconv_1(·, read_1) ×1.75.
      torch::Tensor x = up3(r[3], nullptr, p);
      x = up2(x, &r[2], p);
      const torch::Tensor ref = up1(x, &r[1], p);
      Tap("ref_feat", ref);
      const int64_t dc1 = cfg.decoder_channels[1];
      const torch::Tensor feat = ref.slice(1, 0, dc1);
      // Initial depth: softmax over the 256 log-spaced bins, expectation, clamp, state = (d − 200)/100.
      // conv → ReLU → conv runs stay bf16 between their convolutions (Conv::Chain): ReLU commutes with the rounding,
      // so the values are those of converting around each convolution.
      const torch::Tensor prob = torch::softmax(ChainOut(dr2.Chain(torch::relu(dr0.Chain(feat)))), 1);
      const torch::Tensor d = (prob * bins.view({1, -1, 1, 1})).sum(1, true);
      Tap("init_depth_expectation", d);
      const torch::Tensor d_state = (Clamp(d, cfg.min_depth, cfg.max_depth) - cfg.max_depth) / cfg.regress_scale;
      const torch::Tensor nraw =
          ChainOut(np6.Chain(torch::relu(np4.Chain(torch::relu(np2.Chain(torch::relu(np0.Chain(feat))))))));
      Tap("normal_head_raw", nraw);
      const torch::Tensor n0 = NormNormalize(torch::cat({nraw, ref.slice(1, dc1 + 1, dc1 + 2)}, 1));
      state = torch::cat({d_state, ref.slice(1, dc1, dc1 + 1), n0}, 1);
      Tap("depth_init", state);
      // Context encoder on (read_0, relu(read_1), relu(read_2)) — the in-place ReLU side effect of upstream's
      // ConvBlock.
      const torch::Tensor levels[3] = {r[0], torch::relu(r[1]), torch::relu(r[2])};
      const int64_t hd = cfg.hidden;
      for (int l = 0; l < 3; ++l) {
        net[l] = torch::tanh(ctx[l][0](levels[l], p));
        const torch::Tensor c = torch::relu(ctx[l][1](levels[l], p));
        Tap(std::string("net_init_") + names[l], net[l]);
        Tap(std::string("context_") + names[l], c);
        const torch::Tensor zqr_out = zqr[l](c, p);
        cz[l] = {zqr_out.slice(1, 0, hd), zqr_out.slice(1, hd, 2 * hd), zqr_out.slice(1, 2 * hd, 3 * hd)};
      }
    }
    // Slow-fast multi-level GRU refinement (BasicMultiUpdateBlock, n_gru_layers 3).
    std::vector<torch::Tensor> iter_states;
    torch::Tensor mask;
    for (int it = 0; it < cfg.iters; ++it) {
      const torch::Tensor flow = state;
      net[2] = gru32(net[2], cz[2], {Pool2x(net[1])}, p);
      net[2] = gru32(net[2], cz[2], {Pool2x(net[1])}, p);
      net[1] = gru16(net[1], cz[1], {Interp(Pool2x(net[0]), net[1]), Interp(net[2], net[1])}, p);
      net[2] = gru32(net[2], cz[2], {Pool2x(net[1])}, p);
      net[1] = gru16(net[1], cz[1], {Interp(Pool2x(net[0]), net[1]), Interp(net[2], net[1])}, p);
      net[0] = gru08(net[0], cz[0], {flow, Interp(net[1], net[0])}, p);
      const torch::Tensor delta = torch::cat({ChainOut(fh2d.Chain(torch::relu(fh1d.Chain(net[0])))),
                                              ChainOut(fh2n.Chain(torch::relu(fh1n.Chain(net[0]))))},
                                             1);
      // The upsampling mask: upstream computes it every iteration, but only the last one's is read.
      if (it == cfg.iters - 1) mask = 0.25 * ChainOut(mask2.Chain(torch::relu(mask0.Chain(net[0]))));
      state = state + delta;
      if (taps) iter_states.push_back(state);
    }
    if (taps) {
      Tap("iter_state", torch::stack(iter_states, 0));
      for (int l = 0; l < 3; ++l) Tap(std::string("net_final_") + names[l], net[l]);
      Tap("up_mask_final", mask);
    }
    // Convex ×4 upsampling (upsample_flow): softmax over the 9 taps, unfold with zero padding.
    const int64_t N = state.size(0), Hq = state.size(2), Wq = state.size(3);
    const torch::Tensor m = torch::softmax(mask.view({N, 1, 9, 4, 4, Hq, Wq}), 2);
    const torch::Tensor uf = torch::im2col(state, {3, 3}, {1, 1}, {1, 1}, {1, 1}).view({N, 6, 9, 1, 1, Hq, Wq});
    // Σ over the 9 taps in upstream's order, one tap at a time: the [N, 6, 9, 4, 4, Hq, Wq] products (142 MB at
    // 616×1064) are never materialised.
    torch::Tensor acc = m.select(2, 0) * uf.select(2, 0);
    for (int64_t k = 1; k < 9; ++k) acc.addcmul_(m.select(2, k), uf.select(2, k));
    const torch::Tensor up = acc.permute({0, 1, 4, 2, 5, 3}).reshape({N, 6, 4 * Hq, 4 * Wq});
    *depth = Clamp(up.slice(1, 0, 1) * cfg.regress_scale + cfg.max_depth, cfg.min_depth, cfg.max_depth);
    *conf = up.slice(1, 1, 2);
    *normal = NormNormalize(up.slice(1, 2, 6));
  }
};

namespace {

std::vector<int> Ints(const nlohmann::json& j) { return j.get<std::vector<int>>(); }

}  // namespace

Metric3dModel::Metric3dModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Metric3dModel::~Metric3dModel() = default;
const Metric3dConfig& Metric3dModel::config() const { return impl_->cfg; }
void Metric3dModel::SetTapSink(std::map<std::string, io::TensorView>* sink) const { impl_->taps = sink; }

std::shared_ptr<Metric3dModel> Metric3dModel::Load(const std::string& model_path, const std::string& config_path,
                                                   const RuntimeOptions& runtime) {
  const io::Checkpoint ckpt = io::Checkpoint::Open(model_path);
  const auto sd = ckpt.StateDict({"model_state_dict", "state_dict", "model", ""});
  const std::string json =
      ReadModelConfig(model_path, config_path, ckpt.format() == io::Checkpoint::Format::kSafetensors, "Metric3D");
  return Create(sd, json, model_path, runtime);
}

namespace {

// The architecture from the tensors' shapes (and the config.json sections where they say more).
Metric3dConfig ConfigFromTensors(const std::map<std::string, torch::Tensor>& tensors, const nlohmann::json& je,
                                 const nlohmann::json& jd, const nlohmann::json& jdata, const std::string& source) {
  auto shape = [&](const std::string& n) {
    auto it = tensors.find(n);
    FREELOC_CHECK(it != tensors.end(),
                  source << ": tensor 'depth_model." << n << "' is missing; is this a Metric3D ViT checkpoint?");
    return it->second.sizes().vec();
  };
  Metric3dConfig c;
  const auto pe = shape("encoder.patch_embed.proj.weight");
  c.embed_dim = static_cast<int>(pe[0]);
  c.patch = static_cast<int>(pe[2]);
  c.depth = 0;
  while (tensors.count("encoder.blocks.0." + std::to_string(c.depth) + ".norm1.weight")) ++c.depth;
  FREELOC_CHECK(c.depth > 0, source << ": no encoder.blocks.0.<i> tensors (block_chunks = 1 layout expected)");
  c.swiglu = tensors.count("encoder.blocks.0.0.mlp.w12.weight") > 0;
  c.ffn_hidden = static_cast<int>(
      shape(c.swiglu ? "encoder.blocks.0.0.mlp.w3.weight" : "encoder.blocks.0.0.mlp.fc1.weight")[c.swiglu ? 1 : 0]);
  c.registers = static_cast<int>(shape("encoder.register_tokens")[1]);
  c.pos_grid = static_cast<int>(std::lround(std::sqrt(static_cast<double>(shape("encoder.pos_embed")[1] - 1))));
  c.heads = je.value("num_heads", c.embed_dim / 64);
  c.ln_eps = je.value("layernorm_eps", 1e-6);
  c.variant = c.embed_dim == 384    ? "vit_small"
              : c.embed_dim == 1024 ? "vit_large"
              : c.embed_dim == 1536 ? "vit_giant2"
                                    : "custom";
  c.multi_output = je.value("multi_output", c.swiglu);
  if (je.contains("intermediate_block_indices") && je["intermediate_block_indices"].is_array()) {
    c.feature_blocks = Ints(je["intermediate_block_indices"]);
  } else if (c.multi_output) {
    for (int i = 0; i < c.depth && c.feature_blocks.size() < 4; ++i)
      if ((i + 1) % std::max(1, c.depth / 4) == 0) c.feature_blocks.push_back(i);
  }
  c.feature_channels = {static_cast<int>(shape("decoder.token2feature.read_0.sample.0.weight")[0]),
                        static_cast<int>(shape("decoder.token2feature.read_1.sample.weight")[1]), c.embed_dim,
                        jd.contains("feature_channels") ? Ints(jd["feature_channels"])[3] : 2 * c.embed_dim};
  const int dc1 = static_cast<int>(shape("decoder.decoder_mono.upconv_1.out_conv.weight")[0]) - 2;
  const int dc2 = static_cast<int>(shape("decoder.decoder_mono.upconv_2.out_conv.weight")[0]);
  c.decoder_channels = {jd.contains("decoder_channels") ? Ints(jd["decoder_channels"])[0] : dc1, dc1, dc2, c.embed_dim,
                        c.embed_dim};
  c.hidden = static_cast<int>(shape("decoder.context_zqr_convs.0.weight")[0]) / 3;
  c.iters = jd.value("iters", c.embed_dim == 384 ? 4 : 8);
  FREELOC_CHECK(c.iters >= 1 && c.iters <= 64, "Metric3D config: \"iters\" is "
                                                   << c.iters
                                                   << "; the GRU refinement needs 1 to 64 iterations (the released "
                                                      "models use 4 for ViT-S, 8 otherwise)");
  c.num_bins = static_cast<int>(shape("decoder.depth_regressor.2.weight")[0]);
  if (jdata.contains("input_size")) {
    const auto s = Ints(jdata["input_size"]);
    c.input_h = s[0];
    c.input_w = s[1];
  }
  if (jd.contains("depth_normalize")) {
    c.min_depth = jd["depth_normalize"][0].get<double>();
    c.max_depth = jd["depth_normalize"][1].get<double>();
  }
  FREELOC_CHECK(c.embed_dim % c.heads == 0,
                source << ": embed_dim " << c.embed_dim << " not divisible by " << c.heads << " heads");
  FREELOC_CHECK(!c.multi_output || c.feature_blocks.size() == 4, source << ": need 4 intermediate feature blocks");
  FREELOC_CHECK(c.input_h % 28 == 0 && c.input_w % 28 == 0, source << ": input size must be multiples of 28");
  return c;
}

// Conv2d loaders: 3×3 (padding 1) and 1×1.
void Conv3(WeightStore& ws, const PrecisionPolicy& p, Conv& cv, const std::string& n, int64_t out, int64_t in) {
  cv.Load(ws, n, {out, in, 3, 3}, true, 1, 1, false, p);
}
void Conv1(WeightStore& ws, const PrecisionPolicy& p, Conv& cv, const std::string& n, int64_t out, int64_t in) {
  cv.Load(ws, n, {out, in, 1, 1}, true, 1, 0, false, p);
}

}  // namespace

// The DINOv2 encoder: patch embedding, tokens, blocks, final norm.
void Metric3dModel::Impl::LoadEncoder(WeightStore& ws) {
  const Metric3dConfig& c = cfg;
  const PrecisionPolicy& p = prec;
  const int64_t C = c.embed_dim, F = c.ffn_hidden;
  patch.Load(ws, "encoder.patch_embed.proj", {C, 3, c.patch, c.patch}, true, c.patch, 0, false, p);
  cls = ws.Take("encoder.cls_token", {1, 1, C});
  regs = ws.Take("encoder.register_tokens", {1, c.registers, C});
  pos_embed = ws.Take("encoder.pos_embed", {1, static_cast<int64_t>(c.pos_grid) * c.pos_grid + 1, C});
  ws.Ignore("encoder.mask_token");
  blocks.resize(static_cast<size_t>(c.depth));
  for (int i = 0; i < c.depth; ++i) {
    const std::string b = "encoder.blocks.0." + std::to_string(i) + ".";
    VitBlock& k = blocks[static_cast<size_t>(i)];
    k.heads = c.heads;
    k.swiglu = c.swiglu;
    k.n1.Load(ws, b + "norm1", C, c.ln_eps);
    k.n2.Load(ws, b + "norm2", C, c.ln_eps);
    k.qkv.Load(ws, b + "attn.qkv", 3 * C, C, true, p);
    k.proj.Load(ws, b + "attn.proj", C, C, true, p);
    k.ls1 = ws.Take(b + "ls1.gamma", {C});
    k.ls2 = ws.Take(b + "ls2.gamma", {C});
    if (c.swiglu) {
      k.fc1.Load(ws, b + "mlp.w12", 2 * F, C, true, p);
      k.fc2.Load(ws, b + "mlp.w3", C, F, true, p);
    } else {
      k.fc1.Load(ws, b + "mlp.fc1", F, C, true, p);
      k.fc2.Load(ws, b + "mlp.fc2", C, F, true, p);
    }
  }
  if (ws.Has("encoder.norm.weight")) {
    norm.Load(ws, "encoder.norm", C, c.ln_eps);  // present (and unused) in the giant2 layout too
  }
}

// The decoder's readouts, fusion blocks and the depth and normal heads.
void Metric3dModel::Impl::LoadDecoder(WeightStore& ws) {
  const Metric3dConfig& c = cfg;
  const PrecisionPolicy& p = prec;
  const int64_t C = c.embed_dim;
  const int dc1 = c.decoder_channels[1], dc2 = c.decoder_channels[2];
  const int64_t fc0 = c.feature_channels[0], fc1 = c.feature_channels[1];
  for (int k = 0; k < 4; ++k) {
    const std::string r = "decoder.token2feature.read_" + std::to_string(k) + ".";
    read[k].patch.Load(ws, r + "readoper.project_patch", C, C, true, p);
    read[k].learn.Load(ws, r + "readoper.project_learn", C, (1 + c.registers) * C, false, p);
    if (k == 1) {
      read[k].kind = 1;
      read[k].sample.Load(ws, r + "sample", {C, fc1, 2, 2}, true, 2, 0, true, p);
    } else if (k == 0) {
      read[k].kind = 2;
      read[k].sample.Load(ws, r + "sample.0", {fc0, C, 1, 1}, true, 1, 0, false, p);
    }
  }
  auto block = [&](ConvBlock& b, const std::string& n, int64_t ch) {
    Conv3(ws, p, b.c1, n + ".conv1", ch, ch);
    Conv3(ws, p, b.c2, n + ".conv2", ch, ch);
    b.c1.ForChains();  // both run through Chain only
    b.c2.ForChains();
  };
  const std::string dm = "decoder.decoder_mono.";
  block(up3.trunk, dm + "upconv_3.way_trunk", C);
  Conv1(ws, p, up3.out, dm + "upconv_3.out_conv", C, C);
  block(up2.trunk, dm + "upconv_2.way_trunk", C);
  block(up2.branch, dm + "upconv_2.way_branch", C);
  up2.has_branch = true;
  up2.scale = 2.0;
  Conv1(ws, p, up2.out, dm + "upconv_2.out_conv", dc2, C);
  block(up1.trunk, dm + "upconv_1.way_trunk", fc1);
  block(up1.branch, dm + "upconv_1.way_branch", fc1);
  up1.has_branch = true;
  up1.scale = 1.75;
  Conv1(ws, p, up1.out, dm + "upconv_1.out_conv", dc1 + 2, fc1);
  Conv3(ws, p, dr0, "decoder.depth_regressor.0", 256, dc1);
  Conv1(ws, p, dr2, "decoder.depth_regressor.2", c.num_bins, 256);
  Conv3(ws, p, np0, "decoder.normal_predictor.0", 128, dc1);
  Conv1(ws, p, np2, "decoder.normal_predictor.2", 128, 128);
  Conv1(ws, p, np4, "decoder.normal_predictor.4", 128, 128);
  Conv1(ws, p, np6, "decoder.normal_predictor.6", 3, 128);
}

// The RAFT-style refiner: context encoders, zqr convolutions, ConvGRUs, flow and mask heads.
void Metric3dModel::Impl::LoadRefiner(WeightStore& ws) {
  const Metric3dConfig& c = cfg;
  const PrecisionPolicy& p = prec;
  const int64_t C = c.embed_dim, hd = c.hidden, fc0 = c.feature_channels[0], fc1 = c.feature_channels[1];
  const int64_t level_in[3] = {fc0, fc1, C};
  const char* lv[3] = {"04", "08", "16"};
  for (int l = 0; l < 3; ++l) {
    for (int h = 0; h < 2; ++h) {
      const std::string b =
          "decoder.context_feature_encoder.outputs" + std::string(lv[l]) + "." + std::to_string(h) + ".";
      ContextHead& ch = ctx[l][h];
      Conv3(ws, p, ch.c1, b + "0.conv1", hd, level_in[l]);
      Conv3(ws, p, ch.c2, b + "0.conv2", hd, hd);
      ch.n1w = ws.Take(b + "0.norm1.weight", {hd});
      ch.n1b = ws.Take(b + "0.norm1.bias", {hd});
      ch.n2w = ws.Take(b + "0.norm2.weight", {hd});
      ch.n2b = ws.Take(b + "0.norm2.bias", {hd});
      ch.has_down = ws.Has(b + "0.downsample.0.weight");
      if (ch.has_down) {
        Conv1(ws, p, ch.down, b + "0.downsample.0", hd, level_in[l]);
        ch.ndw = ws.Take(b + "0.downsample.1.weight", {hd});
        ch.ndb = ws.Take(b + "0.downsample.1.bias", {hd});
        ws.Ignore(b + "0.norm3.weight");  // the same module as downsample.1, registered twice
        ws.Ignore(b + "0.norm3.bias");
      }
      Conv3(ws, p, ch.post, b + "1", hd, hd);
    }
    Conv3(ws, p, zqr[l], "decoder.context_zqr_convs." + std::to_string(l), 3 * hd, hd);
  }
  auto gru = [&](ConvGru& g, const std::string& n, int64_t in) {
    Conv3(ws, p, g.z, n + ".convz", hd, hd + in);
    Conv3(ws, p, g.r, n + ".convr", hd, hd + in);
    Conv3(ws, p, g.q, n + ".convq", hd, hd + in);
    for (Conv* cv : {&g.z, &g.r, &g.q}) cv->ForChains();  // Chain only
  };
  gru(gru08, "decoder.update_block.gru08", 2 * hd + 6 - hd);
  gru(gru16, "decoder.update_block.gru16", 2 * hd);
  gru(gru32, "decoder.update_block.gru32", hd);
  Conv3(ws, p, fh1d, "decoder.update_block.flow_head.conv1d", hd, hd);
  Conv3(ws, p, fh2d, "decoder.update_block.flow_head.conv2d", 2, hd);
  Conv3(ws, p, fh1n, "decoder.update_block.flow_head.conv1n", hd, hd);
  Conv3(ws, p, fh2n, "decoder.update_block.flow_head.conv2n", 4, hd);
  Conv3(ws, p, mask0, "decoder.update_block.mask.0", hd, hd);
  Conv1(ws, p, mask2, "decoder.update_block.mask.2", 144, hd);
  // The depth, normal, flow and mask heads run through Chain only (ContextHead, zqr and the readouts do not).
  for (Conv* cv : {&dr0, &dr2, &np0, &np2, &np4, &np6, &fh1d, &fh2d, &fh1n, &fh2n, &mask0, &mask2}) cv->ForChains();
}

std::shared_ptr<Metric3dModel> Metric3dModel::Create(const std::map<std::string, io::TensorView>& sd_in,
                                                     const std::string& config_json, const std::string& source,
                                                     const RuntimeOptions& runtime) {
  ApplyRuntime(runtime);
  const nlohmann::json j = ParseModelConfig(config_json, source, "Metric3D");
  std::map<std::string, torch::Tensor> tensors;
  for (const auto& [k, v] : sd_in) {
    std::string n = k;
    if (n.rfind("depth_model.", 0) == 0) n = n.substr(12);
    tensors[n] = ToTorch(v);
  }
  auto impl = std::make_unique<Impl>();
  impl->cfg = ConfigFromTensors(tensors, j.value("encoder", nlohmann::json::object()),
                                j.value("decoder", nlohmann::json::object()), j.value("data", nlohmann::json::object()),
                                source);
  const Metric3dConfig& c = impl->cfg;
  impl->rt = runtime;
  impl->source = source;
  impl->device = DeviceOf(runtime);
  impl->prec.bf16 = internal::RunBf16(runtime);  // asked for, and pays here (bf16_linear.h)
  WeightStore ws(std::move(tensors), source, impl->device, impl->prec.bf16);
  impl->LoadEncoder(ws);
  impl->LoadDecoder(ws);
  impl->LoadRefiner(ws);
  ws.Finish();
  impl->bins = torch::exp(torch::linspace(std::log(c.min_depth), std::log(c.max_depth), c.num_bins, torch::kFloat32))
                   .to(impl->device);
  return std::shared_ptr<Metric3dModel>(new Metric3dModel(std::move(impl)));
}

void Metric3dModel::Forward(const std::vector<float>& input, io::TensorView* pred_depth, io::TensorView* confidence,
                            io::TensorView* pred_normal) const {
  torch::NoGradGuard ng;
  const int H = impl_->cfg.input_h, W = impl_->cfg.input_w;
  FREELOC_CHECK(input.size() == static_cast<size_t>(3) * H * W,
                "Metric3D: input must be [3, " << H << ", " << W << "]");
  const torch::Tensor x =
      torch::from_blob(const_cast<float*>(input.data()), {1, 3, H, W}, torch::kFloat32).to(impl_->device).clone();
  const auto feats = impl_->Encode(x);
  torch::Tensor d, c, n;
  impl_->Decode(feats, H / impl_->cfg.patch, W / impl_->cfg.patch, &d, &c, &n);
  *pred_depth = ToView(d[0][0]);
  *confidence = ToView(c[0][0]);
  *pred_normal = ToView(n[0]);
}

Metric3dOutput Metric3dModel::Estimate(const Image& image, const Camera& camera) const {
  camera.Validate("Metric3D intrinsics");
  torch::NoGradGuard ng;
  Metric3dOutput out;
  out.input = vision::PrepareMetric3dInput(image, impl_->cfg.input_h, impl_->cfg.input_w);
  const auto t0 = std::chrono::steady_clock::now();
  io::TensorView d, c, n;
  Forward(out.input.input, &d, &c, &n);
  out.network_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  out.canonical_depth = d;
  const auto& pad = out.input.pad;
  const int H = out.input.height, W = out.input.width;
  auto unpad = [&](const io::TensorView& t, int ch) {
    const torch::Tensor full = ToTorch(t).reshape({1, ch, H, W});
    return full.slice(2, pad[0], H - pad[1]).slice(3, pad[2], W - pad[3]);
  };
  // hubconf: bilinear (align_corners=False) to h×w, × (fx·s/1000) in float32, clamp [0, 300].
  const float factor = static_cast<float>(camera.fx * out.input.scale / impl_->cfg.canonical_focal);
  const torch::Tensor dm =
      torch::clamp(torch::upsample_bilinear2d(unpad(d, 1), {image.height, image.width}, false) * factor, 0, 300);
  out.depth = DepthMap(image.width, image.height);
  std::memcpy(out.depth.data.data(), dm.contiguous().data_ptr<float>(), out.depth.data.size() * 4);
  const torch::Tensor cm = torch::upsample_bilinear2d(unpad(c, 1), {image.height, image.width}, false).contiguous();
  out.confidence.assign(cm.data_ptr<float>(), cm.data_ptr<float>() + cm.numel());
  // do_test.py: normals unpadded and resized with align_corners=True, not re-normalised.
  const torch::Tensor nm =
      torch::upsample_bilinear2d(unpad(n, 4).slice(1, 0, 3), {image.height, image.width}, true).contiguous();
  out.normal.assign(nm.data_ptr<float>(), nm.data_ptr<float>() + nm.numel());
  out.metadata = {{"model", impl_->source},
                  {"variant", impl_->cfg.variant},
                  {"precision", ToString(impl_->rt.precision)},
                  {"input_size", std::to_string(H) + "x" + std::to_string(W)},
                  {"scale", std::to_string(out.input.scale)},
                  {"focal_factor", std::to_string(factor)},
                  {"network_ms", std::to_string(out.network_ms)}};
  return out;
}

}  // namespace freeloc::nn
