#include "freeloc/eval/view3d.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

namespace freeloc::eval {

const char* View3dScript() {
  return R"JS(// freeloc's 3D view (src/freeloc/eval/view3d.cc): points and camera frusta, three.js.
"use strict";
function freelocView3d(box, view) {
  box.innerHTML = "";
  if (typeof THREE === "undefined") { box.textContent = "3D view: three.js is not installed (libjs-three)"; return null; }
  // Camera frames are OpenCV's (x right, y down, z forward); the scene root flips y and z to show them upright.
  const scene = new THREE.Scene(), root = new THREE.Group(); root.scale.set(1, -1, -1); scene.add(root);
  const s = view.scale > 0 ? view.scale : 1;
  if (view.points.length) {
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.Float32BufferAttribute(view.points, 3));
    g.setAttribute("color", new THREE.Float32BufferAttribute(view.colors.map(c => c / 255), 3));
    root.add(new THREE.Points(g, new THREE.PointsMaterial({size: 0.01 * s, vertexColors: true})));
  }
  for (const c of view.cameras) {
    // World (= reference camera) points of a camera with query_from_ref (R, t): centre −Rᵀt, axes Rᵀ.
    const R = c.R, t = c.t, k = c.K, d = 0.15 * s;
    const C = [0, 1, 2].map(i => -(R[i] * t[0] + R[3 + i] * t[1] + R[6 + i] * t[2]));
    const w = p => [0, 1, 2].map(i => C[i] + R[i] * p[0] + R[3 + i] * p[1] + R[6 + i] * p[2]);
    const corners = [[0, 0], [c.width, 0], [c.width, c.height], [0, c.height]]
        .map(([u, v]) => w([(u - k.cx) / k.fx * d, (v - k.cy) / k.fy * d, d]));
    const seg = [];
    for (let i = 0; i < 4; i++) seg.push(C, corners[i], corners[i], corners[(i + 1) % 4]);
    const g = new THREE.BufferGeometry(); g.setAttribute("position", new THREE.Float32BufferAttribute(seg.flat(), 3));
    root.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({color: c.color})));
  }
  const width = box.clientWidth || 640, height = box.clientHeight || 400;
  const cam = new THREE.PerspectiveCamera(50, width / height, 0.01 * s, 100 * s);
  cam.position.set(0.6 * s, 0.5 * s, 0.8 * s);
  const renderer = new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
  renderer.setSize(width, height); box.appendChild(renderer.domElement);
  const target = new THREE.Vector3(0, 0, -s);
  const controls = THREE.OrbitControls ? new THREE.OrbitControls(cam, renderer.domElement) : null;
  if (controls) { controls.target.copy(target); controls.update(); } else cam.lookAt(target);
  let alive = true;
  const frame = () => { if (!alive) return; renderer.render(scene, cam); requestAnimationFrame(frame); };
  frame();
  return {dispose: () => { alive = false; renderer.dispose(); }};
}
)JS";
}

std::string View3dJson(const Image& image, const DepthMap& depth, const Camera& k,
                       const std::vector<View3dCamera>& cameras, int max_points) {
  nlohmann::json pts = nlohmann::json::array(), cols = nlohmann::json::array();
  std::vector<float> zs;
  if (!depth.empty() && depth.width == image.width && depth.height == image.height && k.fx > 0 && k.fy > 0) {
    const int step = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(depth.width) * depth.height /
                                                                      std::max(1, max_points)))));
    for (int y = 0; y < depth.height; y += step)
      for (int x = 0; x < depth.width; x += step) {
        const float z = depth.at(x, y);
        if (!(z > 0 && std::isfinite(z))) continue;
        // Rounded to the millimetre: the view needs no more, and the JSON stays small.
        pts.push_back(std::round((x - k.cx) / k.fx * z * 1000) / 1000);
        pts.push_back(std::round((y - k.cy) / k.fy * z * 1000) / 1000);
        pts.push_back(std::round(z * 1000.0) / 1000);
        zs.push_back(z);
        for (int c = 0; c < 3; ++c) cols.push_back(image.at(x, y, c));
      }
  }
  double scale = 1;
  if (!zs.empty()) {
    std::nth_element(zs.begin(), zs.begin() + zs.size() / 2, zs.end());
    scale = zs[zs.size() / 2];
  }
  nlohmann::json cams = nlohmann::json::array();
  for (const auto& c : cameras) {
    const Eigen::Matrix3d R = c.query_from_ref.rotation.toRotationMatrix();
    nlohmann::json r = nlohmann::json::array();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.push_back(R(i, j));
    const Eigen::Vector3d& t = c.query_from_ref.translation;
    cams.push_back({{"R", r},
                    {"t", {t.x(), t.y(), t.z()}},
                    {"K", {{"fx", c.camera.fx}, {"fy", c.camera.fy}, {"cx", c.camera.cx}, {"cy", c.camera.cy}}},
                    {"width", c.camera.width},
                    {"height", c.camera.height},
                    {"color", c.colour},
                    {"label", c.label}});
  }
  return nlohmann::json{{"points", pts}, {"colors", cols}, {"cameras", cams}, {"scale", scale}}.dump();
}

}  // namespace freeloc::eval
