// libFuzzer target: .npy parsing on a buffer and .npz archives through ReadNpz (first byte selects).
#include "freeloc/io/npz.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] {
    if (size >= 2 && data[0] == 'P' && data[1] == 'K') {
      for (const auto& [name, a] : io::ReadNpz(fuzz::AsFile(data, size, ".npz"))) (void)a.shape.size();
    } else {
      const io::NpyArray a = io::ParseNpy(data, size, "fuzz.npy");
      (void)a.shape.size();
    }
  });
  return 0;
}
