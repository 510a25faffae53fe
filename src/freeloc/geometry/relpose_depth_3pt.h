// Relative pose from 3 correspondences with depth in both views, the query depth known up to scale — the
// scale-only minimal case of RePoseD (Ding, Kocur, Vávra, Haladová, Yang, Sattler, Kukelova, "Fixing the Scale and
// Shift in Monocular Depth for Camera Pose Estimation", ICCV 2025). Unknowns: R, t (reference-depth units) and the
// query depth's scale s, with
//     s·d_q,i·y_i = R·(d_r,i·x_i) + t          (x, y: normalised rays with z = 1; d: z-depths)
// A rigid motion keeps distances, so s² is the ratio of the triangles' squared side lengths (least squares over the
// three sides); the rotation and translation then follow from aligning the two triangles (Kabsch). Exact data give
// the exact pose; a degenerate triangle (collinear or coincident points) gives no solution.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace freeloc::geometry {

// A relative pose with the depth models it implies: query-frame point = R·reference point + t, where the reference
// point is (d_r + shift_ref)·x and the query point is scale·(d_q + shift_query)·y.
struct DepthRelPose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double scale = 1;        // query depth → reference-depth units
  double shift_ref = 0;    // added to the reference depth (reference units)
  double shift_query = 0;  // added to the query depth (query units, before the scale)
};

// x[i], y[i]: normalised rays (z = 1) of correspondence i in the reference and the query; dr, dq: their depths
// (> 0). Appends at most one solution; returns the number appended.
int RelPoseDepthScale3pt(const Eigen::Vector3d x[3], const double dr[3], const Eigen::Vector3d y[3], const double dq[3],
                         std::vector<DepthRelPose>* out);

// The rigid motion (R, t) minimising Σ‖b_i − (R·a_i + t)‖² (Kabsch/Horn with the reflection fixed); false when the
// points span less than a plane (a line or a point).
bool AlignRigid(const Eigen::Vector3d* a, const Eigen::Vector3d* b, int n, Eigen::Matrix3d* R, Eigen::Vector3d* t);

}  // namespace freeloc::geometry
