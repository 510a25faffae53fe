// Pinhole camera (no distortion): K = [fx 0 cx; 0 fy cy; 0 0 1], pixel centres at integer coordinates.
#pragma once

#include <Eigen/Core>
#include <string>

namespace freeloc {

struct Camera {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;  // image size in pixels (0 when unknown)

  Eigen::Matrix3d K() const;
  // Pixel (x, y) → normalised image coordinates (x', y', 1).
  Eigen::Vector3d Unproject(double x, double y) const { return {(x - cx) / fx, (y - cy) / fy, 1.0}; }
  // Point in this camera's frame → pixel.
  Eigen::Vector2d Project(const Eigen::Vector3d& p) const { return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy}; }
  // The camera for the same image resized to (new_width, new_height) (pixel-centre convention).
  Camera Scaled(int new_width, int new_height) const;
  // Throws freeloc::Error naming `what` when focal lengths are not positive and finite.
  void Validate(const std::string& what) const;
  // Validate with the bounds of an image of `image_width` × `image_height` pixels when the camera carries no size
  // of its own: intrinsics given without one (flags, Python) meet the map-free reader's bounds once the image is read.
  void ValidateForImage(int image_width, int image_height, const std::string& what) const;

  // Parses "fx,fy,cx,cy" (the CLI's --intrinsics form).
  static Camera FromString(const std::string& text, const std::string& what);
};

}  // namespace freeloc
