// libFuzzer target: correspondence files (ReadCorrespondenceFile: text rows "x1 y1 x2 y2", or .npz by content).
#include "freeloc/io/correspondence_file.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] { (void)io::ReadCorrespondenceFile(fuzz::AsFile(data, size, ".txt")).size(); });
  return 0;
}
