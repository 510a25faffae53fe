// The benchmark's tracks (an option of the pipeline and the evaluator; light header).
#pragma once

#include "freeloc/core/enum_table.h"

namespace freeloc::io {

// The benchmark's tracks (docs/pipeline.md "Multi Frame"): single-frame — every query alone, scored on every 5th frame;
// multi-frame — each evaluated frame (linear positions 9, 19, … of the sorted seq1 frames) with the 8 frames before it.
enum class Track { kSingleFrame, kMultiFrame };

}  // namespace freeloc::io

namespace freeloc {
template <>
struct EnumTable<io::Track> {
  static constexpr const char* kField = "track";
  static constexpr EnumEntry<io::Track> kEntries[] = {{io::Track::kSingleFrame, "single-frame"},
                                                      {io::Track::kMultiFrame, "multi-frame"}};
};
}  // namespace freeloc
