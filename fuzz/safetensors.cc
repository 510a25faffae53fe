// libFuzzer target: SafetensorsFile::Parse on a buffer, every tensor touched.
#include "freeloc/io/safetensors.h"

#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] {
    const io::SafetensorsFile f = io::SafetensorsFile::Parse(data, size, nullptr, "fuzz.safetensors");
    uint64_t s = 0;
    for (const auto& name : f.names) s += fuzz::Touch(f.Get(name));
    if (s == 1) std::fprintf(stderr, " ");
  });
  return 0;
}
