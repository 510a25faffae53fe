#include "freeloc/pose/solve_options.h"

#include <cmath>

#include "freeloc/core/error.h"
#include "freeloc/geometry/absolute_pose.h"
#include "freeloc/geometry/hybrid_pose.h"
#include "freeloc/geometry/relative_pose.h"

namespace freeloc::pose {

void SolveOptions::Validate() const {
  FREELOC_OPTION_CHECK("threshold_px", !threshold_px || (std::isfinite(*threshold_px) && *threshold_px > 0),
                       ": " << *threshold_px << " is not a positive number of pixels (or default: the solver's own)");
  FREELOC_OPTION_CHECK("reprojection_px", std::isfinite(reprojection_px) && reprojection_px > 0,
                       ": " << reprojection_px << " is not a positive number of pixels");
  FREELOC_OPTION_CHECK("depth_shifts", depth_shifts == 0 || depth_shifts == 1,
                       ": " << depth_shifts << " is not 0 or 1");
  FREELOC_OPTION_CHECK("sprt_min_matches", sprt_min_matches >= 0,
                       ": " << sprt_min_matches << " is negative (0: always the full search)");
}

double SolveOptions::ThresholdPx(SolverKind solver) const { return threshold_px.value_or(DefaultThresholdPx(solver)); }

double DefaultThresholdPx(SolverKind solver) {
  switch (solver) {
    case SolverKind::kEssential: return geometry::RelativePoseOptions().threshold_px;
    case SolverKind::kHybrid: return geometry::HybridPoseOptions().threshold_px;
    case SolverKind::kPnp:
    case SolverKind::kProcrustes: return geometry::PnPOptions().threshold_px;
  }
  return geometry::RelativePoseOptions().threshold_px;
}

}  // namespace freeloc::pose
