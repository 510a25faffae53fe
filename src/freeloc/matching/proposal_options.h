// The settings of the reference-instance proposals (proposals.h; an option of the pipeline; light header).
#pragma once

namespace freeloc::matching {

struct ProposalOptions {
  double conf_quantile = 0.3;    // drop the least confident 30 % of pixels
  double depth_jump = 0.05;      // relative depth step that breaks a surface
  double normal_angle_deg = 35;  // normal change that breaks a surface
  double min_area = 0.01;        // fraction of the image
  int max_instances = 5;
  void Validate() const;
};

}  // namespace freeloc::matching
