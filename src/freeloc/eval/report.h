// Evaluation reports: the Markdown tables printed by `freeloc eval`, the JSON object (official key names at the
// top level, plus "per_scene" and "counts"), the per-frame CSV and the SVG plots of the error distributions.
#pragma once

#include <string>
#include <vector>

#include "freeloc/eval/metrics.h"

namespace freeloc::eval {

struct EvalRun {
  std::string label;  // the submission's file name
  std::vector<SceneRecord> scenes;
  Metrics overall;
  std::vector<std::pair<std::string, Metrics>> per_scene;  // scenes with at least one estimate
};

// Evaluates and aggregates one submission (overall and per scene) on the frames `track` scores.
EvalRun RunEvaluation(const std::string& split_dir, const std::vector<std::string>& scenes,
                      const std::string& submission_path, io::Track track = io::Track::kSingleFrame);

std::string MarkdownReport(const EvalRun& run);
// One column per submission.
std::string MarkdownCompare(const std::vector<EvalRun>& runs);
std::string JsonReport(const EvalRun& run, int indent = 2);
std::string ErrorsCsv(const EvalRun& run);

// Cumulative distribution of one error over all evaluated frames (failures count in the denominator, so the curve
// ends at the estimates ratio), one curve per run; a dashed line marks the acceptance threshold.
std::string CdfSvg(const std::vector<const EvalRun*>& runs, const std::string& title, const std::string& x_label,
                   int which /*0 trans, 1 rot, 2 vcre*/, double threshold, double x_max);

// Text for HTML/SVG: & < > " escaped. A number with a printf format ("nan" for NaN).
std::string EscapeMarkup(const std::string& text);
std::string FormatNumber(const char* fmt, double v);

// Writes metrics.json, errors.csv and cdf_{translation,rotation,vcre}.svg into `dir` (created if needed).
void WriteReportDir(const std::string& dir, const std::vector<const EvalRun*>& runs);

}  // namespace freeloc::eval
