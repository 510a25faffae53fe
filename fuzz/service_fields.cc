// libFuzzer target: the service's text fields — `intrinsics` (fx,fy,cx,cy, Camera::FromString) as a client sends it.
// A camera given back must be finite with positive focals.
#include <cmath>
#include <cstdlib>

#include "freeloc/core/camera.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::Expect([&] {
    const Camera k = Camera::FromString(text, "intrinsics");
    if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy) && k.fx > 0 &&
          k.fy > 0))
      std::abort();
  });
  return 0;
}
