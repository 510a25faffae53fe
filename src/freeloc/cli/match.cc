// `freeloc match`: the pipeline's DUSt3R-family matcher on an image pair — global reciprocal 3D matches (dust3r) or
// MASt3R's fast reciprocal descriptor matches (--matcher mast3r), plus instance-restricted matches merged by Eq. 3
// when instance label images are given — written one `x_ref y_ref x_query y_query` per line in original pixels,
// the input format of `freeloc pose`.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <map>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/correspondence_file.h"
#include "freeloc/io/image_io.h"
#include "freeloc/pipeline/relocalizer.h"

namespace freeloc::cli {

namespace {

struct MatchArgs {
  PipelineArgs pipeline;
  std::string model, config, ref, query, ref_masks, query_masks, out, mode, matcher = "dust3r";
  int size = 0, subsample = 0, border = -1;
  double conf_thr = 0;
};

// match spells some option fields its own way.
const std::map<std::string, std::string>& MatchFlags() {
  static const std::map<std::string, std::string> flags = {{"dust3r_model", "--model"},
                                                           {"mast3r_model", "--model"},
                                                           {"dust3r_config", "--config"},
                                                           {"dust3r_size", "--size"},
                                                           {"match_conf_threshold", "--conf-thr"},
                                                           {"mast3r_conf_threshold", "--conf-thr"},
                                                           {"match_subsample", "--subsample"},
                                                           {"mast3r_subsample", "--subsample"},
                                                           {"mast3r_border", "--border"}};
  return flags;
}

pipeline::PipelineOptions Options(const MatchArgs& a, const GlobalOptions& g) {
  PipelineArgs p = a.pipeline;
  const bool mast3r = a.matcher == "mast3r";
  p.values[mast3r ? "mast3r_model" : "dust3r_model"] = a.model;
  FREELOC_CHECK(!mast3r || a.config.empty(),
                "--config: a MASt3R model reads its configuration from the .pth or the config.json beside "
                "model.safetensors");
  p.values["dust3r_config"] = a.config;
  if (a.size > 0) p.values["dust3r_size"] = std::to_string(a.size);
  p.values["instance_mode"] = a.mode;
  p.values["matcher"] = a.matcher + (a.ref_masks.empty() ? "" : "+instances");
  p.values["depth"] = "none";
  return ResolvePipelineArgs(p, g, "dust3r", [&](pipeline::PipelineOptions* o) {
    FREELOC_CHECK(a.ref_masks.empty() == a.query_masks.empty(), "give both --ref-masks and --query-masks, or neither");
    ApplyMaskArgs(o, !a.ref_masks.empty(), !a.query_masks.empty());
    if (mast3r) {
      o->pointmap.mast3r_conf_threshold = a.conf_thr;
      if (a.subsample > 0) o->pointmap.mast3r_subsample = a.subsample;
      if (a.border >= 0) o->pointmap.mast3r_border = a.border;
    } else {
      FREELOC_CHECK(a.border < 0, "--border applies to --matcher mast3r only");
      o->pointmap.match_conf_threshold = a.conf_thr;
      if (a.subsample > 0) o->pointmap.match_subsample = a.subsample;
    }
  });
}

int RunMatch(const MatchArgs& a, const GlobalOptions& g) try {
  const pipeline::PipelineOptions o = Options(a, g);
  const Image ref = io::ReadImage(a.ref), query = io::ReadImage(a.query);
  std::vector<uint16_t> ref_labels, query_labels;
  pipeline::FrameInputs in;
  if (!a.ref_masks.empty()) {
    ref_labels = ReadLabels(a.ref_masks, ref.width, ref.height);
    query_labels = ReadLabels(a.query_masks, query.width, query.height);
    in.instance_labels = &query_labels;
  }
  pipeline::Relocalizer reloc(o, pipeline::Relocalizer::kOptionsValidated);  // Options() validated them
  const Camera none;  // the DUSt3R/MASt3R matchers need no intrinsics
  reloc.SetReference(ref, none, pipeline::FrameInputs{{}, ref_labels.empty() ? nullptr : &ref_labels, nullptr});
  pipeline::QueryResult r;
  const matching::Correspondences c = reloc.Match(query, none, in, &r);
  io::WriteCorrespondenceFile(a.out, c.Rows());
  std::printf("%zu correspondences (%d global before merging; %d of %d instances used) written to %s\n", c.size(),
              r.global_matches, r.instances_used, r.instances, a.out.c_str());
  return 0;
} catch (const OptionError& e) {
  throw Error(FlagMessage(e, MatchFlags()));
}

}  // namespace

void RegisterMatch(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto a = std::make_shared<MatchArgs>();
  auto* sub = app.add_subcommand(
      "match", "DUSt3R / MASt3R correspondences of an image pair (global + instance matches) in original pixels");
  sub->add_option("--matcher", a->matcher,
                  "dust3r (reciprocal 3D matches, default) | mast3r (descriptors, fast reciprocal NN)")
      ->check(CLI::IsMember({"dust3r", "mast3r"}));
  sub->add_option("--model", a->model, "DUSt3R or MASt3R weights: official .pth or model.safetensors")->required();
  sub->add_option("--config", a->config, "DUSt3R config.json with the constructor arguments (optional)");
  sub->add_option("REF", a->ref, "reference image")->required();
  sub->add_option("QUERY", a->query, "query image")->required();
  sub->add_option("--ref-masks", a->ref_masks, "reference instance label PNG (0 = background, k = instance k)");
  sub->add_option("--query-masks", a->query_masks, "query instance label PNG (same labels as the reference)");
  sub->add_option("--instance-mode", a->mode, "mask (I ⊙ Mask, default) or crop")
      ->check(CLI::IsMember({"mask", "crop"}));
  sub->add_option("--size", a->size, "load_images size (default 512)");
  sub->add_option("--conf-thr", a->conf_thr,
                  "dust3r: a pixel is valid if conf >= this; mast3r: keep matches with min desc_conf >= this "
                  "(default 0: all; visloc uses 1.001)");
  sub->add_option("--subsample", a->subsample,
                  "dust3r: keep every k-th query pixel (default 1); mast3r: seed grid step of the fast reciprocal "
                  "NN (default 8)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--border", a->border, "mast3r: drop matches this close to a network image's edge (default 3)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--out", a->out, "output file: x_ref y_ref x_query y_query per line")->required();
  sub->callback([a, run, &global] { *run = [a, &global] { return RunMatch(*a, global); }; });
}

}  // namespace freeloc::cli
