// Helpers shared by the libFuzzer targets (fuzz/*.cc): the input as a file for the path-based readers, and the one
// rule every target checks — a reader either returns or throws freeloc::Error; anything else (another exception, a
// crash, a sanitizer report, a hang) is a finding.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>

#include "freeloc/core/error.h"
#include "freeloc/io/tensor.h"

namespace freeloc::fuzz {

// Writes the input to a per-process file with extension `ext` (readers dispatch on it) and returns its path.
inline std::string AsFile(const uint8_t* data, size_t size, const char* ext) {
  const char* dir = std::getenv("FREELOC_FUZZ_TMP");
  std::string path = std::string(dir ? dir : "/tmp") + "/freeloc_fuzz_" + std::to_string(getpid()) + ext;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

// Reads every byte of a tensor, so that a view pointing outside its buffer is caught by ASan.
inline uint64_t Touch(const io::TensorView& t) {
  uint64_t s = 0;
  for (size_t k = 0; k < t.nbytes; ++k) s += t.data[k];
  return s;
}

// Reads the fuzzer's bytes as a stream of choices; past the end every choice is 0.
class Choices {
 public:
  Choices(const uint8_t* d, size_t n) : d_(d), n_(n) {}
  uint8_t Byte() { return i_ < n_ ? d_[i_++] : 0; }
  // An integer biased to the edges that break size arithmetic.
  int64_t Int() {
    switch (Byte() % 12) {
      case 0: return 0;
      case 1: return 1;
      case 2: return -1;
      case 3: return std::numeric_limits<int64_t>::max();
      case 4: return std::numeric_limits<int64_t>::min();
      case 5: return int64_t{1} << 62;
      case 6: return int64_t{1} << 61;
      case 7: return int64_t{1} << (Byte() % 63);
      case 8: {
        uint64_t v = 0;
        for (int k = 0; k < 8; ++k) v = v << 8 | Byte();
        return static_cast<int64_t>(v);
      }
      default: return Byte() % 24;
    }
  }

 private:
  const uint8_t* d_;
  size_t n_, i_ = 0;
};

template <class F>
void Expect(F&& f) {
  try {
    f();
  } catch (const freeloc::Error& e) {
    // The contract: a clear error. FREELOC_FUZZ_SHOW_ERRORS=1 prints it (replaying a corpus shows which checks its
    // inputs reach: `fuzz_<t>_replay DIR 2>&1 | sort | uniq -c`).
    static const bool show = std::getenv("FREELOC_FUZZ_SHOW_ERRORS") != nullptr;
    if (show) std::fprintf(stderr, "error: %s\n", e.what());
  }
}

}  // namespace freeloc::fuzz
