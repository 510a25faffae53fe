// Helpers shared by the libFuzzer targets (fuzz/*.cc): the input as a file for the path-based readers, and the one
// rule every target checks — a reader either returns or throws freeloc::Error; anything else (another exception, a
// crash, a sanitizer report, a hang) is a finding.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
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
inline uint64_t Touch(const TensorView& t) {
  uint64_t s = 0;
  for (size_t k = 0; k < t.nbytes; ++k) s += t.data[k];
  return s;
}

template <class F>
void Expect(F&& f) {
  try {
    f();
  } catch (const freeloc::Error&) {
    // the contract: a clear error
  }
}

}  // namespace freeloc::fuzz
