// How the metric scale of an essential-matrix pose is found (metric_scale.h; an option of the pipeline; light header).
#pragma once

#include "freeloc/core/enum_table.h"

namespace freeloc::geometry {

// kOfficial: the benchmark's vote; kRobust: freeloc's vote; kAnchored: the depths anchor |t| (metric_scale.h).
enum class ScaleMethod { kOfficial, kRobust, kAnchored };

}  // namespace freeloc::geometry

namespace freeloc {
template <>
struct EnumTable<geometry::ScaleMethod> {
  static constexpr const char* kField = "scale";
  static constexpr EnumEntry<geometry::ScaleMethod> kEntries[] = {{geometry::ScaleMethod::kRobust, "robust"},
                                                                  {geometry::ScaleMethod::kOfficial, "official"},
                                                                  {geometry::ScaleMethod::kAnchored, "anchored"}};
};
}  // namespace freeloc
