// libFuzzer target: submission ZIPs (ZipContents::Read) and the pose files inside them.
#include "freeloc/io/submission.h"

#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] {
    const io::ZipContents z = io::ZipContents::Read(fuzz::AsFile(data, size, ".zip"));
    for (const auto& [name, text] : z.files) (void)io::ParseOfficialPoses(text, true).size();
  });
  return 0;
}
