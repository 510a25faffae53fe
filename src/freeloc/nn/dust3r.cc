// DUSt3R forward pass. Each block cites the upstream code it reproduces (naver/dust3r 4c24a6e, croco d7de070).
#include "freeloc/nn/dust3r.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/io/checkpoint.h"
#include "freeloc/nn/internal/layers.h"
#include "freeloc/nn/internal/torch_util.h"

namespace freeloc::nn {

using namespace internal;  // NOLINT

namespace {

using Rope = std::pair<torch::Tensor, torch::Tensor>;

double Ms(std::chrono::steady_clock::time_point a) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a).count();
}

// croco/models/blocks.py Block: x + attn(norm1 x), x + mlp(norm2 x).
struct EncBlock {
  LayerNorm n1, n2;
  SelfAttention attn;
  Mlp mlp;
  torch::Tensor operator()(torch::Tensor x, const Rope& r, const PrecisionPolicy& p) const {
    const torch::Tensor h = n2.AddForProducts(&x, attn(n1.ForProducts(x, p), r, p), p);
    return x + mlp(h, p);
  }
};

// croco/models/blocks.py DecoderBlock (norm_im2_in_dec = True).
struct DecBlock {
  LayerNorm n1, n2, n3, ny;
  SelfAttention attn;
  CrossAttention cross;
  Mlp mlp;
  torch::Tensor operator()(torch::Tensor x, const torch::Tensor& y, const Rope& rx, const Rope& ry,
                           const PrecisionPolicy& p) const {
    torch::Tensor h = n2.AddForProducts(&x, attn(n1.ForProducts(x, p), rx, p), p);
    const torch::Tensor yn = ny.ForProducts(y, p);
    h = n3.AddForProducts(&x, cross(h, yn, rx, ry, p), p);
    return x + mlp(h, p);
  }
};

// dust3r/heads/dpt_head.py DPTOutputAdapter_fix + croco/models/dpt_block.py (FeatureFusionBlock_custom,
// ResidualConvUnit_custom).
// The convolutions are Conv::Chain links: in bf16 they run on bf16 channels-last activations, while the residual
// stream (the skip connections, the fusion sums) stays fp32 — rounding it to bf16 too doubled the heads' share of
// the bf16 error on the parity fixtures (Bf16.AccuracyCostOnTheParityFixtures).
struct Rcu {
  Conv c1, c2;
  torch::Tensor operator()(const torch::Tensor& x) const {
    // The first ReLU must not touch x (the skip connection uses it); the second may work in place.
    torch::Tensor h = c1.Chain(torch::relu(x));
    h.relu_();
    return c2.Chain(h).to(torch::kFloat32).add_(x);
  }
};
struct Fusion {
  Rcu rcu1, rcu2;
  Conv out;
  bool has_rcu1 = true;
  torch::Tensor operator()(const torch::Tensor& x0, const torch::Tensor* x1) const {
    torch::Tensor o = x0;
    if (x1) o = o + rcu1(*x1);
    o = rcu2(o);
    // Upstream upsamples (×2 bilinear, align_corners) and then applies out_conv (1×1). The two commute — a 1×1
    // convolution acts on each pixel's channels alike, and the interpolation weights sum to 1 — so the convolution
    // runs on the small map: a quarter of its work, and no conversion of the upsampled map into and out of bf16.
    return Upsample2xAlignCorners(out.Chain(o).to(torch::kFloat32));
  }
};

struct DptHead {
  Conv act_proj[4], act_resize[4];  // act_postprocess.{i}.0 and .1 (none for i = 2)
  Conv layer_rn[4];
  Fusion refine[4];  // refinenet1..4
  Conv head0, head2;
  PointwiseOut head4;
};

// mast3r/catmlp_dpt_head.py Cat_MLP_LocalFeatures_DPT_Pts3d: head_local_features (Mlp: fc1, exact GELU, fc2).
struct LocalHead {
  Linear fc1, fc2;
};

