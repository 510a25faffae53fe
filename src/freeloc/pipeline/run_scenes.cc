#include "freeloc/pipeline/run_scenes.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/pipeline/relocalize_scene.h"

namespace freeloc::pipeline {

namespace fs = std::filesystem;

std::map<std::string, io::MapfreeScene> LoadScenes(const std::string& split_dir, const std::vector<std::string>& scenes,
                                                   const PipelineOptions& o) {
  bool any_depth = !o.UsesProvidedDepth();
  std::string example;
  std::map<std::string, io::MapfreeScene> loaded;
  for (const auto& name : scenes) {
    const io::MapfreeScene& scene = loaded[name] = io::MapfreeScene::Load(split_dir + "/" + name);
    AnsweredQueries(scene, o);  // multi-frame: every query must be orderable by its frame number
    if (!o.UsesProvidedDepth()) continue;
    const std::string p = scene.DepthPath(scene.reference, o.depth.suffix);
    if (example.empty()) example = p;
    std::error_code ec;
    any_depth = any_depth || fs::exists(p, ec);
  }
  FREELOC_OPTION_CHECK("depth", any_depth,
                       " " << o.depth.ToString() << ": no scene has this depth (e.g. " << example
                           << " is missing); check the suffix, or use metric3d or none");
  return loaded;
}

std::vector<std::vector<std::string>> AssignScenes(const std::vector<std::string>& scenes,
                                                   const std::map<std::string, io::MapfreeScene>& loaded, int ranks) {
  std::vector<std::string> order = scenes;
  auto queries = [&](const std::string& n) { return loaded.at(n).queries.size(); };
  std::stable_sort(order.begin(), order.end(), [&](const std::string& a, const std::string& b) {
    return queries(a) != queries(b) ? queries(a) > queries(b) : a < b;
  });
  std::vector<std::vector<std::string>> out(static_cast<size_t>(ranks));
  std::vector<size_t> load(static_cast<size_t>(ranks), 0);
  for (const auto& n : order) {
    const size_t r = static_cast<size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    out[r].push_back(n);
    load[r] += queries(n) + 1;  // + 1: an empty scene still costs its reference
  }
  for (auto& v : out) std::sort(v.begin(), v.end());
  return out;
}

}  // namespace freeloc::pipeline
