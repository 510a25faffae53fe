// The metric scale of a window of cameras from every depth map's anchoring at once (the Multi Frame track,
// pose/window_fusion.h). A window is an evaluated camera q and the frames j before it, each relocalized against a
// reference camera and related to q. Directions are what the images give well: each camera's ray towards the
// reference centre, and each frame's direction from q. Lengths come from depth maps, each of which may be off by its
// own global factor (a monocular map: ±20 %): a frame's distance to the reference as the reference map and as its own
// map anchor it, and a relation's length as q's map and the frame's map anchor it.
//
// The rays and directions fix the window's shape; every anchored length is then a measurement of one unknown scale
// through one map, and each map's error is a random effect shared by all its measurements (a map that is 10 % long
// makes every length it anchors 10 % long). The solution is the maximum a posteriori shape and scale of
//
//   Σ rays      ‖dir(P − c_j) − d_j‖² / σ_j²        P: the reference centre, c_j: frame j's centre (c_q = 0)
//   Σ baselines ‖dir(c_j) − u_j‖² / σ_u²
//   Σ lengths   (log ‖·‖ − e_map − anchored)² / se²
//   Σ maps      e_m² / σ_map²                        σ_map: estimated from the maps' own disagreement
//
// found by Levenberg–Marquardt (levenberg_marquardt.h). With M maps of equal quality the distance's scale error falls
// as σ_map/√M, where one frame's anchored answer, which averages two maps, has σ_map/√2. When the maps agree
// (σ_map at its floor) the shape's own uncertainties dominate and the evaluated camera's own anchoring stands.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace freeloc::geometry {

// A length anchored by one depth map: log of the length, its standard error; `has` false when that map gave none.
struct AnchoredLength {
  bool has = false;
  double log_length = 0, se = 0;
};

// One frame of the window other than the evaluated one, in the evaluated camera's axes.
struct WindowFrameGeometry {
  Eigen::Vector3d ray;       // unit direction from the frame's centre towards the reference centre
  double ray_sigma_rad = 0;  // its angular uncertainty
  Eigen::Vector3d baseline;  // the frame's centre relative to the evaluated camera (its direction is used; a metric
                             // length, if known, only starts the search)
  double baseline_sigma_rad = 0;
  AnchoredLength to_ref_by_ref, to_ref_by_own;    // ‖P − c_j‖: the reference map's and the frame's own
  AnchoredLength relation_by_q, relation_by_own;  // ‖c_j‖: the evaluated camera's map's and the frame's own
};

struct WindowScaleInput {
  Eigen::Vector3d ray;  // the evaluated camera's ray towards the reference centre
  double ray_sigma_rad = 0;
  AnchoredLength to_ref_by_ref, to_ref_by_own;  // ‖P‖: the reference map's and the evaluated camera's own
  std::vector<WindowFrameGeometry> frames;
  double min_map_sigma = 0.01;  // floor of σ_map (relative)
};

struct WindowScaleResult {
  bool ok = false;
  double distance = 0;             // ‖P‖, metres
  double log_sigma = 0;            // standard deviation of log ‖P‖
  double map_sigma = 0;            // σ_map the solution used
  int maps = 0;                    // depth maps that anchored at least one length
  Eigen::Vector3d reference;       // P
  std::vector<double> map_errors;  // fitted e_m: [0] reference, [1] evaluated camera, [2 + j] frame j
};

// Needs at least three maps with anchored lengths (else ok = false: a single frame's anchoring is as good).
WindowScaleResult EstimateWindowScale(const WindowScaleInput& input);

}  // namespace freeloc::geometry
