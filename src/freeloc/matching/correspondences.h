// The correspondences every matcher hands to the solvers: core/correspondences.h, named in this module's namespace.
#pragma once

#include "freeloc/core/correspondences.h"

namespace freeloc::matching {
using Correspondences = freeloc::Correspondences;
}  // namespace freeloc::matching
