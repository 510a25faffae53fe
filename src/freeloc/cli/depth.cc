// `freeloc depth`: Metric3D v2 metric depth of one image with its intrinsics — a uint16 millimetre PNG (map-free
// convention, 0 invalid) and optionally the raw float outputs.
#include <CLI/CLI.hpp>

#include "freeloc/cli/commands.h"
#include "freeloc/core/camera.h"
#include "freeloc/core/error.h"
#include "freeloc/pipeline/networks.h"

namespace freeloc::cli {

namespace {

int RunDepth(pipeline::DepthCommand c, const GlobalOptions& g) {
  Camera::FromString(c.intrinsics, "--intrinsics");  // the flag named in its error, before any model loads
  c.runtime = g.Runtime();
  return pipeline::Networks().depth(c);
}

}  // namespace

void RegisterDepth(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto o = std::make_shared<pipeline::DepthCommand>();
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
