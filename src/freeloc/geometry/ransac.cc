#include "freeloc/geometry/ransac.h"

#include "freeloc/core/error.h"

namespace freeloc::geometry {

void RansacOptions::Validate(const char* estimator) const {
  FREELOC_CHECK(success_prob > 0 && success_prob < 1, estimator << ": success_prob must be in (0, 1)");
  FREELOC_CHECK(min_iterations >= 0 && max_iterations >= 1 && min_iterations <= max_iterations,
                estimator << ": need 0 <= min_iterations <= max_iterations and max_iterations >= 1");
  FREELOC_CHECK(max_seconds >= 0 && std::isfinite(max_seconds), estimator << ": max_seconds must be >= 0");
  FREELOC_CHECK(sprt_min_data >= 0, estimator << ": sprt_min_data must be >= 0 (0: no sequential test)");
  FREELOC_CHECK(min_inlier_ratio > 0 && min_inlier_ratio < 1, estimator << ": min_inlier_ratio must be in (0, 1)");
  FREELOC_CHECK(give_up_prob > 0 && give_up_prob < 1, estimator << ": give_up_prob must be in (0, 1)");
}

}  // namespace freeloc::geometry
