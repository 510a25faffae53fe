// Which intrinsics a photo gets (docs/geometry.md "Intrinsics without a calibration"), one rule for every entry point
// (CLI, Python): handed in (flags, keywords, an intrinsics file) > the photo's EXIF (io/exif.h) > the focal of the
// photo's own pointmap (a DUSt3R/MASt3R matcher; the Relocalizer estimates it) > none, which the caller refuses with
// a message naming its own flags or keywords.
#pragma once

#include <string>

#include "freeloc/core/camera.h"
#include "freeloc/core/image.h"
#include "freeloc/inputs/input_options.h"
#include "freeloc/io/exif.h"

namespace freeloc::inputs {

struct IntrinsicsChoice {
  Camera camera;  // all zero for kPointmap (the Relocalizer fills it) and kNone
  IntrinsicsSource source = IntrinsicsSource::kNone;
  int orientation = 0;  // the EXIF orientation the decoder applied
  std::string why;      // the EXIF fields used, or why the EXIF gave none
};

// `given` (nullptr: none) came from `given_source` (kGiven or kFile); `image` is the photo as decoded (upright) and
// `exif` its EXIF; `pointmap`: the matcher can estimate a focal (PipelineOptions::UsesPointmapModel). EXIF that has
// focal fields but absurd or damaged values is said in one warning naming `what`, and the next source is used.
// `warn` false: no warning (a caller that prints `why` itself).
IntrinsicsChoice ChooseIntrinsics(const Camera* given, IntrinsicsSource given_source, const io::ExifInfo& exif,
                                  const Image& image, bool pointmap, const std::string& what, bool warn = true);

}  // namespace freeloc::inputs
