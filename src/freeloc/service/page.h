// The web page of `freeloc serve` (GET /): anchors and queries by upload or drag and drop, the answer with the two
// photos and their matches, the depth maps, and a 3D view (three.js from libjs-three, served by freeloc: the page
// loads nothing from elsewhere) of the anchor's points and both cameras — predicted and, when given, true.
#pragma once

namespace freeloc::service {

const char* PageHtml();

}  // namespace freeloc::service