// downstream_head{h+1}.dpt: act_postprocess, scratch layers, the four refinenets and the head convolutions.
void LoadDptHead(WeightStore& ws, const Dust3rConfig& c, int h, const PrecisionPolicy& hp, DptHead* head) {
  DptHead& hd = *head;
  const int64_t F = c.dpt_feature_dim;
  const int64_t dims_in[4] = {c.enc_dim, c.dec_dim, c.dec_dim, c.dec_dim};
  const std::string pre = "downstream_head" + std::to_string(h + 1) + ".dpt.";
  for (int i = 0; i < 4; ++i) {
    const int64_t L = c.dpt_layer_dims[i];
    const std::string ap = pre + "act_postprocess." + std::to_string(i);
    hd.act_proj[i].Load(ws, ap + ".0", {L, dims_in[i], 1, 1}, true, 1, 0, false, hp);
    if (i == 0) hd.act_resize[i].Load(ws, ap + ".1", {L, L, 4, 4}, true, 4, 0, true, hp);
    if (i == 1) hd.act_resize[i].Load(ws, ap + ".1", {L, L, 2, 2}, true, 2, 0, true, hp);
    if (i == 3) hd.act_resize[i].Load(ws, ap + ".1", {L, L, 3, 3}, true, 2, 1, false, hp);
    // scratch.layer{i+1}_rn and scratch.layer_rn.{i} name the same tensor; accept either spelling.
    const std::string a = pre + "scratch.layer" + std::to_string(i + 1) + "_rn",
                      b = pre + "scratch.layer_rn." + std::to_string(i);
    const bool use_a = ws.Has(a + ".weight");
    hd.layer_rn[i].Load(ws, use_a ? a : b, {F, L, 3, 3}, false, 1, 1, false, hp);
    if (use_a) ws.Ignore(b + ".weight");
    const std::string rf = pre + "scratch.refinenet" + std::to_string(i + 1);
    Fusion& fu = hd.refine[i];
    if (i < 3) {
      fu.rcu1.c1.Load(ws, rf + ".resConfUnit1.conv1", {F, F, 3, 3}, true, 1, 1, false, hp);
      fu.rcu1.c2.Load(ws, rf + ".resConfUnit1.conv2", {F, F, 3, 3}, true, 1, 1, false, hp);
    } else {
      // refinenet4.resConfUnit1 exists in the checkpoint but is never used.
      for (const char* n : {".resConfUnit1.conv1.weight", ".resConfUnit1.conv1.bias", ".resConfUnit1.conv2.weight",
                            ".resConfUnit1.conv2.bias"})
        ws.Ignore(rf + n);
    }
    fu.rcu2.c1.Load(ws, rf + ".resConfUnit2.conv1", {F, F, 3, 3}, true, 1, 1, false, hp);
    fu.rcu2.c2.Load(ws, rf + ".resConfUnit2.conv2", {F, F, 3, 3}, true, 1, 1, false, hp);
    fu.out.Load(ws, rf + ".out_conv", {F, F, 1, 1}, true, 1, 0, false, hp);
  }
  hd.head0.Load(ws, pre + "head.0", {c.dpt_head0_dim, F, 3, 3}, true, 1, 1, false, hp);
  hd.head2.Load(ws, pre + "head.2", {c.dpt_last_dim, c.dpt_head0_dim, 3, 3}, true, 1, 1, false, hp);
  hd.head4.Load(ws, pre + "head.4", c.dpt_channels, c.dpt_last_dim, true, hp);
  // Every (non-transposed) convolution of the head runs through Chain.
  for (int i = 0; i < 4; ++i) {
    hd.act_proj[i].ForChains();
    hd.act_resize[i].ForChains();
    hd.layer_rn[i].ForChains();
    for (Conv* cv : {&hd.refine[i].rcu1.c1, &hd.refine[i].rcu1.c2, &hd.refine[i].rcu2.c1, &hd.refine[i].rcu2.c2,
                     &hd.refine[i].out})
      cv->ForChains();
  }
  hd.head0.ForChains();
  hd.head2.ForChains();
}

