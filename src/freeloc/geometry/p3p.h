// Perspective-three-point: J. A. Grunert, "Das pothenotische Problem in erweiterter Gestalt nebst Bemerkungen über
// seine Anwendung in der Geodäsie", 1841, in the formulation reviewed by Haralick, Lee, Ottenberg, Nölle, "Review
// and analysis of solutions of the three point perspective pose estimation problem", IJCV 13(3), 1994: the law of
// cosines on the three rays gives a quartic in the depth ratio v = s3/s1 (its coefficients are obtained here by
// polynomial arithmetic rather than written out), then the absolute orientation of the three recovered points.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/geometry/essential.h"

namespace freeloc::geometry {

// X[i]: 3D points in the source frame; b[i]: bearing vectors (any length) of the same points in the camera.
// Appends every pose (camera_from_source, x_cam = R·X + t) with all three points in front of the camera.
int P3P(const Eigen::Vector3d X[3], const Eigen::Vector3d b[3], std::vector<PoseRt>* poses);

// Least-squares rigid transform (Kabsch / Umeyama without scale): dst ≈ R·src + t.
PoseRt RigidAlign(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst);

}  // namespace freeloc::geometry
