// What a user hands in with a photo, as options and as a record (docs/formats.md "Plausible inputs"): the unit of
// integer depth maps, the bounds that refuse a well-formed file meaning something else (InputOptions, held by
// PipelineOptions as `inputs`), and the intrinsics a frame was given with where they came from (FrameIntrinsics,
// reported with every answer). Light header.
#pragma once

#include "freeloc/core/camera.h"
#include "freeloc/core/enum_table.h"

namespace freeloc::inputs {

// The unit of integer depth maps handed in (16-bit PNGs, uint16 arrays): mm (the map-free convention), cm or m.
// Float maps are metres whatever this says.
enum class DepthUnit { kMillimetre, kCentimetre, kMetre };

// What inputs handed in must look like to be taken as they say (inputs/input_checks.h, docs/formats.md "Plausible
// inputs"): the unit of integer depth maps and the bounds that refuse a well-formed file meaning something else —
// depth in the wrong unit, intrinsics normalised or in another order. Loosening a bound is recorded with the answer
// and lowers its confidence where the input needed it.
struct InputOptions {
  // The working resolution: photos are decoded and matched at most this many pixels on their long side (JPEG's
  // scaled decoding where it reaches); intrinsics, depth maps, matches and answers stay in the photo's own pixels.
  // 0: full resolution. max_side for SIFT, network_max_side for the DUSt3R/MASt3R matchers (their networks see 512
  // px; Metric3D's ViT about 1064). Chosen by measurement (docs/pipeline.md "Phone photos").
  int max_side = 1600;
  int network_max_side = 1024;
  DepthUnit depth_unit = DepthUnit::kMillimetre;
  double depth_median_min_m = 0.4;  // the valid depths' median, metres: below it the map is refused
  double depth_median_max_m = 100;  // … and above it
  double focal_min = 0.1;           // given focal lengths, in multiples of the image's long side
  double focal_max = 20;
  double focal_aspect_max = 1.1;      // max(fx, fy) / min(fx, fy)
  double principal_point_margin = 0;  // how far outside the image the principal point may lie, fraction of its size
  void Validate() const;
};

// Where a frame's intrinsics came from, in the order freeloc prefers them: handed in (flags, Python), a file
// (intrinsics.txt), the photo's EXIF, the pointmap's focal (DUSt3R/MASt3R). docs/geometry.md "Intrinsics without a
// calibration".
enum class IntrinsicsSource { kNone, kGiven, kFile, kExif, kPointmap };

struct FrameIntrinsics {
  Camera camera;  // all zero while kNone
  IntrinsicsSource source = IntrinsicsSource::kNone;
  int orientation = 0;        // the EXIF orientation the decoder applied to the photo (0: no tag, 1: as stored)
  double pointmap_focal = 0;  // the pointmap's focal when one was estimated (estimate or check), else 0
  bool known() const { return source != IntrinsicsSource::kNone; }
};

}  // namespace freeloc::inputs

namespace freeloc {
template <>
struct EnumTable<inputs::DepthUnit> {
  static constexpr const char* kField = "depth_unit";
  static constexpr EnumEntry<inputs::DepthUnit> kEntries[] = {
      {inputs::DepthUnit::kMillimetre, "mm"}, {inputs::DepthUnit::kCentimetre, "cm"}, {inputs::DepthUnit::kMetre, "m"}};
};
template <>
struct EnumTable<inputs::IntrinsicsSource> {
  static constexpr const char* kField = "intrinsics source";
  static constexpr EnumEntry<inputs::IntrinsicsSource> kEntries[] = {{inputs::IntrinsicsSource::kNone, "none"},
                                                                     {inputs::IntrinsicsSource::kGiven, "given"},
                                                                     {inputs::IntrinsicsSource::kFile, "file"},
                                                                     {inputs::IntrinsicsSource::kExif, "exif"},
                                                                     {inputs::IntrinsicsSource::kPointmap, "pointmap"}};
};
}  // namespace freeloc
