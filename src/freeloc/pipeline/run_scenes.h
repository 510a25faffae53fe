// The run controller's scenes (run_controller.h): shards, the scenes of a split, every scene read before any work,
// and the scenes' assignment to MPI ranks. Internal to the run controller.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "freeloc/io/mapfree.h"
#include "freeloc/pipeline/options.h"

namespace freeloc::pipeline {

// Every scene read before any work: a missing or malformed intrinsics.txt/poses.txt is one error now, not after
// hours, and a provided-depth suffix must exist for at least one reference (a typo is an error, not N failures).
std::map<std::string, io::MapfreeScene> LoadScenes(const std::string& split_dir, const std::vector<std::string>& scenes,
                                                   const PipelineOptions& o);

// Scenes over ranks: longest first (by query count, then name) to the least loaded rank (ties: the lowest) —
// deterministic, so every rank computes the same assignment.
std::vector<std::vector<std::string>> AssignScenes(const std::vector<std::string>& scenes,
                                                   const std::map<std::string, io::MapfreeScene>& loaded, int ranks);

}  // namespace freeloc::pipeline