// load_model(): dec_blocks copied into dec_blocks2 when the checkpoint has none.
void AddSecondDecoder(std::map<std::string, torch::Tensor>* tensors) {
  for (const auto& [k, v] : *tensors)
    if (k.rfind("dec_blocks2.", 0) == 0) return;
  std::map<std::string, torch::Tensor> add;
  for (const auto& [k, v] : *tensors)
    if (k.rfind("dec_blocks.", 0) == 0) add["dec_blocks2." + k.substr(11)] = v;
  tensors->insert(add.begin(), add.end());
}

}  // namespace

class Dust3rModel::Encoding {
 public:
  torch::Tensor tokens;  // [1, N, C] after enc_norm
  int64_t h = 0, w = 0;  // token grid
  int height = 0, width = 0;
  double ms = 0;
};

struct Dust3rModel::Impl {
  Dust3rConfig cfg;
  RuntimeOptions rt;
  torch::Device device = torch::kCPU;
  // The whole model, heads included: upstream runs the heads in fp32 (autocast disabled in the head wrapper);
  // freeloc's bf16 runs their convolutions (channels-last) and MLPs in bf16 as well — 2.5× the fp32 rate on the
  // heads' third of a pair's FLOPs — except head.4, whose raw output the exp() reads; the cost is in
  // Bf16.AccuracyCostOnTheParityFixtures.
  PrecisionPolicy prec;
  Rope2D rope;
  Conv patch;
  std::vector<EncBlock> enc;
  LayerNorm enc_norm, dec_norm;
  Linear dec_embed;
  std::vector<DecBlock> dec1, dec2;
  DptHead head[2];
  LocalHead local[2];  // MASt3R only
  mutable std::map<std::string, io::TensorView>* taps = nullptr;

  void Tap(const std::string& name, const torch::Tensor& t) const {
    if (taps) (*taps)[name] = ToView(t);
  }

  // dust3r/patch_embed.py PatchEmbedDust3R + croco encoder loop (AsymmetricCroCo3DStereo._encode_image).
  torch::Tensor EncodeBatch(const torch::Tensor& img, int64_t h, int64_t w, const std::vector<int>& view_ids) const {
    // [B, N, C], n = y·w + x, contiguous: elementwise ops keep their input's strides, so a transposed view here
    // would carry through every block's residual stream (a strided add and a LayerNorm copy per use).
    torch::Tensor x = patch(img, prec).flatten(2).transpose(1, 2).contiguous();
    const Rope r = rope.Tables(h, w, cfg.enc_dim / cfg.enc_heads, device);
    auto tap_each = [&](const std::string& suffix, const torch::Tensor& t) {
      if (!taps) return;
      for (size_t b = 0; b < view_ids.size(); ++b)
        Tap("enc" + std::to_string(view_ids[b]) + "." + suffix,
            t.slice(0, static_cast<int64_t>(b), static_cast<int64_t>(b) + 1));
    };
    tap_each("patch_embed", x);
    for (size_t i = 0; i < enc.size(); ++i) {
      x = enc[i](x, r, prec);
      tap_each("block" + std::to_string(i), x);
    }
    x = enc_norm(x);
    tap_each("out", x);
    return x;
  }

  torch::Tensor ToInput(const Dust3rView& v) const {
    FREELOC_CHECK(v.chw && v.height > 0 && v.width > 0, "DUSt3R: empty input view");
    FREELOC_CHECK(v.height % cfg.patch_size == 0 && v.width % cfg.patch_size == 0,
                  "DUSt3R: input " << v.width << "x" << v.height << " is not a multiple of the patch size "
                                   << cfg.patch_size << "; preprocess with PreprocessForDust3r");
    return torch::from_blob(const_cast<float*>(v.chw), {1, 3, v.height, v.width}, torch::kFloat32).to(device).clone();
  }

