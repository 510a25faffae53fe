// Relative pose from 3 correspondences with affine depth in both views: the reference depth known up to a shift,
// the query depth up to a scale and a shift — the scale-and-shift minimal case of RePoseD (Ding, Kocur, Vávra,
// Haladová, Yang, Sattler, Kukelova, "Fixing the Scale and Shift in Monocular Depth for Camera Pose Estimation",
// ICCV 2025; MADPose, Yu et al., CVPR 2025, models monocular depth the same way). Unknowns R, t, s, u, v with
//     s·(d_q,i + v)·y_i = R·((d_r,i + u)·x_i) + t .
// Rigid motion keeps the three side lengths: ‖A_ij(u)‖² = s²·‖B_ij(v)‖² for the sides ij of the triangle, each side
// quadratic in its shift. Eliminating s² leaves two equations quadratic in u and in v; their resultant in v is a
// polynomial of degree 8 in u, solved by Sturm bisection (polynomial.h). Each real root with positive depths and s²
// gives one pose (triangle alignment, relpose_depth_3pt.h). Our derivation, not the authors' quartic formulation:
// it is slower (µs instead of sub-µs) but exact and simple to check.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "freeloc/geometry/relpose_depth_3pt.h"

namespace freeloc::geometry {

// As RelPoseDepthScale3pt, with shift_ref and shift_query free. Appends every admissible solution (≤ 8); returns
// their number.
int RelPoseDepthShift3pt(const Eigen::Vector3d x[3], const double dr[3], const Eigen::Vector3d y[3], const double dq[3],
                         std::vector<DepthRelPose>* out);

}  // namespace freeloc::geometry
