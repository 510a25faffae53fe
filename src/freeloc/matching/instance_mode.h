// How an instance's pixels are fed to the pointmap network (an option of the pipeline; light header).
#pragma once

#include "freeloc/core/enum_table.h"

namespace freeloc::matching {

// kMask: I ⊙ Mask (the paper); kCrop: the masks' bounding boxes.
enum class InstanceMode { kMask, kCrop };

}  // namespace freeloc::matching

namespace freeloc {
template <>
struct EnumTable<matching::InstanceMode> {
  static constexpr const char* kField = "instance_mode";
  static constexpr EnumEntry<matching::InstanceMode> kEntries[] = {{matching::InstanceMode::kMask, "mask"},
                                                                   {matching::InstanceMode::kCrop, "crop"}};
};
}  // namespace freeloc
