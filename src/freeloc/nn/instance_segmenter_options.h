// The settings of SegGPT's instance propagation and its filters (instance_segmenter.h; an option of the pipeline;
// light header, torch-free).
#pragma once

namespace freeloc::nn {

struct InstanceSegmenterOptions {
  int max_batch = 8;            // instances per network call
  double min_score = 0.2;       // drop propagations whose foreground is barely painted
  double min_area_ratio = 0.1;  // query area / reference area (as image fractions) must lie in [min, max]
  double max_area_ratio = 10.0;
};

}  // namespace freeloc::nn
