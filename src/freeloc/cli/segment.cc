// `freeloc segment`: SegGPT in-context segmentation — one or more prompts (image + mask), a target image, the binary
// mask of the target (0/255 PNG at the target's size) and optionally the raw network output of the target half.
#include <CLI/CLI.hpp>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/pipeline/networks.h"

namespace freeloc::cli {

namespace {

int RunSegment(pipeline::SegmentCommand c, const GlobalOptions& g) {
  FREELOC_CHECK(c.prompt_images.size() == c.prompt_masks.size(), "give one --prompt-mask per --prompt-image (got "
                                                                     << c.prompt_images.size() << " images and "
                                                                     << c.prompt_masks.size() << " masks)");
  c.runtime = g.Runtime();
  return pipeline::Networks().segment(c);
}

}  // namespace

void RegisterSegment(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto o = std::make_shared<pipeline::SegmentCommand>();
  auto* sub =
      app.add_subcommand("segment", "SegGPT: segment the target like the prompt mask(s) segment the prompt image(s)");
  sub->add_option("--model", o->model, "SegGPT weights: seggpt_vit_large.pth or HF model.safetensors")->required();
  sub->add_option("--config", o->config, "config.json (optional)");
  sub->add_option("--prompt-image", o->prompt_images, "prompt image (repeat for several prompts)")->required();
  sub->add_option("--prompt-mask", o->prompt_masks, "prompt mask PNG, white object on black (one per prompt image)")
      ->required();
  sub->add_option("--target", o->target, "target image")->required();
  sub->add_option("--type", o->type, "instance (default) or semantic")->check(CLI::IsMember({"instance", "semantic"}));
  sub->add_option("--out", o->out, "binary mask PNG (0/255) at the target's size")->required();
  sub->add_option("--raw", o->raw, "also write the network output of the target half as safetensors ('pred' [3,S,S])");
  sub->callback([o, run, &global] { *run = [o, &global] { return RunSegment(*o, global); }; });
}

}  // namespace freeloc::cli
