// SegGPT forward pass. Blocks cite the upstream functions (baaivision/Painter SegGPT_inference models_seggpt.py,
// util/vitdet_utils.py) they reproduce.
#include "freeloc/nn/seggpt.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/io/checkpoint.h"
#include "freeloc/nn/internal/bf16_linear.h"
#include "freeloc/nn/internal/layers.h"
#include "freeloc/nn/internal/torch_util.h"

namespace freeloc::nn {

using namespace internal;  // NOLINT

std::string SegGptConfig::Summary() const {
  std::ostringstream os;
  os << "SegGPT " << depth << "×" << embed_dim << " (" << heads << " heads, MLP " << mlp << "), input " << 2 * half
     << "×" << half << " (grid " << grid_h << "×" << grid_w << "), merge after block " << merge_index << ", taps [";
  for (size_t i = 0; i < out_indices.size(); ++i) os << (i ? "," : "") << out_indices[i];
  os << "], decoder " << decoder_dim;
  return os.str();
}

SegType ParseSegType(const std::string& s) {
  if (s == "instance") return SegType::kInstance;
  if (s == "semantic") return SegType::kSemantic;
  FREELOC_THROW("segmentation type '" << s << "' is unknown; use instance or semantic");
}

namespace {

// vitdet_utils.get_rel_pos, first half: the relative table [2·max(q, k) − 1, hd], linearly interpolated when its
// length differs.
torch::Tensor RelTable(int64_t q, int64_t k, const torch::Tensor& rel) {
  const int64_t max_dist = 2 * std::max(q, k) - 1;
  if (rel.size(0) == max_dist) return rel;
  return torch::upsample_linear1d(rel.reshape({1, rel.size(0), -1}).permute({0, 2, 1}), {max_dist}, false)
      .reshape({-1, max_dist})
      .permute({1, 0});
}

// vitdet_utils.get_rel_pos: the table for q_size × k_size, [q, k, hd].
torch::Tensor GetRelPos(int64_t q, int64_t k, const torch::Tensor& rel) {
  const torch::Tensor r = RelTable(q, k, rel);
  const torch::Tensor qc = torch::arange(q, torch::kFloat64).unsqueeze(1) * std::max(static_cast<double>(k) / q, 1.0);
  const torch::Tensor kc = torch::arange(k, torch::kFloat64).unsqueeze(0) * std::max(static_cast<double>(q) / k, 1.0);
  const torch::Tensor idx = (qc - kc + (k - 1) * std::max(static_cast<double>(q) / k, 1.0)).to(torch::kLong);
  return r.index({idx.to(r.device())});  // [q, k, hd]
}

struct Block {
  LayerNorm n1, n2;
  Linear qkv, proj;
  torch::Tensor rel_h, rel_w;
  Mlp mlp;
  int64_t heads = 1;
  // bf16 on the CPU: the relative tables of the model's token grid, prepacked (q is bf16 already: bf16 products,
  // fp32 accumulation and output, as every other product of q).
  std::shared_ptr<PackedLinearBf16> rel_h_packed, rel_w_packed;
  int64_t packed_h = 0, packed_w = 0;

  void PackRelTables(int64_t H, int64_t W) {
    rel_h_packed = std::make_shared<PackedLinearBf16>(RelTable(H, H, rel_h).contiguous(), torch::Tensor());
    rel_w_packed = std::make_shared<PackedLinearBf16>(RelTable(W, W, rel_w).contiguous(), torch::Tensor());
    packed_h = H;
    packed_w = W;
  }

