// `freeloc pointmap`: DUSt3R or MASt3R pointmaps of an image pair — preprocessing (load_images policy), the
// network, and a safetensors file with pts3d_1/conf_1 (view 1), pts3d_2/conf_2 (view 2 in view 1's frame), for a
// MASt3R model also desc_1/desc_conf_1/desc_2/desc_conf_2, the preprocessed crops and metadata (model, size,
// precision, timings). With --matches: DUSt3R's reciprocal 3D matches, or MASt3R's fast reciprocal NN matches (raw,
// upstream order) and the filtered ones in original pixels.
#include <CLI/CLI.hpp>
#include <sstream>
#include <tuple>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/pipeline/networks.h"

namespace freeloc::cli {

namespace {

// The command's fields, bound to the flags directly; --size is text until the run parses it.
struct PointmapOptions {
  pipeline::PointmapCommand command;
  std::string size = "512";
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
  pipeline::PointmapCommand c = o.command;
  std::tie(c.size1, c.size2) = ParseSizes(o.size);
  c.runtime = g.Runtime();
  return pipeline::Networks().pointmap(c);
}

}  // namespace

void RegisterPointmap(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto o = std::make_shared<PointmapOptions>();
  auto* sub = app.add_subcommand(
      "pointmap", "DUSt3R / MASt3R pointmaps (and MASt3R descriptors) of an image pair, written as safetensors");
  sub->add_option("--model", o->command.model,
                  "DUSt3R or MASt3R weights: official .pth (constructor string inside) or model.safetensors "
                  "(config.json beside it)")
      ->required();
  sub->add_option("--config", o->command.config, "config.json with the constructor arguments (optional)");
  sub->add_option("--size", o->size, "load_images size: 224 or a multiple of 16, one value or two (SIZE1,SIZE2)");
  sub->add_option("--out", o->command.out, "output .safetensors")->required();
  sub->add_option("IMAGES", o->command.images, "IMG1 IMG2")->expected(2);
  sub->add_flag("--matches", o->command.matches,
                "also store matches: 'matches' (network pixels; MASt3R: the raw fast reciprocal NN, upstream order) "
                "and 'matches_orig' (original pixels; MASt3R: after the border / desc_conf filter)");
  sub->add_option("--conf-thr", o->command.conf_thr,
                  "with --matches: DUSt3R: a pixel is valid if conf >= this; MASt3R: keep matches with min "
                  "desc_conf >= this (default 0: all)");
  sub->add_option("--subsample", o->command.subsample,
                  "with --matches: DUSt3R: keep every k-th query pixel (default 1); MASt3R: the seed grid step of "
                  "the fast reciprocal NN (upstream subsample_or_initxy1, default 8)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--border", o->command.border,
                  "with --matches, MASt3R: drop matches this close to an edge (default 3)")
      ->check(CLI::NonNegativeNumber);
  sub->callback([o, run, &global] { *run = [o, &global] { return RunPointmap(*o, global); }; });
}

}  // namespace freeloc::cli
