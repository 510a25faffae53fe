// libFuzzer target: the pickle reader (ParsePickle) and the walks over what it returns (Repr, Find).
#include "freeloc/io/pickle.h"

#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] {
    io::PickleLimits limits;
    limits.max_objects = 100000;  // the defaults allow hundreds of MB; keep each execution small
    io::PyRef r = io::ParsePickle(
        data, size, "fuzz.pkl", [](const io::PyRef&) { return io::PyObject::Str("storage"); }, nullptr, limits);
    (void)r->Repr(4000);
    (void)r->Find("a.0.b");
  });
  return 0;
}
