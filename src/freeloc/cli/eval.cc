// `freeloc eval`: Map-free metrics of a submission ZIP, identical to the official evaluator's, as Markdown tables
// (overall and per scene), JSON (official key names), and an optional report folder (metrics.json, errors.csv,
// CDF plots). `--compare A.zip B.zip …` puts several submissions side by side.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <sstream>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/eval/report.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/mapfree.h"

namespace freeloc::cli {

namespace {

struct EvalOptions {
  std::string data, split = "val", submission, json, report, scenes, track = "single-frame";
  std::vector<std::string> compare;
};

int RunEval(const EvalOptions& o) {
  std::string split_dir;
  const std::vector<std::string> scenes = ResolveScenes(o.data, o.split, o.scenes, &split_dir);
  std::vector<std::string> subs = o.compare;
  if (!o.submission.empty()) subs.insert(subs.begin(), o.submission);
  const io::Track track = ParseEnum<io::Track>(o.track, "--track");
  std::vector<eval::EvalRun> runs;
  for (const auto& s : subs) runs.push_back(eval::RunEvaluation(split_dir, scenes, s, track));

  const bool json_stdout = o.json == "-";
  if (!json_stdout) {
    if (runs.size() == 1) {
      std::printf("%s", eval::MarkdownReport(runs[0]).c_str());
    } else {
      std::printf("## Map-free metrics — %zu submissions on %zu scenes\n\n%s", runs.size(), scenes.size(),
                  eval::MarkdownCompare(runs).c_str());
    }
  }
  if (!o.json.empty()) {
    std::string text;
    if (runs.size() == 1) {
      text = eval::JsonReport(runs[0]);
    } else {
      text = "{\n";
      for (size_t i = 0; i < runs.size(); ++i) {
        std::string j = eval::JsonReport(runs[i]);
        j.pop_back();
        text += "\"" + runs[i].label + "\": " + j + (i + 1 < runs.size() ? ",\n" : "\n");
      }
      text += "}\n";
    }
    if (json_stdout) {
      std::printf("%s", text.c_str());
    } else {
      io::WriteFileAtomic(o.json, text.data(), text.size());
    }
  }
  if (!o.report.empty()) {
    std::vector<const eval::EvalRun*> ptrs;
    for (const auto& r : runs) ptrs.push_back(&r);
    eval::WriteReportDir(o.report, ptrs);
    if (!json_stdout) std::printf("\nreport written to %s\n", o.report.c_str());
  }
  return 0;
}

}  // namespace

void RegisterEval(CLI::App& app, const GlobalOptions& /*global*/, RunFn* run) {
  auto o = std::make_shared<EvalOptions>();
  auto* sub = app.add_subcommand("eval", "Map-free metrics of a submission ZIP (identical to the official evaluator)");
  sub->add_option("--data", o->data, "dataset root (holding val/ test/) or the split folder itself")->required();
  sub->add_option("--split", o->split, "split folder under --data (default: val)");
  auto* s = sub->add_option("--submission", o->submission, "submission ZIP (pose_sNNNNN.txt files)");
  auto* c = sub->add_option("--compare", o->compare, "several submission ZIPs, compared side by side")->expected(1, -1);
  s->excludes(c);
  sub->add_option("--json", o->json, "also write the metrics as JSON to this file ('-' for stdout only)");
  sub->add_option("--report", o->report, "write metrics.json, errors.csv and CDF plots (SVG) into this folder");
  sub->add_option("--scenes", o->scenes, "comma-separated scene names to evaluate (default: all in the split)");
  sub->add_option("--track", o->track,
                  "single-frame (default: every 5th frame, as the official evaluator) | multi-frame (the frames at "
                  "linear positions 9, 19, … of each scene's sorted seq1 frames)");
  sub->callback([o, run, s, c] {
    if (s->count() == 0 && c->count() == 0) throw CLI::RequiredError("--submission or --compare");
    *run = [o] { return RunEval(*o); };
  });
}

}  // namespace freeloc::cli
