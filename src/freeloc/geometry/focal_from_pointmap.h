// The focal length of a camera from its own pointmap, the principal point known — how DUSt3R/MASt3R (Wang et al.,
// "DUSt3R: Geometric 3D Vision Made Easy", CVPR 2024, §3.3 "Recovering intrinsics") give a camera to a photo without a
// calibration: every pixel (x, y) and its 3-D point (X, Y, Z) in the camera's frame should satisfy
// (x − cx, y − cy) = f · (X/Z, Y/Z). Upstream minimises Σ ‖(x − cx, y − cy) − f · (X/Z, Y/Z)‖ by the Weiszfeld
// iteration; freeloc does the same in ray space — Σ ‖(X/Z, Y/Z) − (x − cx, y − cy) / f‖, because the pixels are exact
// and the points are what is noisy (pixel space shrinks f by the noise's variance) — from the least-squares start,
// then Tukey's biweight (scale from the median residual) so that wrong points get no weight. One focal for both axes
// (square pixels), as upstream.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace freeloc::geometry {

struct FocalFromPointmapOptions {
  int max_iterations = 50;
  double tolerance = 1e-9;  // relative change of f that ends the iteration
};

// `pixels[i]` (image pixels) sees `points[i]` (the camera's frame). Points at Z <= 0 or not finite are skipped.
// Returns the focal in the pixels' units, or 0 when fewer than 8 points are usable or the points give no positive
// focal.
double FocalFromPointmap(const std::vector<Eigen::Vector2d>& pixels, const std::vector<Eigen::Vector3d>& points,
                         const Eigen::Vector2d& principal_point, const FocalFromPointmapOptions& options = {});

}  // namespace freeloc::geometry
