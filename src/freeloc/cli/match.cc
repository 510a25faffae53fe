// `freeloc match`: DUSt3R correspondences of an image pair in original pixels — global reciprocal 3D matches,
// plus instance-restricted matches when instance label images are given (merged by Eq. 3) — written one
// `x_ref y_ref x_query y_query` per line, the input format of `freeloc pose`.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <fstream>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/dust3r_preprocess.h"
#include "freeloc/io/image_io.h"
#include "freeloc/matching/instance.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/pipeline/dust3r_stage.h"

namespace freeloc::cli {

namespace {

struct MatchOptions {
  std::string model, config, ref, query, ref_masks, query_masks, out, mode = "mask";
  int size = 512, subsample = 1;
  double conf_thr = 0;
};

std::vector<uint16_t> ReadLabels(const std::string& path, int w, int h) {
  int lw, lh;
  const std::vector<uint16_t> v = ReadPng16(path, &lw, &lh);
  FREELOC_CHECK(lw == w && lh == h, path << ": the label image is " << lw << "x" << lh << " but its photo is " << w
                                         << "x" << h << "; give masks at the photo's resolution");
  return v;
}

int RunMatch(const MatchOptions& o, const GlobalOptions& g) {
  FREELOC_CHECK(o.ref_masks.empty() == o.query_masks.empty(), "give both --ref-masks and --query-masks, or neither");
  nn::RuntimeOptions rt;
  rt.device = g.device;
  rt.threads = g.threads;
  const auto model = nn::Dust3rModel::Load(o.model, o.config, rt);
  const matching::PointmapFn fn = pipeline::Dust3rPointmapFn(model);
  const Image ref = ReadImage(o.ref), query = ReadImage(o.query);
  matching::InstanceOptions io;
  io.mode = matching::ParseInstanceMode(o.mode);
  io.preprocess.size = o.size;
  io.match.conf_threshold = o.conf_thr;
  io.match.subsample = o.subsample;
  io.match.threads = g.threads;
  io.Validate();
  const Dust3rInput a = PreprocessForDust3r(ref, io.preprocess), b = PreprocessForDust3r(query, io.preprocess);
  const auto global = matching::GlobalCorrespondences(fn(a, b), a, b, io.match);
  std::vector<matching::Correspondence> final_matches = global;
  int used = 0, given = 0;
  if (!o.ref_masks.empty()) {
    const auto lr = matching::SplitLabels(ReadLabels(o.ref_masks, ref.width, ref.height));
    const auto lq = matching::SplitLabels(ReadLabels(o.query_masks, query.width, query.height));
    std::vector<matching::InstanceMasks> masks;
    for (const auto& [id, m] : lr)
      for (const auto& [idq, mq] : lq)
        if (id == idq) masks.push_back({id, m, mq});
    std::vector<matching::InstanceResult> results;
    for (const auto& m : masks) {
      results.push_back(matching::MatchInstance(ref, query, m, fn, io));
      used += results.back().used;
      if (!results.back().used)
        std::fprintf(stderr, "freeloc match: instance %d skipped: %s\n", m.id, results.back().reason.c_str());
    }
    given = static_cast<int>(masks.size());
    final_matches = matching::MergeMatches(global, results, masks, ref.width, ref.height);
  }
  matching::Correspondences out;
  for (const auto& c : final_matches) {
    out.ref.push_back(c.ref);
    out.query.push_back(c.query);
  }
  WriteCorrespondences(o.out, out);
  std::printf("%zu correspondences (%zu global before merging; %d of %d instances used) written to %s\n",
              final_matches.size(), global.size(), used, given, o.out.c_str());
  return 0;
}

}  // namespace

void RegisterMatch(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto o = std::make_shared<MatchOptions>();
  auto* sub = app.add_subcommand(
      "match", "DUSt3R correspondences of an image pair (global + instance matches) in original pixels");
  sub->add_option("--model", o->model, "DUSt3R weights: official .pth or model.safetensors")->required();
  sub->add_option("--config", o->config, "config.json with the constructor arguments (optional)");
  sub->add_option("REF", o->ref, "reference image")->required();
  sub->add_option("QUERY", o->query, "query image")->required();
  sub->add_option("--ref-masks", o->ref_masks, "reference instance label PNG (0 = background, k = instance k)");
  sub->add_option("--query-masks", o->query_masks, "query instance label PNG (same labels as the reference)");
  sub->add_option("--instance-mode", o->mode, "mask (I ⊙ Mask, default) or crop")
      ->check(CLI::IsMember({"mask", "crop"}));
  sub->add_option("--size", o->size, "load_images size (default 512)");
  sub->add_option("--conf-thr", o->conf_thr, "a pixel is valid if conf >= this (default 0)");
  sub->add_option("--subsample", o->subsample, "keep every k-th query pixel (default 1)")->check(CLI::PositiveNumber);
  sub->add_option("--out", o->out, "output file: x_ref y_ref x_query y_query per line")->required();
  sub->callback([o, run, &global] { *run = [o, &global] { return RunMatch(*o, global); }; });
}

}  // namespace freeloc::cli
