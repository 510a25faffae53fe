// The work of the network commands `freeloc pointmap`, `segment` and `depth` (pipeline/networks.h); the CLI parses
// their flags (cli/pointmap.cc, segment.cc, depth.cc) and calls these through the networks module.
#include "freeloc/networks/commands.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>

#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/matching/fast_nn.h"
#include "freeloc/matching/pixel_mapping.h"
#include "freeloc/matching/reciprocal.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/nn/metric3d.h"
#include "freeloc/nn/seggpt.h"
#include "freeloc/vision/dust3r_preprocess.h"

namespace freeloc::networks {

using namespace freeloc::pipeline;  // NOLINT: the networks module implements the pipeline's stages

int Pointmap(const PointmapCommand& o) {
  FREELOC_CHECK(o.images.size() == 2, "pointmap needs exactly two images (IMG1 IMG2), got " << o.images.size());
  const int s1 = o.size1, s2 = o.size2;
  const nn::RuntimeOptions& rt = o.runtime;
  const auto t_load = std::chrono::steady_clock::now();
  const auto model = nn::Dust3rModel::Load(o.model, o.config, rt);
  const double load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_load).count();
  vision::Dust3rPreprocessOptions p1, p2;
  p1.size = s1;
  p2.size = s2;
  const vision::Dust3rInput a = vision::PreprocessForDust3r(io::ReadImage(o.images[0]), p1);
  const vision::Dust3rInput b = vision::PreprocessForDust3r(io::ReadImage(o.images[1]), p2);
  const nn::Dust3rPrediction pr =
      model->Run({a.normalized.data(), a.height(), a.width()}, {b.normalized.data(), b.height(), b.width()});
  std::vector<std::pair<std::string, io::TensorView>> t = {
      {"pts3d_1", pr.pts3d_1},
      {"conf_1", pr.conf_1},
      {"pts3d_2", pr.pts3d_2},
      {"conf_2", pr.conf_2},
      {"image_1", io::MakeTensor(io::DType::kU8, {a.height(), a.width(), 3}, a.image.data.data(), a.image.data.size())},
      {"image_2", io::MakeTensor(io::DType::kU8, {b.height(), b.width(), 3}, b.image.data.data(), b.image.data.size())},
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
    // naver/mast3r mast3r/fast_nn.py: raw fast reciprocal NN (upstream order, no filter), then the border / desc_conf
    // filter.
    matching::FastNnOptions fo;
    fo.subsample = o.subsample > 0 ? o.subsample : 8;
    fo.threads = rt.threads;
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
    t.emplace_back("matches",
                   io::MakeTensor(io::DType::kI32, {static_cast<int64_t>(raw.size()), 4}, net.data(), net.size() * 4));
    t.emplace_back("matches_orig", io::MakeTensor(io::DType::kF32, {static_cast<int64_t>(kept.size()), 4}, orig.data(),
                                                  orig.size() * 4));
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
    mo.threads = rt.threads;
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
    t.emplace_back("matches", io::MakeTensor(io::DType::kI32, {n, 4}, net.data(), net.size() * 4));
    t.emplace_back("matches_orig", io::MakeTensor(io::DType::kF32, {n, 4}, orig.data(), orig.size() * 4));
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
  io::WriteSafetensors(o.out, t, meta);
  std::printf("%s pointmaps %dx%d and %dx%d written to %s (encode %.0f ms, decode %.0f ms, heads %.0f ms)\n",
              model->config().family(), a.width(), a.height(), b.width(), b.height(), o.out.c_str(), pr.encode_ms,
              pr.decode_ms, pr.heads_ms);
  return 0;
}

int Segment(const SegmentCommand& o) {
  FREELOC_CHECK(!o.prompt_images.empty() && o.prompt_images.size() == o.prompt_masks.size(),
                "give one prompt mask per prompt image (got " << o.prompt_images.size() << " images and "
                                                              << o.prompt_masks.size() << " masks)");
  const nn::RuntimeOptions& rt = o.runtime;
  const auto model = nn::SegGptModel::Load(o.model, o.config, rt);
  std::vector<Image> pi, pm;
  for (size_t k = 0; k < o.prompt_images.size(); ++k) {
    pi.push_back(io::ReadImage(o.prompt_images[k]));
    pm.push_back(io::ReadImage(o.prompt_masks[k]));
  }
  const Image target = io::ReadImage(o.target);
  io::TensorView pred;
  const vision::SegGptMask m = model->Segment(pi, pm, target, nn::ParseSegType(o.type), &pred);
  std::vector<uint8_t> png(m.mask.size());
  size_t on = 0;
  for (size_t i = 0; i < png.size(); ++i) {
    png[i] = m.mask[i] ? 255 : 0;
    on += m.mask[i];
  }
  if (!o.raw.empty()) {
    // Item 0, target (bottom) half, before denormalisation: [3, S, S].
    const int S = model->config().half;
    std::vector<float> half(static_cast<size_t>(3) * S * S);
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < S; ++y)
        for (int x = 0; x < S; ++x)
          half[(static_cast<size_t>(c) * S + y) * S + x] =
              pred.as<float>()[(static_cast<size_t>(c) * 2 * S + S + y) * S + x];
    io::WriteSafetensors(o.raw, {{"pred", io::MakeTensor(io::DType::kF32, {3, S, S}, half.data(), half.size() * 4)}},
                         {{"model", o.model},
                          {"config", model->config().Summary()},
                          {"type", o.type},
                          {"prompts", std::to_string(pi.size())}});
  }
  io::WritePng8(o.out, target.width, target.height, png);
  std::printf("mask %dx%d written to %s (%.1f %% foreground, %zu prompt%s, %s)\n", target.width, target.height,
              o.out.c_str(), 100.0 * on / png.size(), pi.size(), pi.size() > 1 ? "s, feature ensemble" : "",
              o.type.c_str());
  return 0;
}

int Depth(const DepthCommand& o) {
  const Camera cam = Camera::FromString(o.intrinsics, "intrinsics");
  const Image img = io::ReadImage(o.image);
  cam.ValidateForImage(img.width, img.height, o.image + ": intrinsics");
  const nn::RuntimeOptions& rt = o.runtime;
  const auto model = nn::Metric3dModel::Load(o.model, o.config, rt);
  const nn::Metric3dOutput out = model->Estimate(img, cam);
  if (!o.raw.empty()) {
    const int h = img.height, w = img.width;
    std::map<std::string, std::string> meta = out.metadata;
    meta["image"] = o.image;
    meta["intrinsics"] = o.intrinsics;
    io::WriteSafetensors(
        o.raw,
        {{"depth", io::MakeTensor(io::DType::kF32, {h, w}, out.depth.data.data(), out.depth.data.size() * 4)},
         {"confidence", io::MakeTensor(io::DType::kF32, {h, w}, out.confidence.data(), out.confidence.size() * 4)},
         {"normal", io::MakeTensor(io::DType::kF32, {3, h, w}, out.normal.data(), out.normal.size() * 4)},
         {"canonical_depth", out.canonical_depth}},
        meta);
  }
  io::WriteDepthPng(o.out, out.depth);
  float lo = 1e30f, hi = 0;
  for (float v : out.depth.data)
    if (v > 0) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  std::printf("depth %dx%d written to %s (%.3f–%.3f m, %s, network %.0f ms)\n", img.width, img.height, o.out.c_str(),
              lo, hi, model->config().variant.c_str(), out.network_ms);
  return 0;
}

}  // namespace freeloc::networks
