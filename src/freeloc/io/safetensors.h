// Safetensors reader (memory-mapped, fully validated) and writer (atomic).
// Format: u64 little-endian header length n, n bytes of JSON {name: {dtype, shape, data_offsets}, "__metadata__"},
// then the tensor bytes; offsets are relative to the end of the header.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "freeloc/io/tensor.h"

namespace freeloc::io {

class MappedFile;

struct SafetensorsFile {
  std::string path;
  std::vector<std::string> names;  // header order
  std::map<std::string, TensorView> tensors;
  std::map<std::string, std::string> metadata;  // "__metadata__"

  // Throws freeloc::Error naming the file and the problem on any malformed input.
  static SafetensorsFile Open(const std::string& path);
  // Same, over bytes already in memory (`owner` keeps them alive).
  static SafetensorsFile Parse(const uint8_t* bytes, size_t size, std::shared_ptr<const void> owner,
                               const std::string& what);
  const TensorView& Get(const std::string& name) const;
};

// Serialises tensors (in the given order) and metadata to safetensors bytes.
std::vector<uint8_t> SerializeSafetensors(const std::vector<std::pair<std::string, TensorView>>& tensors,
                                          const std::map<std::string, std::string>& metadata = {});
// Atomic write of the same.
void WriteSafetensors(const std::string& path, const std::vector<std::pair<std::string, TensorView>>& tensors,
                      const std::map<std::string, std::string>& metadata = {});

}  // namespace freeloc::io
