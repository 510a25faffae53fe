// Network pixels → original-image pixels (docs/architecture.md §2): undo DUSt3R's preprocessing (resize + centre crop)
// for each frame, pixel-centre convention, so correspondences leave `matching` ready for the geometry engine with each
// frame's own K.
#pragma once

#include <vector>

#include "freeloc/matching/correspondences.h"
#include "freeloc/matching/reciprocal.h"
#include "freeloc/vision/dust3r_preprocess.h"

namespace freeloc::matching {

Correspondences ToOriginalPixels(const std::vector<PixelMatch>& matches, const vision::Dust3rInput& ref,
                                 const vision::Dust3rInput& query);

}  // namespace freeloc::matching
