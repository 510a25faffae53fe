// libFuzzer target: the map-free text files — intrinsics.txt (ReadIntrinsicsFile) and poses.txt / pose_*.txt
// (ParseOfficialPoses, with and without the confidence column).
#include "freeloc/io/mapfree.h"
#include "freeloc/io/submission.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] { (void)io::ReadIntrinsicsFile(fuzz::AsFile(data, size, ".txt")).size(); });
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::Expect([&] { (void)io::ParseOfficialPoses(text, true).size(); });
  fuzz::Expect([&] { (void)io::ParseOfficialPoses(text, false).size(); });
  return 0;
}