  // models_seggpt.Attention with use_rel_pos (vitdet add_decomposed_rel_pos): logits = (q·scale)·kᵀ + rel terms of the
  // UNSCALED q, global over all tokens.
  torch::Tensor Attend(const torch::Tensor& x, const PrecisionPolicy& p) const {
    const int64_t B = x.size(0), H = x.size(1), W = x.size(2), C = x.size(3), hd = C / heads, N = H * W;
    const double scale = std::pow(static_cast<double>(hd), -0.5);
    if (UseFusedAttention(x.device())) {
      // q/k/v as views into the projection (bf16 when it runs bf16); the rel terms of the unscaled q added inside the
      // fused pass, given by relative offset: q times each relative table is one GEMM (N × (2H − 1) and N × (2W − 1)
      // per head), where the per-pair tables [H, H, hd] needed a batched product per query row and its copies.
      const torch::Tensor t = qkv.ForProducts(x, p).reshape({B, N, 3, heads, hd}).permute({2, 0, 3, 1, 4});
      AttentionExtras e;
      if (p.bf16 && rel_h_packed && H == packed_h && W == packed_w) {
        e.rel_h = (*rel_h_packed)(t[0]).reshape({B * heads, N, -1});
        e.rel_w = (*rel_w_packed)(t[0]).reshape({B * heads, N, -1});
      } else {
        const torch::Tensor rq = t[0].to(torch::kFloat32).reshape({B * heads, N, hd});
        e.rel_h = torch::matmul(rq, RelTable(H, H, rel_h).t());
        e.rel_w = torch::matmul(rq, RelTable(W, W, rel_w).t());
      }
      e.rel_by_offset = true;
      e.rel_key_w = W;
      return proj(
          FusedAttention(t[0], t[1], t[2], scale, e, p.bf16, AttentionIsa::kAuto, proj.TakesBf16(p)).view({B, H, W, C}),
          p);
    }
    const torch::Tensor Rh = GetRelPos(H, H, rel_h), Rw = GetRelPos(W, W, rel_w);
    const torch::Tensor t =
        qkv(x, p).reshape({B, N, 3, heads, hd}).permute({2, 0, 3, 1, 4}).reshape({3, B * heads, N, hd});
    const torch::Tensor q = t[0], k = t[1], v = t[2];
    // Heads in chunks whose N×N logits stay under ~16 MB: large blocks are then reused from the heap instead of
    // being mapped and faulted in for every block (the full 16-head map is 157 MB at 1568 tokens).
    const int64_t per = std::max<int64_t>(1, (int64_t{16} << 20) / (N * N * 4));
    torch::Tensor o = torch::empty({B * heads, N, hd}, q.options());
    for (int64_t h0 = 0; h0 < B * heads; h0 += per) {
      const int64_t h1 = std::min(B * heads, h0 + per);
      const torch::Tensor qc = q.slice(0, h0, h1), kc = k.slice(0, h0, h1), vc = v.slice(0, h0, h1);
      torch::Tensor attn = torch::matmul(qc * scale, kc.transpose(-2, -1));
      const torch::Tensor rq = qc.reshape({h1 - h0, H, W, hd});
      const torch::Tensor relh = torch::einsum("bhwc,hkc->bhwk", {rq, Rh});
      const torch::Tensor relw = torch::einsum("bhwc,wkc->bhwk", {rq, Rw});
      attn.view({h1 - h0, H, W, H, W}).add_(relh.unsqueeze(4)).add_(relw.unsqueeze(3));
      o.slice(0, h0, h1).copy_(torch::matmul(torch::softmax(attn, -1), vc));
    }
    o = o.view({B, heads, H, W, hd}).permute({0, 2, 3, 1, 4}).reshape({B, H, W, C});
    return proj(o, p);
  }
};

}  // namespace

struct SegGptModel::Impl {
  SegGptConfig cfg;
  RuntimeOptions rt;
  torch::Device device = torch::kCPU;
  PrecisionPolicy prec;
  Conv patch;
  torch::Tensor mask_token, seg_x, seg_y, type_cls, type_ins, pos_embed;
  std::vector<Block> blocks;
  LayerNorm norm;
  Linear dec_embed;
  Conv dec_conv, dec_head;
  LayerNorm dec_ln;  // decoder_pred.1
  mutable std::map<std::string, io::TensorView>* taps = nullptr;
  void Tap(const std::string& n, const torch::Tensor& t) const {
    if (taps) (*taps)[n] = ToView(t);
  }

