#include "freeloc/matching/pixel_mapping.h"

namespace freeloc::matching {

Correspondences ToOriginalPixels(const std::vector<PixelMatch>& matches, const vision::Dust3rInput& ref,
                                 const vision::Dust3rInput& query) {
  Correspondences c;
  c.ref.reserve(matches.size());
  c.query.reserve(matches.size());
  for (const PixelMatch& m : matches) {
    double x1, y1, x2, y2;
    ref.ToOriginal(m.x1, m.y1, &x1, &y1);
    query.ToOriginal(m.x2, m.y2, &x2, &y2);
    c.ref.emplace_back(x1, y1);
    c.query.emplace_back(x2, y2);
  }
  return c;
}

}  // namespace freeloc::matching