  // dust3r/heads/dpt_head.py: hooks → act_postprocess → layer_rn → refinenet4..1 (path4 cropped) → head.
  torch::Tensor RunHead(int which, const std::vector<torch::Tensor>& list, int64_t h, int64_t w, int view) const {
    const DptHead& hd = head[which];
    const std::string tp = "head" + std::to_string(view) + ".";
    torch::Tensor layers[4];
    for (int i = 0; i < 4; ++i) {
      const torch::Tensor& tok = list[static_cast<size_t>(cfg.hooks[i])];
      torch::Tensor g = tok.reshape({tok.size(0), h, w, tok.size(2)}).permute({0, 3, 1, 2});
      g = hd.act_proj[i].Chain(g);
      if (i != 2) g = hd.act_resize[i].Chain(g);
      Tap(tp + "act" + std::to_string(i), g);
      layers[i] = hd.layer_rn[i].Chain(g).to(torch::kFloat32);
      Tap(tp + "rn" + std::to_string(i), layers[i]);
    }
    torch::Tensor path4 = hd.refine[3](layers[3], nullptr);
    Tap(tp + "refinenet4", path4);
    path4 = path4.slice(2, 0, layers[2].size(2)).slice(3, 0, layers[2].size(3));
    const torch::Tensor path3 = hd.refine[2](path4, &layers[2]);
    Tap(tp + "refinenet3", path3);
    const torch::Tensor path2 = hd.refine[1](path3, &layers[1]);
    Tap(tp + "refinenet2", path2);
    const torch::Tensor path1 = hd.refine[0](path2, &layers[0]);
    Tap(tp + "refinenet1", path1);
    torch::Tensor o = hd.head0.Chain(path1);
    o = Upsample2xAlignCorners(o);
    o = hd.head2.Chain(o);
    o.relu_();
    o = hd.head4(o);  // fp32-exact weights and fp32 output: the raw output the exp() reads
    Tap(tp + "raw", o);
    return o;
  }

  // dust3r/heads/postprocess.py reg_dense_conf('exp', vmin, vmax): vmin + exp(x).clip(max = vmax − vmin).
  static torch::Tensor DenseConf(const torch::Tensor& x, double vmin, double vmax) {
    torch::Tensor e = x.exp();
    if (std::isfinite(vmax)) e = e.clamp_max(vmax - vmin);
    return vmin + e;
  }

  // dust3r/heads/postprocess.py: reg_dense_depth('exp') and reg_dense_conf.
  void Postprocess(const torch::Tensor& raw, io::TensorView* pts, io::TensorView* conf) const {
    const torch::Tensor f = raw.permute({0, 2, 3, 1}).contiguous();  // B,H,W,4 (the norm runs over contiguous xyz)
    const torch::Tensor xyz = f.slice(3, 0, 3);
    const torch::Tensor d = xyz.norm(2, -1, true);
    const torch::Tensor p = xyz / d.clamp_min(1e-8) * torch::expm1(d);
    *pts = ToView(p[0]);
    *conf = ToView(DenseConf(f.select(3, 3), cfg.conf_min, cfg.conf_max)[0]);
  }

  // mast3r/catmlp_dpt_head.py: MLP on [enc_norm tokens ‖ dec_norm(last decoder block)], pixel_shuffle(p) to the
  // full resolution; mast3r/model.py postprocess: desc = f/‖f‖ (desc_mode 'norm', no epsilon), desc_conf =
  // reg_dense_conf(desc_conf_mode) of the last channel (two_confs) or a copy of conf.
  void LocalFeatures(int which, const torch::Tensor& enc, const torch::Tensor& dec, int64_t h, int64_t w, int view,
                     const io::TensorView& conf, io::TensorView* desc, io::TensorView* desc_conf) const {
    const std::string tp = "head" + std::to_string(view) + ".";
    const int64_t P = cfg.patch_size, D = cfg.local_feat_dim;
    const torch::Tensor in = torch::cat({enc, dec}, -1);  // [1, N, Ce + Cd]
    Tap(tp + "mlp_in", in);
    const torch::Tensor hidden = local[which].fc1.Gelu(in, prec);
    Tap(tp + "mlp_hidden", hidden);
    const torch::Tensor out = local[which].fc2(hidden, prec);  // [1, N, (D + T)·P²]
    Tap(tp + "mlp_out", out);
    const int64_t C = out.size(2) / (P * P);  // D + T
    if (taps) Tap(tp + "local", torch::pixel_shuffle(out.transpose(1, 2).reshape({1, out.size(2), h, w}), P));
    // pixel_shuffle(P) straight to channels-last: token (y, x)'s channel c·P² + i·P + j is pixel (y·P + i, x·P + j)'s
    // channel c — one gather into [H, W, D + T], where the NCHW shuffle took a transpose copy, the shuffle's copy and a
    // norm over a strided dimension.
    const torch::Tensor hwc = out.reshape({h, w, C, P, P}).permute({0, 3, 1, 4, 2}).reshape({h * P, w * P, C});
    const torch::Tensor f = hwc.slice(2, 0, D);  // H, W, D
    *desc = ToView(f / f.norm(2, -1, true));
    if (cfg.two_confs)
      *desc_conf = ToView(DenseConf(hwc.select(2, D), cfg.desc_conf_min, cfg.desc_conf_max));
    else
      *desc_conf = conf;
  }