  // `shared_image`: every item's image pair is the same (one reference and one query, K prompts' masks — the
  // pipeline's instance propagation). The image stream is then computed once up to the merge, where it meets each
  // item's mask stream: the same values for a K-th of that work (3 of SegGPT-L's 24 blocks run at 2K items).
  torch::Tensor Forward(const torch::Tensor& imgs, const torch::Tensor& tgts, SegType type, bool ensemble,
                        bool shared_image = false) const {
    const int64_t K = tgts.size(0), Hg = cfg.grid_h, Wg = cfg.grid_w, C = cfg.embed_dim;
    const bool one_image = shared_image && !ensemble && K > 1;
    // forward_encoder: shared patch embedding (channels-last tokens).
    torch::Tensor x = patch(one_image ? imgs.slice(0, 0, 1) : imgs, prec).permute({0, 2, 3, 1});
    torch::Tensor y = patch(tgts, prec).permute({0, 2, 3, 1});
    // bool_masked_pos: the bottom half of the token grid (the target half) of the mask stream only.
    torch::Tensor w = torch::zeros({1, Hg, Wg, 1}, torch::TensorOptions().device(device));
    w.slice(1, Hg / 2, Hg).fill_(1.0);
    y = y * (1 - w) + mask_token.reshape({1, 1, 1, C}) * w;
    x = x + seg_x.reshape({1, 1, 1, C});
    y = y + seg_y.reshape({1, 1, 1, C});
    // get_abs_pos: bicubic, size-based, align_corners=False, cls entry dropped.
    const int64_t G = cfg.pos_grid;
    torch::Tensor pos = pos_embed.slice(1, 1, 1 + G * G).reshape({1, G, G, C}).permute({0, 3, 1, 2});
    pos = torch::upsample_bicubic2d(pos, {Hg, Wg}, false).permute({0, 2, 3, 1});
    Tap("pos_embed_resized", pos);
    x = x + pos;
    y = y + pos;
    const torch::Tensor tt = (type == SegType::kInstance ? type_ins : type_cls).reshape({1, 1, 1, C});
    x = x + tt;
    y = y + tt;
    x = torch::cat({x, y}, 0);  // [2K, Hg, Wg, C]: image stream, then mask stream
    Tap("embeddings", x);
    std::vector<torch::Tensor> feats;
    for (size_t idx = 0; idx < blocks.size(); ++idx) {
      const Block& b = blocks[idx];
      torch::Tensor a = b.Attend(b.n1.ForProducts(x, prec), prec);
      if (ensemble) {
        // Block.forward feature ensemble on the attention output's query half: per stream up to merge_index,
        // over the whole batch afterwards.
        const int merge = static_cast<int>(idx) <= cfg.merge_index ? 1 : 2;
        torch::Tensor top = a.slice(1, 0, Hg / 2), bottom = a.slice(1, Hg / 2, Hg);
        if (merge == 1) {
          const int64_t B = bottom.size(0);
          const auto sz = bottom.sizes().vec();
          std::vector<int64_t> v = {2, B / 2};
          v.insert(v.end(), sz.begin() + 1, sz.end());
          bottom = bottom.reshape(v).mean(1, true).expand(v).reshape(sz);
        } else {
          bottom = bottom.mean(0, true).expand_as(bottom);
        }
        a = torch::cat({top, bottom}, 1);
      }
      const torch::Tensor h = b.n2.AddForProducts(&x, a, prec);
      x = x + b.mlp(h, prec);
      if (idx == 0) Tap("block0_out", x);
      if (static_cast<int>(idx) == cfg.merge_index) {
        const int64_t images = one_image ? 1 : K;  // the image stream's items, then the K mask-stream items
        x = (x.slice(0, 0, images) + x.slice(0, images, x.size(0))) * 0.5;
        Tap("merged", x);
      }
      if (std::find(cfg.out_indices.begin(), cfg.out_indices.end(), static_cast<int>(idx)) != cfg.out_indices.end())
        feats.push_back(norm(x));
    }
    const torch::Tensor feat = torch::cat(feats, -1);
    Tap("decoder_input", feat);
    // forward_decoder one item at a time: its full-resolution activations (decoder_dim × 896 × 448, 100 MB each in
    // fp32) made a batch of 4 the query's memory peak, and batching them bought no speed on the CPU.
    std::vector<torch::Tensor> out;
    std::vector<torch::Tensor> shuffled;
    for (int64_t k = 0; k < K; ++k) out.push_back(Decode(feat.slice(0, k, k + 1), taps ? &shuffled : nullptr));
    if (taps) Tap("decoder_pixel_shuffled", torch::cat(shuffled, 0));
    return torch::cat(out, 0);
  }

