// libFuzzer target, structure-aware: the fuzzer's bytes choose the *metadata* of a well-formed torch.save checkpoint
// (storage classes, declared element counts, record lengths, and each tensor's storage, offset, size and stride),
// tests/testing/pth_builder.h writes it, and Checkpoint::Open reads it with every tensor touched. Byte-level
// mutation of a .pth almost never yields a valid zip + pickle whose metadata lies; this target does nothing else.
#include <cstdint>

#include "freeloc/io/checkpoint.h"
#include "fuzz_input.h"
#include "testing/pth_builder.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  static const char* kClasses[] = {"FloatStorage", "DoubleStorage", "HalfStorage", "BFloat16Storage", "LongStorage",
                                   "IntStorage",   "ShortStorage",  "CharStorage", "ByteStorage",     "BoolStorage"};
  fuzz::Choices c(data, size);
  testing::PthSpec spec;
  const int storages = 1 + c.Byte() % 2;
  for (int s = 0; s < storages; ++s) {
    testing::PthStorageSpec st;
    st.key = std::to_string(s);
    const int cls = c.Byte() % 10;
    st.cls = kClasses[cls];
    st.declared_numel = c.Int();
    static const int kItem[] = {4, 8, 2, 2, 8, 4, 2, 1, 1, 1};
    const int64_t item = kItem[cls];
    switch (c.Byte() % 3) {
      case 0:  // exactly what the declared count needs, when that is small: valid storages reach the view checks
        st.record_bytes =
            st.declared_numel >= 0 && st.declared_numel <= 4096 ? static_cast<uint64_t>(st.declared_numel * item) : 0;
        break;
      case 1: st.record_bytes = c.Byte(); break;
      default: st.record_bytes = static_cast<uint64_t>(c.Byte()) * 8;
    }
    spec.storages.push_back(st);
  }
  const int tensors = 1 + c.Byte() % 3;
  for (int t = 0; t < tensors; ++t) {
    testing::PthTensorSpec ts;
    ts.name = "t" + std::to_string(t);
    ts.storage_key = std::to_string(c.Byte() % storages);
    ts.offset = c.Int();
    const int nd = c.Byte() % 5;
    for (int d = 0; d < nd; ++d) ts.shape.push_back(c.Int());
    const bool mismatched = c.Byte() % 16 == 0;  // stride of another rank now and then
    for (int d = 0; d < nd + (mismatched ? 1 : 0); ++d) ts.stride.push_back(c.Int());
    spec.tensors.push_back(ts);
  }
  const std::string path = fuzz::AsFile(nullptr, 0, ".pth");
  testing::WritePthSpec(path, spec);
  fuzz::Expect([&] {
    const io::Checkpoint ck = io::Checkpoint::Open(path);
    uint64_t sum = 0;
    for (const auto& name : ck.names()) sum += fuzz::Touch(ck.Get(name));
    if (sum == 1) std::fprintf(stderr, " ");
  });
  return 0;
}
