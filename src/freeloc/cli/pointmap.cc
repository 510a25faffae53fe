// `freeloc pointmap`: DUSt3R or MASt3R pointmaps of an image pair — preprocessing (load_images policy), the
// network, and a safetensors file with pts3d_1/conf_1 (view 1), pts3d_2/conf_2 (view 2 in view 1's frame), for a
// MASt3R model also desc_1/desc_conf_1/desc_2/desc_conf_2, the preprocessed crops and metadata (model, size,
// precision, timings). With --matches: DUSt3R's reciprocal 3D matches, or MASt3R's fast reciprocal NN matches (raw,
// upstream order) and the filtered ones in original pixels.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <sstream>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/vision/dust3r_preprocess.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/matching/fast_nn.h"
#include "freeloc/matching/pixel_mapping.h"
#include "freeloc/matching/reciprocal.h"
#include "freeloc/nn/dust3r.h"

namespace freeloc::cli {

namespace {

struct PointmapOptions {
  std::string model, config, size = "512", out;
  std::vector<std::string> images;
  bool matches = false;
  double conf_thr = 0;
  int subsample = 0;  // 0: the model's default (DUSt3R 1, MASt3R 8)
  int border = 3;
};

std::pair<int, int> ParseSizes(const std::string& s) {
  std::stringstream ss(s);
  std::string a, b;
  std::getline(ss, a, ',');
  std::getline(ss, b, ',');
  try {
    const int x = std::stoi(a);
    const int y = b.empty() ? x : std::stoi(b);
    return {x, y};
  } catch (...) {
    FREELOC_THROW("--size '" << s << "' must be one number or two comma-separated numbers (224 or multiples of 16)");
  }
}

int RunPointmap(const PointmapOptions& o, const GlobalOptions& g) {
  FREELOC_CHECK(o.images.size() == 2, "pointmap needs exactly two images (IMG1 IMG2), got " << o.images.size());
  const auto [s1, s2] = ParseSizes(o.size);
  const nn::RuntimeOptions rt = g.Runtime();
  const auto t_load = std::chrono::steady_clock::now();
  const auto model = nn::Dust3rModel::Load(o.model, o.config, rt);
  const double load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_load).count();
  Dust3rPreprocessOptions p1, p2;
  p1.size = s1;
  p2.size = s2;
  const Dust3rInput a = PreprocessForDust3r(ReadImage(o.images[0]), p1);
  const Dust3rInput b = PreprocessForDust3r(ReadImage(o.images[1]), p2);
  const nn::Dust3rPrediction pr =
      model->Run({a.normalized.data(), a.height(), a.width()}, {b.normalized.data(), b.height(), b.width()});
  std::vector<std::pair<std::string, TensorView>> t = {
      {"pts3d_1", pr.pts3d_1},
      {"conf_1", pr.conf_1},
      {"pts3d_2", pr.pts3d_2},
      {"conf_2", pr.conf_2},
      {"image_1", MakeTensor(DType::kU8, {a.height(), a.width(), 3}, a.image.data.data(), a.image.data.size())},
      {"image_2", MakeTensor(DType::kU8, {b.height(), b.width(), 3}, b.image.data.data(), b.image.data.size())},
  };
  const bool mast3r = model->config().is_mast3r();
  if (mast3r) {
    t.emplace_back("desc_1", pr.desc_1);
    t.emplace_back("desc_conf_1", pr.desc_conf_1);
    t.emplace_back("desc_2", pr.desc_2);
    t.emplace_back("desc_conf_2", pr.desc_conf_2);
  }
  std::string match_info;
  if (o.matches && mast3r) {
    // spec/mast3r.md §4: raw fast reciprocal NN (upstream order, no filter), then the border / desc_conf filter.
    matching::FastNnOptions fo;
    fo.subsample = o.subsample > 0 ? o.subsample : 8;
    fo.threads = g.threads;
    matching::FastNnStats st;
    const int64_t D = pr.desc_1.shape.back();
    const auto raw = matching::FastReciprocalNN(
        {pr.desc_1.as<float>(), pr.desc_conf_1.as<float>(), a.height(), a.width(), static_cast<int>(D)},
        {pr.desc_2.as<float>(), pr.desc_conf_2.as<float>(), b.height(), b.width(), static_cast<int>(D)}, fo, &st);
    matching::DescriptorMatchFilter filt;
    filt.border = o.border;
    filt.min_conf = o.conf_thr;
    const auto kept = matching::FilterDescriptorMatches(raw, a.width(), a.height(), b.width(), b.height(), filt);
    const matching::Correspondences c = matching::ToOriginalPixels(kept, a, b);
    std::vector<int32_t> net;
    std::vector<float> orig;
    for (const auto& m : raw) net.insert(net.end(), {m.x1, m.y1, m.x2, m.y2});
    for (size_t i = 0; i < kept.size(); ++i)
      orig.insert(orig.end(), {static_cast<float>(c.ref[i].x()), static_cast<float>(c.ref[i].y()),
                               static_cast<float>(c.query[i].x()), static_cast<float>(c.query[i].y())});
    t.emplace_back("matches", MakeTensor(DType::kI32, {static_cast<int64_t>(raw.size()), 4}, net.data(), net.size() * 4));
    t.emplace_back("matches_orig",
                   MakeTensor(DType::kF32, {static_cast<int64_t>(kept.size()), 4}, orig.data(), orig.size() * 4));
    std::string sizes;
    for (size_t i = 0; i < st.query_sizes.size(); ++i) sizes += (i ? "," : "") + std::to_string(st.query_sizes[i]);
    match_info = "fast reciprocal NN, subsample " + std::to_string(fo.subsample) + ", " + st.kernel +
                 " screening, NN calls [" + sizes + "], " + std::to_string(st.dropped) + " seeds dropped, " +
                 std::to_string(raw.size()) + " raw, " + std::to_string(kept.size()) + " after border " +
                 std::to_string(o.border) + " px and desc_conf >= " + std::to_string(o.conf_thr);
    std::printf("%zu fast reciprocal NN matches (subsample %d, %.0f ms), %zu after the %d px border%s\n", raw.size(),
                fo.subsample, st.ms, kept.size(), o.border, o.conf_thr > 0 ? " and desc_conf filter" : "");
  } else if (o.matches) {
    matching::ReciprocalOptions mo;
    mo.conf_threshold = o.conf_thr;
    mo.subsample = o.subsample > 0 ? o.subsample : 1;
    mo.threads = g.threads;
    const auto m = matching::ReciprocalMatches(
        {pr.pts3d_1.as<float>(), pr.conf_1.as<float>(), nullptr, a.height(), a.width()},
        {pr.pts3d_2.as<float>(), pr.conf_2.as<float>(), nullptr, b.height(), b.width()}, mo);
    const matching::Correspondences c = matching::ToOriginalPixels(m, a, b);
    std::vector<int32_t> net;
    std::vector<float> orig;
    for (size_t i = 0; i < m.size(); ++i) {
      net.insert(net.end(), {m[i].x1, m[i].y1, m[i].x2, m[i].y2});
      orig.insert(orig.end(), {static_cast<float>(c.ref[i].x()), static_cast<float>(c.ref[i].y()),
                               static_cast<float>(c.query[i].x()), static_cast<float>(c.query[i].y())});
    }
    const int64_t n = static_cast<int64_t>(m.size());
    t.emplace_back("matches", MakeTensor(DType::kI32, {n, 4}, net.data(), net.size() * 4));
    t.emplace_back("matches_orig", MakeTensor(DType::kF32, {n, 4}, orig.data(), orig.size() * 4));
    std::printf("%lld reciprocal matches (conf ≥ %g, subsample %d)\n", static_cast<long long>(n), o.conf_thr,
                mo.subsample);
    match_info = "reciprocal 3D, conf >= " + std::to_string(o.conf_thr) + ", subsample " + std::to_string(mo.subsample);
  }
  char timing[160];
  std::snprintf(timing, sizeof(timing),
                "{\"load_ms\": %.1f, \"encode_ms\": %.1f, \"decode_ms\": %.1f, \"heads_ms\": %.1f}", load_ms,
                pr.encode_ms, pr.decode_ms, pr.heads_ms);
  std::map<std::string, std::string> meta = {
      {"model", o.model},
      {"family", model->config().family()},
      {"config", model->config().Summary()},
      {"size", std::to_string(s1) + "," + std::to_string(s2)},
      {"precision", ToString(rt.precision)},
      {"device", ToString(rt.device)},
      {"timings", timing},
      {"image_1", o.images[0] + " " + std::to_string(a.orig_width) + "x" + std::to_string(a.orig_height) +
                      " -> resized " + std::to_string(a.resized_width) + "x" + std::to_string(a.resized_height) +
                      " -> crop at (" + std::to_string(a.crop_x) + "," + std::to_string(a.crop_y) + ")"},
      {"image_2", o.images[1] + " " + std::to_string(b.orig_width) + "x" + std::to_string(b.orig_height) +
                      " -> resized " + std::to_string(b.resized_width) + "x" + std::to_string(b.resized_height) +
                      " -> crop at (" + std::to_string(b.crop_x) + "," + std::to_string(b.crop_y) + ")"},
  };
  if (!match_info.empty()) meta["matching"] = match_info;
  WriteSafetensors(o.out, t, meta);
  std::printf("%s pointmaps %dx%d and %dx%d written to %s (encode %.0f ms, decode %.0f ms, heads %.0f ms)\n",
              model->config().family(), a.width(),
              a.height(), b.width(), b.height(), o.out.c_str(), pr.encode_ms, pr.decode_ms, pr.heads_ms);
  return 0;
}

}  // namespace

