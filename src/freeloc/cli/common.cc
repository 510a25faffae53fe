// Helpers shared by the subcommands.
#include <cstdio>
#include <sstream>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/mapfree.h"

namespace freeloc::cli {

std::vector<std::string> ResolveScenes(const std::string& data, const std::string& split, const std::string& scenes_csv,
                                       std::string* split_dir) {
  *split_dir = ResolveSplitDir(data, split);
  std::vector<std::string> only;
  std::stringstream ss(scenes_csv);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) only.push_back(item);
  std::vector<std::string> scenes = ListScenes(*split_dir, only);
  FREELOC_CHECK(!scenes.empty(), *split_dir << ": no scene folders to process");
  return scenes;
}

void WriteCorrespondences(const std::string& path, const matching::Correspondences& c) {
  std::string text;
  char line[128];
  for (size_t i = 0; i < c.size(); ++i) {
    std::snprintf(line, sizeof(line), "%.3f %.3f %.3f %.3f\n", c.ref[i].x(), c.ref[i].y(), c.query[i].x(),
                  c.query[i].y());
    text += line;
  }
  WriteFileAtomic(path, text.data(), text.size());
}

}  // namespace freeloc::cli
