#include "freeloc/inputs/input_options.h"

#include "freeloc/core/error.h"

namespace freeloc::inputs {

void InputOptions::Validate() const {
  FREELOC_OPTION_CHECK("max_side", max_side == 0 || (max_side >= 64 && max_side <= 1 << 16),
                       ": " << max_side << " is not 0 (full resolution) or a long side of 64 to 65536 pixels");
  FREELOC_OPTION_CHECK("network_max_side",
                       network_max_side == 0 || (network_max_side >= 512 && network_max_side <= 1 << 16),
                       ": " << network_max_side << " is not 0 (full resolution) or a long side of 512 to 65536 pixels");
  FREELOC_OPTION_CHECK(
      "depth_median_min_m", depth_median_min_m > 0 && depth_median_min_m < depth_median_max_m,
      ": " << depth_median_min_m << " must be > 0 and below depth_median_max_m (" << depth_median_max_m << ")");
  FREELOC_OPTION_CHECK("focal_min", focal_min > 0 && focal_min < focal_max,
                       ": " << focal_min << " must be > 0 and below focal_max (" << focal_max << ")");
  FREELOC_OPTION_CHECK("focal_aspect_max", focal_aspect_max >= 1, ": " << focal_aspect_max << " must be >= 1");
  FREELOC_OPTION_CHECK("principal_point_margin", principal_point_margin >= 0,
                       ": " << principal_point_margin << " must be >= 0");
}

}  // namespace freeloc::inputs