void RegisterPointmap(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto o = std::make_shared<PointmapOptions>();
  auto* sub = app.add_subcommand(
      "pointmap", "DUSt3R / MASt3R pointmaps (and MASt3R descriptors) of an image pair, written as safetensors");
  sub->add_option("--model", o->model,
                  "DUSt3R or MASt3R weights: official .pth (constructor string inside) or model.safetensors "
                  "(config.json beside it)")
      ->required();
  sub->add_option("--config", o->config, "config.json with the constructor arguments (optional)");
  sub->add_option("--size", o->size, "load_images size: 224 or a multiple of 16, one value or two (SIZE1,SIZE2)");
  sub->add_option("--out", o->out, "output .safetensors")->required();
  sub->add_option("IMAGES", o->images, "IMG1 IMG2")->expected(2);
  sub->add_flag("--matches", o->matches,
                "also store matches: 'matches' (network pixels; MASt3R: the raw fast reciprocal NN, upstream order) "
                "and 'matches_orig' (original pixels; MASt3R: after the border / desc_conf filter)");
  sub->add_option("--conf-thr", o->conf_thr,
                  "with --matches: DUSt3R: a pixel is valid if conf >= this; MASt3R: keep matches with min "
                  "desc_conf >= this (default 0: all)");
  sub->add_option("--subsample", o->subsample,
                  "with --matches: DUSt3R: keep every k-th query pixel (default 1); MASt3R: the seed grid step of "
                  "the fast reciprocal NN (upstream subsample_or_initxy1, default 8)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--border", o->border, "with --matches, MASt3R: drop matches this close to an edge (default 3)")
      ->check(CLI::NonNegativeNumber);
  sub->callback([o, run, &global] { *run = [o, &global] { return RunPointmap(*o, global); }; });
}

}  // namespace freeloc::cli
