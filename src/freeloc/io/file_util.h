// File helpers: whole-file reads, read-only memory maps, atomic writes (temp file in the same folder + rename).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace freeloc::io {

std::vector<uint8_t> ReadFileBytes(const std::string& path);

// A read-only (copy-on-write) memory map of a whole file. Empty files map to size 0.
class MappedFile {
 public:
  static std::shared_ptr<MappedFile> Open(const std::string& path);
  ~MappedFile();
  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }
  const std::string& path() const { return path_; }

 private:
  MappedFile() = default;
  std::string path_;
  uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

// Writes `bytes` to `path` atomically: a temporary file in the same folder, fsync, rename.
// A crash leaves either the old file or the new one, never a truncated file.
void WriteFileAtomic(const std::string& path, const void* bytes, size_t size);
// Before a long job writes anything: `path` can be written as a file (not a folder, its folder exists and takes a
// new file — probed, not assumed) / as a folder (an existing writable folder, or creatable in an existing one).
// Throws naming the path and `what` it is for.
void CheckWritableFile(const std::string& path, const std::string& what);
void CheckWritableFolder(const std::string& path, const std::string& what);
// Same, but the content is produced by `writer`, which gets the temporary file's path.
void WriteFileAtomicWith(const std::string& path, const std::function<void(const std::string& tmp_path)>& writer);

// A ZIP member's declared size, checked before anything is allocated for it: a stored member's size equals its
// compressed size, a compressed one expands at most ~1032x (deflate's bound; 1100x allowed, + 64 KiB). A forged
// header (a 544-byte ZIP declaring gigabytes) is refused, naming `what`.
void CheckZipMemberSize(uint64_t size, uint64_t compressed_size, bool stored, const std::string& what);

}  // namespace freeloc::io
