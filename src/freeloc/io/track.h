// The benchmark's tracks (an option of the pipeline and the evaluator; light header).
#pragma once

#include "freeloc/core/enum_table.h"

namespace freeloc {

// The benchmark's tracks (spec/mapfree-multiframe.md): single-frame — every query alone, scored on every 5th frame;
// multi-frame — each evaluated frame (linear positions 9, 19, … of the sorted seq1 frames) with the 8 frames before it.
enum class Track { kSingleFrame, kMultiFrame };
template <>
struct EnumTable<Track> {
  static constexpr const char* kField = "track";
  static constexpr EnumEntry<Track> kEntries[] = {{Track::kSingleFrame, "single-frame"},
                                                  {Track::kMultiFrame, "multi-frame"}};
};

}  // namespace freeloc