  Dust3rPrediction Decode(const Encoding& e1, const Encoding& e2, const DecodeOutputs& want) const {
    torch::NoGradGuard ng;
    Dust3rPrediction out;
    auto t0 = std::chrono::steady_clock::now();
    const Rope r1 = rope.Tables(e1.h, e1.w, cfg.dec_dim / cfg.dec_heads, device);
    const Rope r2 = rope.Tables(e2.h, e2.w, cfg.dec_dim / cfg.dec_heads, device);
    // AsymmetricCroCo3DStereo._decoder: shared decoder_embed, simultaneous updates of both stacks.
    std::vector<torch::Tensor> l1 = {e1.tokens}, l2 = {e2.tokens};
    torch::Tensor f1 = dec_embed(e1.tokens, prec), f2 = dec_embed(e2.tokens, prec);
    Tap("dec1.embed", f1);
    Tap("dec2.embed", f2);
    for (size_t i = 0; i < dec1.size(); ++i) {
      const torch::Tensor n1 = dec1[i](f1, f2, r1, r2, prec);
      const torch::Tensor n2 = dec2[i](f2, f1, r2, r1, prec);
      f1 = n1;
      f2 = n2;
      char b[32];
      std::snprintf(b, sizeof(b), "block%02d", static_cast<int>(i));
      Tap(std::string("dec1.") + b, f1);
      Tap(std::string("dec2.") + b, f2);
      l1.push_back(f1);
      l2.push_back(f2);
    }
    l1.back() = dec_norm(l1.back());
    l2.back() = dec_norm(l2.back());
    Tap("dec1.out", l1.back());
    Tap("dec2.out", l2.back());
    out.decode_ms = Ms(t0);
    t0 = std::chrono::steady_clock::now();
    const bool desc = want.descriptors && cfg.is_mast3r();
    if (want.view1) {
      Postprocess(RunHead(0, l1, e1.h, e1.w, 1), &out.pts3d_1, &out.conf_1);
      if (desc) LocalFeatures(0, e1.tokens, l1.back(), e1.h, e1.w, 1, out.conf_1, &out.desc_1, &out.desc_conf_1);
    }
    if (want.view2) {
      Postprocess(RunHead(1, l2, e2.h, e2.w, 2), &out.pts3d_2, &out.conf_2);
      if (desc) LocalFeatures(1, e2.tokens, l2.back(), e2.h, e2.w, 2, out.conf_2, &out.desc_2, &out.desc_conf_2);
    }
    out.heads_ms = Ms(t0);
    return out;
  }
};

namespace {

std::map<std::string, std::string> KwargsFromJson(const nlohmann::json& j) {
  std::map<std::string, std::string> kw;
  const nlohmann::json& a = j.contains("constructor_args") ? j["constructor_args"] : j;
  for (auto it = a.begin(); it != a.end(); ++it) {
    if (it.value().is_string())
      kw[it.key()] = it.value().get<std::string>();
    else if (it.value().is_number_integer())
      kw[it.key()] = std::to_string(it.value().get<int64_t>());
    else
      kw[it.key()] = it.value().dump();
  }
  return kw;
}

}  // namespace

Dust3rModel::Dust3rModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Dust3rModel::~Dust3rModel() = default;
const Dust3rConfig& Dust3rModel::config() const { return impl_->cfg; }
const RuntimeOptions& Dust3rModel::runtime() const { return impl_->rt; }
void Dust3rModel::SetTapSink(std::map<std::string, io::TensorView>* sink) const { impl_->taps = sink; }

