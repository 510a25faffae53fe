#include "freeloc/io/file_util.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"

namespace freeloc::io {

std::vector<uint8_t> ReadFileBytes(const std::string& path) {
  std::error_code ec;
  FREELOC_CHECK(std::filesystem::exists(path, ec), path << ": file not found; check the path");
  FREELOC_CHECK(!std::filesystem::is_directory(path, ec), path << ": is a folder, expected a file");
  FREELOC_CHECK(std::filesystem::is_regular_file(path, ec),
                path << ": not a regular file (a FIFO or device); give a file");
  std::ifstream f(path, std::ios::binary);
  FREELOC_CHECK(f.good(), path << ": cannot open for reading (" << std::strerror(errno) << ")");
  f.seekg(0, std::ios::end);
  const std::streamoff n = f.tellg();
  // A "regular" file without a size (/proc, some FUSE files) tells -1: refused, never a size_t of 2^64 − 1.
  FREELOC_CHECK(n >= 0, path << ": cannot tell its size (not a plain file on disk?); copy it to a file and give that");
  f.seekg(0);
  std::vector<uint8_t> bytes(static_cast<size_t>(n));
  if (n > 0) f.read(reinterpret_cast<char*>(bytes.data()), n);
  FREELOC_CHECK(f.good() || n == 0, path << ": read error");
  return bytes;
}

std::shared_ptr<MappedFile> MappedFile::Open(const std::string& path) {
  std::shared_ptr<MappedFile> m(new MappedFile());
  m->path_ = path;
  // O_NONBLOCK: opening a FIFO must not wait for a writer; anything but a regular file is refused right after.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK);
  FREELOC_CHECK(fd >= 0, path << ": cannot open (" << std::strerror(errno) << "); check the path");
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    FREELOC_THROW(path << ": not a regular file (a folder, FIFO or device); give a file");
  }
  m->size_ = static_cast<size_t>(st.st_size);
  if (m->size_ > 0) {
    void* p = ::mmap(nullptr, m->size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (p == MAP_FAILED) {
      ::close(fd);
      FREELOC_THROW(path << ": cannot memory-map (" << std::strerror(errno) << ")");
    }
    m->data_ = static_cast<uint8_t*>(p);
  }
  ::close(fd);
  return m;
}

MappedFile::~MappedFile() {
  if (data_) ::munmap(data_, size_);
}

void WriteFileAtomicWith(const std::string& path, const std::function<void(const std::string&)>& writer) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  FREELOC_CHECK(fs::is_directory(dir, ec),
                path << ": the folder " << dir.string() << " does not exist; create it first");
  std::random_device rd;
  const std::string tmp =
      (dir / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()) + "_" + std::to_string(rd())))
          .string();
  try {
    writer(tmp);
    const int fd = ::open(tmp.c_str(), O_RDONLY);
    if (fd >= 0) {
      // A full disk or a failing network file system may only show here: never rename a file that did not land.
      const bool synced = ::fsync(fd) == 0 || errno == EINVAL;
      ::close(fd);
      FREELOC_CHECK(synced, path << ": writing failed (" << std::strerror(errno) << "); check free disk space");
    }
    fs::rename(tmp, target, ec);
    FREELOC_CHECK(!ec, path << ": cannot move the finished file into place (" << ec.message() << ")");
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
}

void CheckWritableFile(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  FREELOC_CHECK(!path.empty(), what << ": no path given");
  FREELOC_CHECK(!fs::is_directory(path, ec), path << ": is a folder, but " << what << " is a file; give a file path");
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  FREELOC_CHECK(fs::is_directory(dir, ec),
                path << ": the folder " << dir.string() << " does not exist; create it first (" << what << ")");
  // A real probe (as root, access(2) says yes even on a read-only mount): create and remove a file beside it.
  std::string probe = (dir / ("." + target.filename().string() + ".probeXXXXXX")).string();
  const int fd = ::mkstemp(probe.data());
  FREELOC_CHECK(fd >= 0, path << ": cannot write in " << dir.string() << " (" << std::strerror(errno) << "); "
                              << "choose a writable place for " << what);
  ::close(fd);
  fs::remove(probe, ec);
}

void CheckWritableFolder(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(path, ec)) {
    FREELOC_CHECK(fs::is_directory(path, ec),
                  path << ": is a file, but " << what << " is a folder; give a folder path");
    CheckWritableFile((fs::path(path) / "probe").string(), what);
    return;
  }
  fs::path p(path);
  if (!p.has_filename()) p = p.parent_path();  // "report/"
  const fs::path parent = p.has_parent_path() ? p.parent_path() : fs::path(".");
  FREELOC_CHECK(fs::is_directory(parent, ec),
                path << ": its folder " << parent.string() << " does not exist; create it first (" << what << ")");
  CheckWritableFile(p.string(), what);  // the folder will be created there
}

void WriteFileAtomic(const std::string& path, const void* bytes, size_t size) {
  WriteFileAtomicWith(path, [&](const std::string& tmp) {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    FREELOC_CHECK(f != nullptr, path << ": cannot write (" << std::strerror(errno) << ")");
    const size_t n = size ? std::fwrite(bytes, 1, size, f) : 0;
    bool ok = n == size && std::fflush(f) == 0;
    ok = std::fclose(f) == 0 && ok;  // always closed; a delayed write error shows here
    FREELOC_CHECK(ok, path << ": write failed (disk full?)");
  });
}

void CheckZipMemberSize(uint64_t size, uint64_t compressed_size, bool stored, const std::string& what) {
  const bool ok = stored ? size == compressed_size
                         : compressed_size <= (UINT64_MAX - 65536) / 1100 && size <= compressed_size * 1100 + 65536;
  FREELOC_CHECK(ok, what << ": declares " << size << " bytes from " << compressed_size << " compressed ("
                         << (stored ? "stored" : "compressed")
                         << "), more than any real archive holds; the file is damaged or hostile");
  FREELOC_CHECK(stored || size <= static_cast<uint64_t>(Limits().max_zip_member_bytes),
                what << ": expands to " << size << " bytes, beyond the " << LimitHint("max_zip_member_bytes"));
}

}  // namespace freeloc::io