  // forward_decoder: decoder_embed, pixel shuffle nhwpqc → nchpwq, conv3×3 → LayerNorm2D → GELU → conv1×1. The
  // shuffle writes channels-last (n, h·p, w·q, c): whole runs of D channels move, where the NCHW order moved single
  // values (10× the time), and the 3×3 convolution — a Conv::Chain link, bf16 channels-last in bf16 — reads it as it
  // is; in bf16 the embedding's output is bf16 already (it only feeds that convolution). The LayerNorm then reads
  // the convolution's output as NHWC without a copy.
  torch::Tensor Decode(const torch::Tensor& feat, std::vector<torch::Tensor>* shuffled) const {
    const int64_t Hg = cfg.grid_h, Wg = cfg.grid_w, p = cfg.patch, D = cfg.decoder_dim;
    torch::Tensor d = dec_embed.ForProducts(feat, prec).reshape({1, Hg, Wg, p, p, D});
    d = d.permute({0, 1, 3, 2, 4, 5}).reshape({1, Hg * p, Wg * p, D}).permute({0, 3, 1, 2});  // NCHW, channels-last
    if (shuffled) shuffled->push_back(d.to(torch::kFloat32).contiguous());
    d = dec_conv.Chain(d);
    // Norm + GELU (bf16 on the CPU: one pass, written in bf16 for the bf16 1×1 head; else LibTorch's fp32 ops).
    d = dec_ln.GeluForProducts(d.permute({0, 2, 3, 1}), prec).permute({0, 3, 1, 2});
    return dec_head(d, prec);
  }
};

namespace {

// HF (BAAI/seggpt-vit-large) names → original names (baaivision/Painter SegGPT, fixtures/seggpt/README §8).
std::string FromHfName(const std::string& n) {
  static const std::vector<std::pair<std::string, std::string>> kPrefix = {
      {"model.embeddings.patch_embeddings.projection.", "patch_embed.proj."},
      {"model.embeddings.mask_token", "mask_token"},
      {"model.embeddings.segment_token_input", "segment_token_x"},
      {"model.embeddings.segment_token_prompt", "segment_token_y"},
      {"model.embeddings.type_token_semantic", "type_token_cls"},
      {"model.embeddings.type_token_instance", "type_token_ins"},
      {"model.embeddings.position_embeddings", "pos_embed"},
      {"model.encoder.layernorm.", "norm."},
      {"decoder.decoder_embed.", "decoder_embed."},
      {"decoder.decoder_pred.conv.", "decoder_pred.0."},
      {"decoder.decoder_pred.layernorm.", "decoder_pred.1."},
      {"decoder.decoder_pred.head.", "decoder_pred.3."},
  };
  for (const auto& [a, b] : kPrefix)
    if (n.rfind(a, 0) == 0) return b + n.substr(a.size());
  const std::string layers = "model.encoder.layers.";
  if (n.rfind(layers, 0) == 0) {
    const size_t dot = n.find('.', layers.size());
    const std::string i = n.substr(layers.size(), dot - layers.size());
    std::string rest = n.substr(dot + 1);
    static const std::vector<std::pair<std::string, std::string>> kBlock = {{"attention.", "attn."},
                                                                            {"mlp.lin1.", "mlp.fc1."},
                                                                            {"mlp.lin2.", "mlp.fc2."},
                                                                            {"layernorm_before.", "norm1."},
                                                                            {"layernorm_after.", "norm2."}};
    for (const auto& [a, b] : kBlock)
      if (rest.rfind(a, 0) == 0) rest = b + rest.substr(a.size());
    return "blocks." + i + "." + rest;
  }
  return n;
}

int JsonInt(const nlohmann::json& j, std::initializer_list<const char*> keys, int fallback) {
  for (const char* k : keys)
    if (j.contains(k) && j[k].is_number_integer()) return j[k].get<int>();
  return fallback;
}

}  // namespace

SegGptModel::SegGptModel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SegGptModel::~SegGptModel() = default;
const SegGptConfig& SegGptModel::config() const { return impl_->cfg; }
void SegGptModel::SetTapSink(std::map<std::string, io::TensorView>* sink) const { impl_->taps = sink; }

std::shared_ptr<SegGptModel> SegGptModel::Load(const std::string& model_path, const std::string& config_path,
                                               const RuntimeOptions& runtime) {
  const io::Checkpoint ckpt = io::Checkpoint::Open(model_path);
  auto sd = ckpt.StateDict({"model", ""});
  const std::string json =
      ReadModelConfig(model_path, config_path, ckpt.format() == io::Checkpoint::Format::kSafetensors, "SegGPT");
  return Create(sd, json, model_path, runtime);
}

namespace {

// The architecture from the tensors' shapes and the config (HF or Painter key names).
SegGptConfig ConfigFromTensors(const std::map<std::string, torch::Tensor>& tensors, const nlohmann::json& j,
                               const std::string& source) {
  auto shape = [&](const std::string& n) {
    auto it = tensors.find(n);
    FREELOC_CHECK(it != tensors.end(), source << ": tensor '" << n << "' is missing; is this a SegGPT checkpoint?");
    return it->second.sizes().vec();
  };
  SegGptConfig c;
  c.source = source;
  const auto pe = shape("patch_embed.proj.weight");
  c.embed_dim = static_cast<int>(pe[0]);
  c.patch = static_cast<int>(pe[2]);
  c.depth = 0;
  while (tensors.count("blocks." + std::to_string(c.depth) + ".norm1.weight")) ++c.depth;
  c.mlp = static_cast<int>(shape("blocks.0.mlp.fc1.weight")[0]);
  c.pos_grid = static_cast<int>(std::lround(std::sqrt(static_cast<double>(shape("pos_embed")[1] - 1))));
  c.decoder_dim = static_cast<int>(shape("decoder_pred.0.weight")[0]);
  c.heads = JsonInt(j, {"num_heads", "num_attention_heads"}, 16);
  c.merge_index = JsonInt(j, {"merge_index"}, 2);
  for (const char* key : {"out_indices", "intermediate_hidden_state_indices"})
    if (j.contains(key)) c.out_indices = j[key].get<std::vector<int>>();
  c.ln_eps = j.value("norm_layer_eps", j.value("layer_norm_eps", 1e-6));
  // Input size: img_size / image_size = [2S, S]; else from the relative-position table (2·Hg − 1 rows).
  std::vector<int> img;
  for (const char* key : {"img_size", "image_size"})
    if (j.contains(key) && j[key].is_array()) img = j[key].get<std::vector<int>>();
  if (img.size() == 2) {
    FREELOC_CHECK(img[0] == 2 * img[1], source << ": img_size " << img[0] << "×" << img[1] << " must be (2S, S)");
    c.half = img[1];
  } else {
    c.half = static_cast<int>((shape("blocks.0.attn.rel_pos_h")[0] + 1) / 2 * c.patch / 2);
  }
  c.grid_h = 2 * c.half / c.patch;
  c.grid_w = c.half / c.patch;
  FREELOC_CHECK(c.half % c.patch == 0,
                source << ": half size " << c.half << " is not a multiple of the patch " << c.patch);
  FREELOC_CHECK(c.embed_dim % c.heads == 0,
                source << ": embed_dim " << c.embed_dim << " not divisible by " << c.heads << " heads");
  FREELOC_CHECK(c.merge_index >= 0 && c.merge_index < c.depth,
                source << ": merge_index " << c.merge_index << " outside the blocks");
  for (int i : c.out_indices)
    FREELOC_CHECK(i >= 0 && i < c.depth, source << ": out index " << i << " outside the blocks");
  return c;
}

}  // namespace

std::shared_ptr<SegGptModel> SegGptModel::Create(const std::map<std::string, io::TensorView>& sd_in,
                                                 const std::string& config_json, const std::string& source,
                                                 const RuntimeOptions& runtime) {
  ApplyRuntime(runtime);
  const nlohmann::json j = ParseModelConfig(config_json, source, "SegGPT");
  std::map<std::string, torch::Tensor> tensors;
  for (const auto& [k, v] : sd_in) tensors[FromHfName(k)] = ToTorch(v);
  auto impl = std::make_unique<Impl>();
  impl->cfg = ConfigFromTensors(tensors, j, source);
  const SegGptConfig& c = impl->cfg;
  const int64_t hd_dim = c.embed_dim / c.heads;
  const int64_t dec_in = static_cast<int64_t>(c.out_indices.size()) * c.embed_dim;
  impl->rt = runtime;
  impl->device = DeviceOf(runtime);
  impl->prec.bf16 = internal::RunBf16(runtime);  // asked for, and pays here (bf16_linear.h)
  WeightStore ws(std::move(tensors), source, impl->device, impl->prec.bf16);
  const PrecisionPolicy& p = impl->prec;
  const int64_t C = c.embed_dim;
  impl->patch.Load(ws, "patch_embed.proj", {C, 3, c.patch, c.patch}, true, c.patch, 0, false, p);
  impl->mask_token = ws.Take("mask_token", {1, 1, 1, C});
  impl->seg_x = ws.Take("segment_token_x", {1, 1, 1, C});
  impl->seg_y = ws.Take("segment_token_y", {1, 1, 1, C});
  impl->type_cls = ws.Take("type_token_cls", {1, 1, 1, C});
  impl->type_ins = ws.Take("type_token_ins", {1, 1, 1, C});
  impl->pos_embed = ws.Take("pos_embed", {1, static_cast<int64_t>(c.pos_grid) * c.pos_grid + 1, C});
  impl->blocks.resize(static_cast<size_t>(c.depth));
  for (int i = 0; i < c.depth; ++i) {
    const std::string pre = "blocks." + std::to_string(i);
    Block& b = impl->blocks[static_cast<size_t>(i)];
    b.heads = c.heads;
    b.n1.Load(ws, pre + ".norm1", C, c.ln_eps);
    b.qkv.Load(ws, pre + ".attn.qkv", 3 * C, C, true, p);
    b.proj.Load(ws, pre + ".attn.proj", C, C, true, p);
    b.rel_h = ws.Take(pre + ".attn.rel_pos_h", {-1, hd_dim});
    b.rel_w = ws.Take(pre + ".attn.rel_pos_w", {-1, hd_dim});
    if (p.bf16 && b.rel_h.device().is_cpu()) b.PackRelTables(c.grid_h, c.grid_w);
    b.n2.Load(ws, pre + ".norm2", C, c.ln_eps);
    b.mlp.Load(ws, pre + ".mlp", C, c.mlp, p);
  }
  impl->norm.Load(ws, "norm", C, c.ln_eps);
  impl->dec_embed.Load(ws, "decoder_embed", static_cast<int64_t>(c.patch) * c.patch * c.decoder_dim, dec_in, true, p);
  impl->dec_conv.Load(ws, "decoder_pred.0", {c.decoder_dim, c.decoder_dim, 3, 3}, true, 1, 1, false, p);
  impl->dec_conv.ForChains();  // a Chain link only
  impl->dec_ln.Load(ws, "decoder_pred.1", c.decoder_dim, c.ln_eps);
  impl->dec_head.Load(ws, "decoder_pred.3", {3, c.decoder_dim, 1, 1}, true, 1, 0, false, p);
  ws.Finish();
  return std::shared_ptr<SegGptModel>(new SegGptModel(std::move(impl)));
}

io::TensorView SegGptModel::Forward(const std::vector<float>& imgs, const std::vector<float>& tgts, int k, SegType type,
                                    bool ensemble) const {
  torch::NoGradGuard ng;
  const int S = impl_->cfg.half;
  const size_t item = static_cast<size_t>(3) * 2 * S * S;
  FREELOC_CHECK(k >= 1 && imgs.size() == item * k && tgts.size() == item * k,
                "SegGPT: inputs must be [K, 3, " << 2 * S << ", " << S << "] for this model");
  const auto opts = torch::TensorOptions().dtype(torch::kFloat32);
  const torch::Tensor a = torch::from_blob(const_cast<float*>(imgs.data()), {k, 3, 2 * S, S}, opts).to(impl_->device);
  const torch::Tensor b = torch::from_blob(const_cast<float*>(tgts.data()), {k, 3, 2 * S, S}, opts).to(impl_->device);
  bool shared = true;
  for (int i = 1; i < k && shared; ++i)
    shared = std::equal(imgs.begin(), imgs.begin() + static_cast<std::ptrdiff_t>(item),
                        imgs.begin() + static_cast<std::ptrdiff_t>(item * i));
  return ToView(impl_->Forward(a.clone(), b.clone(), type, ensemble, shared));
}

vision::SegGptMask SegGptModel::Segment(const std::vector<Image>& prompt_images, const std::vector<Image>& prompt_masks,
                                        const Image& target, SegType type, io::TensorView* raw_pred) const {
  const vision::SegGptInputs in = vision::PrepareSegGptInputs(prompt_images, prompt_masks, target, impl_->cfg.half);
  // run_one_image: the ensemble is on exactly when there are several prompts.
  const io::TensorView pred = Forward(in.imgs, in.tgts, in.k, type, in.k > 1);
  if (raw_pred) *raw_pred = pred;
  return vision::PostprocessSegGpt(pred.as<float>(), in.half, target.width, target.height);
}

}  // namespace freeloc::nn
