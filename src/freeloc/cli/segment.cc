// `freeloc segment`: SegGPT in-context segmentation — one or more prompts (image + mask), a target image, the binary
// mask of the target (0/255 PNG at the target's size) and optionally the raw network output of the target half.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/safetensors.h"
#include "freeloc/nn/seggpt.h"

namespace freeloc::cli {

namespace {

struct SegmentOptions {
  std::string model, config, target, out, raw, type = "instance";
  std::vector<std::string> prompt_images, prompt_masks;
};

int RunSegment(const SegmentOptions& o, const GlobalOptions& g) {
  FREELOC_CHECK(!o.prompt_images.empty() && o.prompt_images.size() == o.prompt_masks.size(),
                "give one --prompt-mask per --prompt-image (got " << o.prompt_images.size() << " images and "
                                                                  << o.prompt_masks.size() << " masks)");
  const nn::RuntimeOptions rt = g.Runtime();
  const auto model = nn::SegGptModel::Load(o.model, o.config, rt);
  std::vector<Image> pi, pm;
  for (size_t k = 0; k < o.prompt_images.size(); ++k) {
    pi.push_back(ReadImage(o.prompt_images[k]));
    pm.push_back(ReadImage(o.prompt_masks[k]));
  }
  const Image target = ReadImage(o.target);
  TensorView pred;
  const SegGptMask m = model->Segment(pi, pm, target, nn::ParseSegType(o.type), &pred);
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
    WriteSafetensors(o.raw, {{"pred", MakeTensor(DType::kF32, {3, S, S}, half.data(), half.size() * 4)}},
                     {{"model", o.model},
                      {"config", model->config().Summary()},
                      {"type", o.type},
                      {"prompts", std::to_string(pi.size())}});
  }
  WritePng8(o.out, target.width, target.height, png);
  std::printf("mask %dx%d written to %s (%.1f %% foreground, %zu prompt%s, %s)\n", target.width, target.height,
              o.out.c_str(), 100.0 * on / png.size(), pi.size(), pi.size() > 1 ? "s, feature ensemble" : "",
              o.type.c_str());
  return 0;
}

}  // namespace

void RegisterSegment(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto o = std::make_shared<SegmentOptions>();
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
