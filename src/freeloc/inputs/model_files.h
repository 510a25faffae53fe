// Where the networks' weights come from (docs/models.md): an explicit file per stage, or the published file names
// looked up in `--models DIR` and then in each folder of $FREELOC_MODELS (colon-separated). The per-process model
// caches are in networks/model_cache.h. Light header.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace freeloc::inputs {

enum class Network { kDust3r, kMast3r, kSegGpt, kMetric3d };
const char* NetworkName(Network n);    // "DUSt3R", "MASt3R", "SegGPT", "Metric3D v2"
const char* NetworkOption(Network n);  // the PipelineOptions field: "dust3r_model", "mast3r_model", …

// The published file names freeloc looks for, in order of preference (relative to a models folder).
std::vector<std::string> PublishedNames(Network n);

// `models_dir` (when not empty) and then the folders of $FREELOC_MODELS.
std::vector<std::string> ModelDirs(const std::string& models_dir);

// The first published file of `n` found in `dirs`; "" when there is none.
std::string FindModel(Network n, const std::vector<std::string>& dirs);

// One line for a model that is needed and was not found: what was looked for where, where to get it, and which
// presets run without it.
std::string MissingModelMessage(Network n, const std::string& preset, const std::vector<std::string>& dirs);

}  // namespace freeloc::inputs