std::shared_ptr<Dust3rModel> Dust3rModel::Load(const std::string& model_path, const std::string& config_path,
                                               const RuntimeOptions& runtime) {
  ApplyRuntime(runtime);
  const io::Checkpoint ckpt = io::Checkpoint::Open(model_path);
  const auto sd = ckpt.StateDict({"model", ""});
  FREELOC_CHECK(!sd.empty(), model_path << ": no tensors found; expected DUSt3R weights");
  // Constructor arguments: explicit config, the .pth's args.model, or a config.json beside the weights.
  std::map<std::string, std::string> kw;
  std::string source = "released defaults";
  std::string cfg_file = config_path;
  if (cfg_file.empty()) {
    const auto sibling = std::filesystem::path(model_path).parent_path() / "config.json";
    if (ckpt.format() == io::Checkpoint::Format::kSafetensors && std::filesystem::exists(sibling))
      cfg_file = sibling.string();
  }
  if (!cfg_file.empty()) {
    const std::string text = ReadModelConfig(model_path, cfg_file, true, "DUSt3R/MASt3R");
    const nlohmann::json j = ParseModelConfig(text, cfg_file, "DUSt3R/MASt3R");
    FREELOC_CHECK(j.is_object(), cfg_file << ": the DUSt3R/MASt3R config is not a JSON object");
    kw = KwargsFromJson(j);
    source = cfg_file;
  } else if (const std::string m = ckpt.MetadataOr("args.model", ""); !m.empty()) {
    // load_model(): ManyAR_PatchEmbed → PatchEmbedDust3R and landscape_only=False (the native path).
    kw = ParseConstructorKwargs(m);
    source = model_path + " (args.model)";
  }
  return Create(sd, kw, source, runtime, model_path);
}

