// libFuzzer target: image decoding (DecodeImage: JPEG, PNG, BMP, TIFF, WebP) and 16-bit depth PNGs (ReadDepthPng).
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] {
    const Image img = io::DecodeImage(std::vector<uint8_t>(data, data + size), "fuzz.img");
    (void)img.width;
  });
  fuzz::Expect([&] { (void)io::ReadDepthPng(fuzz::AsFile(data, size, ".png")).width; });
  return 0;
}
