// libFuzzer target: the EXIF path (io/exif.h) — the bounded APP1 walk, libexif's parse of the segment, the checked
// reading of every field and the intrinsics derived from them — for images of a few sizes.
#include "freeloc/io/exif.h"

#include <cmath>

#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] {
    const io::ExifInfo e = io::ReadExif(data, size);
    if (e.orientation < 0 || e.orientation > 8) std::abort();
    (void)io::OrientationText(e.orientation);
    for (auto [w, h] : {std::pair{640, 480}, std::pair{1, 1}, std::pair{65535, 3}}) {
      Camera k;
      std::string why;
      // A camera given back must be usable: finite, positive focals, centred principal point.
      if (io::CameraFromExif(e, w, h, &k, &why) &&
          !(std::isfinite(k.fx) && std::isfinite(k.fy) && k.fx > 0 && k.fy > 0 && k.cx == (w - 1) / 2.0))
        std::abort();
    }
  });
  return 0;
}
