#include "testing/testing.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include "freeloc/core/error.h"

namespace freeloc::testing {

std::string SharedDir() {
  if (const char* env = std::getenv("FREELOC_SHARED_DIR")) return env;
  return FREELOC_SHARED_DIR;
}
std::string SharedPath(const std::string& relative) { return SharedDir() + "/" + relative; }
bool SharedExists(const std::string& relative) { return std::filesystem::exists(SharedPath(relative)); }
std::string SourceDir() { return FREELOC_SOURCE_DIR; }
std::string TinyModelPath(const std::string& relative) {
  return std::string(FREELOC_TINY_MODELS_DIR) + (relative.empty() ? "" : "/" + relative);
}

std::vector<float> RandomImage(int h, int w, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<float> v(static_cast<size_t>(3) * h * w);
  for (auto& x : v) x = u(rng);
  return v;
}

std::string DemoPath(const std::string& relative) {
  return std::string(FREELOC_SOURCE_DIR) + "/data/demo" + (relative.empty() ? "" : "/" + relative);
}

TempDir::TempDir() {
  std::random_device rd;
  const auto base = std::filesystem::temp_directory_path();
  for (int attempt = 0; attempt < 100; ++attempt) {
    const auto p = base / ("freeloc_test_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
    if (std::filesystem::create_directory(p)) {
      path_ = p.string();
      return;
    }
  }
  throw std::runtime_error("cannot create a temporary folder");
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string ErrorOf(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const ::freeloc::Error& e) {
    return e.what();
  }
  return "";
}

void WriteText(const std::string& path, const std::string& text) { WriteBytes(path, text); }

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string ReadText(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace freeloc::testing
