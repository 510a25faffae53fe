// The 3D view of a relocalization, shared by `freeloc serve`'s page and the detail views of `run --report`: the
// reference's points (its depth back-projected, in the photo's colours) and camera frusta — reference, predicted
// query, true query when known — drawn with three.js (libjs-three) and orbitable (OrbitControls). The script defines
// `freelocView3d(container, view)`; the view is JSON made by View3dJson.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"
#include "freeloc/core/depth_map.h"
#include "freeloc/core/image.h"
#include "freeloc/core/rigid3d.h"

namespace freeloc::eval {

// The script (plain JavaScript, no module syntax; it needs THREE and, optionally, THREE.OrbitControls loaded first).
const char* View3dScript();

// Where three.js is installed (Debian's libjs-three): build/three.min.js and examples/js/controls/OrbitControls.js.
constexpr const char* kThreeJsDir = "/usr/share/javascript/three";

struct View3dCamera {
  Rigid3d query_from_ref;  // this camera's pose (identity: the reference)
  Camera camera;           // with its image size
  std::string colour;      // "#33dd66"
  std::string label;
};

// {"points": [x, y, z, …], "colors": [r, g, b, …], "cameras": [{"R": [9, row-major], "t": [3], "K": {…}, "width",
// "height", "color", "label"}], "scale"}: `depth` back-projected with `k_ref` on a grid of at most ~`max_points`
// pixels, coloured by `image` (same size as the depth; else no points).
std::string View3dJson(const Image& image, const DepthMap& depth, const Camera& k_ref,
                       const std::vector<View3dCamera>& cameras, int max_points = 30000);

}  // namespace freeloc::eval
