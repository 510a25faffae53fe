// `freeloc depth`: Metric3D v2 metric depth of one image with its intrinsics — a uint16 millimetre PNG (map-free
// convention, 0 invalid) and optionally the raw float outputs.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/nn/metric3d.h"

namespace freeloc::cli {

namespace {

struct DepthOptions {
  std::string model, config, image, intrinsics, out, raw;
};

int RunDepth(const DepthOptions& o, const GlobalOptions& g) {
  const Camera cam = Camera::FromString(o.intrinsics, "--intrinsics");
  const nn::RuntimeOptions rt = g.Runtime();
  const auto model = nn::Metric3dModel::Load(o.model, o.config, rt);
  const Image img = ReadImage(o.image);
  const nn::Metric3dOutput out = model->Estimate(img, cam);
  if (!o.raw.empty()) {
    const int h = img.height, w = img.width;
    std::map<std::string, std::string> meta = out.metadata;
    meta["image"] = o.image;
    meta["intrinsics"] = o.intrinsics;
    WriteSafetensors(o.raw,
                     {{"depth", MakeTensor(DType::kF32, {h, w}, out.depth.data.data(), out.depth.data.size() * 4)},
                      {"confidence", MakeTensor(DType::kF32, {h, w}, out.confidence.data(), out.confidence.size() * 4)},
                      {"normal", MakeTensor(DType::kF32, {3, h, w}, out.normal.data(), out.normal.size() * 4)},
                      {"canonical_depth", out.canonical_depth}},
                     meta);
  }
  WriteDepthPng(o.out, out.depth);
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

}  // namespace

void RegisterDepth(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto o = std::make_shared<DepthOptions>();
  auto* sub = app.add_subcommand("depth", "Metric3D v2: metric depth of one image from its intrinsics");
  sub->add_option("--model", o->model, "metric_depth_vit_{small,large,giant2}_800k.pth or safetensors")->required();
  sub->add_option("--config", o->config, "config.json (optional; released defaults otherwise)");
  sub->add_option("--image", o->image, "input image")->required();
  sub->add_option("--intrinsics", o->intrinsics, "fx,fy,cx,cy of the image")->required();
  sub->add_option("--out", o->out, "depth PNG, uint16 millimetres, 0 = invalid")->required();
  sub->add_option("--raw", o->raw, "also write depth/confidence/normal/canonical_depth as float32 safetensors");
  sub->callback([o, run, &global] { *run = [o, &global] { return RunDepth(*o, global); }; });
}

}  // namespace freeloc::cli
