// libFuzzer target: the Multi Frame track's tracking poses (poses_device.txt, ReadDevicePoses) — every pose it gives
// back must be usable: finite, a unit quaternion, a translation of metres (a file it cannot trust is an Error, and the
// scene falls back to its images).
#include <cmath>

#include "freeloc/io/mapfree.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] {
    for (const auto& [name, p] : io::ReadDevicePoses(fuzz::AsFile(data, size, ".txt"))) {
      if (name.empty() || !p.translation.allFinite() || !p.rotation.coeffs().allFinite() ||
          std::abs(p.rotation.norm() - 1) > 1e-6 || p.translation.cwiseAbs().maxCoeff() > 1000)
        std::abort();
    }
  });
  return 0;
}
