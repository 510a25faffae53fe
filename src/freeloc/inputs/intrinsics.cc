#include "freeloc/inputs/intrinsics.h"

#include "freeloc/core/logging.h"

namespace freeloc::inputs {

IntrinsicsChoice ChooseIntrinsics(const Camera* given, IntrinsicsSource given_source, const io::ExifInfo& exif,
                                  const Image& image, bool pointmap, const std::string& what, bool warn) {
  IntrinsicsChoice c;
  c.orientation = exif.orientation;
  if (given) {
    c.camera = *given;
    c.source = given_source;
    c.why = given_source == IntrinsicsSource::kFile ? "from the intrinsics file" : "given";
    return c;
  }
  Camera k;
  std::string refused;
  if (io::CameraFromExif(exif, image.PhotoWidth(), image.PhotoHeight(), &k, &c.why, &refused)) {
    c.camera = k;
    c.source = IntrinsicsSource::kExif;
    if (warn && !refused.empty())
      FREELOC_LOG(WARNING) << what << ": EXIF " << refused << "; using " << c.why << " instead";
    return c;
  }
  const bool had_focal = exif.focal_length_mm > 0 || exif.focal_length_35mm > 0 || exif.focal_plane_x_resolution > 0;
  if (warn && (had_focal || !exif.problems.empty())) {
    std::string problems;
    for (const auto& p : exif.problems) problems += "; " + p;
    FREELOC_LOG(WARNING) << what << ": its EXIF gives no usable focal length (" << c.why << problems << "); "
                         << (pointmap ? "estimating it from the pointmap instead" : "no other source");
  }
  c.source = pointmap ? IntrinsicsSource::kPointmap : IntrinsicsSource::kNone;
  return c;
}

}  // namespace freeloc::inputs
