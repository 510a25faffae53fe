// How the Multi Frame fusion (window_fusion.h) treats the phone's tracking poses: an option of the pose room, in its
// own light header for PipelineOptions (pipeline/options.h).
#pragma once

#include "freeloc/core/enum_table.h"

namespace freeloc::pose {

// The phone's tracking poses (poses_device.txt). auto — used where they agree with the images, per window; use —
// trusted in the documented convention; ignore — never read.
enum class DevicePoseUse { kAuto, kUse, kIgnore };

}  // namespace freeloc::pose

namespace freeloc {
template <>
struct EnumTable<pose::DevicePoseUse> {
  static constexpr const char* kField = "device_poses";
  static constexpr EnumEntry<pose::DevicePoseUse> kEntries[] = {{pose::DevicePoseUse::kAuto, "auto"},
                                                                {pose::DevicePoseUse::kUse, "use"},
                                                                {pose::DevicePoseUse::kIgnore, "ignore"}};
};
}  // namespace freeloc