std::shared_ptr<Dust3rModel> Dust3rModel::Create(const std::map<std::string, io::TensorView>& sd,
                                                 const std::map<std::string, std::string>& kw,
                                                 const std::string& source, const RuntimeOptions& runtime,
                                                 const std::string& weights) {
  ApplyRuntime(runtime);
  const std::string& model_path = weights.empty() ? source : weights;  // weight errors name the weights file
  auto impl = std::make_unique<Impl>();
  impl->cfg = MakeDust3rConfig(sd, kw, source);
  impl->rt = runtime;
  impl->device = DeviceOf(runtime);
  impl->prec.bf16 = internal::RunBf16(runtime);  // asked for, and pays here (bf16_linear.h)
  impl->rope = Rope2D(impl->cfg.rope_base);
  const Dust3rConfig& c = impl->cfg;
  std::map<std::string, torch::Tensor> tensors;
  for (const auto& [k, v] : sd) tensors[k] = ToTorch(v);
  AddSecondDecoder(&tensors);
  WeightStore ws(std::move(tensors), model_path, impl->device, impl->prec.bf16);
  const PrecisionPolicy& p = impl->prec;
  impl->patch.Load(ws, "patch_embed.proj", {c.enc_dim, 3, c.patch_size, c.patch_size}, true, c.patch_size, 0, false, p);
  impl->enc.resize(static_cast<size_t>(c.enc_depth));
  for (int i = 0; i < c.enc_depth; ++i) {
    const std::string pre = "enc_blocks." + std::to_string(i);
    EncBlock& b = impl->enc[static_cast<size_t>(i)];
    b.n1.Load(ws, pre + ".norm1", c.enc_dim, c.ln_eps);
    b.attn.Load(ws, pre + ".attn", c.enc_dim, c.enc_heads, p);
    b.n2.Load(ws, pre + ".norm2", c.enc_dim, c.ln_eps);
    b.mlp.Load(ws, pre + ".mlp", c.enc_dim, c.enc_mlp, p);
  }
  impl->enc_norm.Load(ws, "enc_norm", c.enc_dim, c.ln_eps);
  impl->dec_embed.Load(ws, "decoder_embed", c.dec_dim, c.enc_dim, true, p);
  for (int s = 0; s < 2; ++s) {
    auto& stack = s == 0 ? impl->dec1 : impl->dec2;
    stack.resize(static_cast<size_t>(c.dec_depth));
    for (int i = 0; i < c.dec_depth; ++i) {
      const std::string pre = (s == 0 ? "dec_blocks." : "dec_blocks2.") + std::to_string(i);
      DecBlock& b = stack[static_cast<size_t>(i)];
      b.n1.Load(ws, pre + ".norm1", c.dec_dim, c.ln_eps);
      b.attn.Load(ws, pre + ".attn", c.dec_dim, c.dec_heads, p);
      b.cross.Load(ws, pre + ".cross_attn", c.dec_dim, c.dec_heads, p);
      b.n2.Load(ws, pre + ".norm2", c.dec_dim, c.ln_eps);
      b.n3.Load(ws, pre + ".norm3", c.dec_dim, c.ln_eps);
      b.ny.Load(ws, pre + ".norm_y", c.dec_dim, c.ln_eps);
      b.mlp.Load(ws, pre + ".mlp", c.dec_dim, c.dec_mlp, p);
    }
  }
  impl->dec_norm.Load(ws, "dec_norm", c.dec_dim, c.ln_eps);
  for (int h = 0; h < 2; ++h) LoadDptHead(ws, c, h, impl->prec, &impl->head[h]);
  if (c.is_mast3r()) {
    const int64_t rows = static_cast<int64_t>(c.local_feat_dim + (c.two_confs ? 1 : 0)) * c.patch_size * c.patch_size;
    for (int h = 0; h < 2; ++h) {
      const std::string pre = "downstream_head" + std::to_string(h + 1) + ".head_local_features.";
      impl->local[h].fc1.Load(ws, pre + "fc1", c.local_mlp_hidden, c.enc_dim + c.dec_dim, true, impl->prec);
      impl->local[h].fc2.Load(ws, pre + "fc2", rows, c.local_mlp_hidden, true, impl->prec);
    }
  }
  ws.Ignore("mask_token");
  ws.Finish();
  if (c.is_mast3r())  // the desc_conf mode in effect matters (a missing desc_conf_mode falls back to conf_mode)
    FREELOC_LOG(INFO) << "loaded " << c.Summary() << " from " << model_path << " (" << source << ")";
  else
    FREELOC_LOG(DEBUG) << "loaded " << c.Summary() << " from " << model_path << " (" << source << ")";
  return std::shared_ptr<Dust3rModel>(new Dust3rModel(std::move(impl)));
}

std::shared_ptr<const Dust3rModel::Encoding> Dust3rModel::Encode(const Dust3rView& view) const {
  return EncodeView(view, 1);
}

std::shared_ptr<const Dust3rModel::Encoding> Dust3rModel::EncodeView(const Dust3rView& view, int tap_id) const {
  torch::NoGradGuard ng;
  const auto t0 = std::chrono::steady_clock::now();
  auto e = std::make_shared<Encoding>();
  e->h = view.height / impl_->cfg.patch_size;
  e->w = view.width / impl_->cfg.patch_size;
  e->height = view.height;
  e->width = view.width;
  e->tokens = impl_->EncodeBatch(impl_->ToInput(view), e->h, e->w, {tap_id});
  e->ms = Ms(t0);
  return e;
}

Dust3rPrediction Dust3rModel::Decode(const Encoding& a, const Encoding& b, const DecodeOutputs& outputs) const {
  Dust3rPrediction p = impl_->Decode(a, b, outputs);
  p.encode_ms = a.ms + b.ms;
  return p;
}

Dust3rPrediction Dust3rModel::Run(const Dust3rView& v1, const Dust3rView& v2) const {
  // Each view is encoded on its own (upstream batches same-shape pairs; the results agree within float rounding),
  // so the one-shot path and the cached-reference path give identical outputs.
  const auto e1 = EncodeView(v1, 1);
  const auto e2 = EncodeView(v2, 2);
  return Decode(*e1, *e2, {});
}

}  // namespace freeloc::nn
