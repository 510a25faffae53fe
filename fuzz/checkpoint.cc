// libFuzzer target: checkpoint files (.pth zip + pickle, safetensors) through Checkpoint::Open, every tensor touched.
#include "freeloc/io/checkpoint.h"

#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  const std::string path = fuzz::AsFile(data, size, ".pth");
  fuzz::Expect([&] {
    const io::Checkpoint c = io::Checkpoint::Open(path);
    uint64_t s = 0;
    for (const auto& name : c.names()) s += fuzz::Touch(c.Get(name));
    if (s == 1) std::fprintf(stderr, " ");
  });
  return 0;
}
