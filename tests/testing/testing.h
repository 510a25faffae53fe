// Helpers shared by freeloc's tests: where ../shared is, skipping when optional data is absent, temp folders.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace freeloc::testing {

// The `shared/` folder beside the checkout (fixtures, specs, data). FREELOC_SHARED_DIR overrides it.
std::string SharedDir();
std::string SharedPath(const std::string& relative);
bool SharedExists(const std::string& relative);
// The repository root.
std::string SourceDir();
// The bundled demo data (data/demo: TUM RGB-D scenes in the map-free layout, CC BY 4.0), always present.
std::string DemoPath(const std::string& relative = "");
// freeloc's own tiny random-weight models, written by the build (tests/tools/make_tiny_models.cc):
// "dust3r_tiny.pth", "mast3r_tiny.pth", "seggpt/model.safetensors", "metric3d/model.safetensors".
std::string TinyModelPath(const std::string& relative = "");
// A seeded normalised image for the networks: 3 × h × w values uniform in [−1, 1].
std::vector<float> RandomImage(int h, int w, uint32_t seed);

// A fresh empty folder under the system temp dir, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// The message of the freeloc::Error that `fn` throws; "" when it throws none.
std::string ErrorOf(const std::function<void()>& fn);

void WriteText(const std::string& path, const std::string& text);
void WriteBytes(const std::string& path, const std::string& bytes);
std::string ReadText(const std::string& path);

}  // namespace freeloc::testing

// Skips the current test with a clear message when a file of ../shared is absent.
#define FREELOC_REQUIRE_SHARED(relative)                                                          \
  do {                                                                                            \
    if (!::freeloc::testing::SharedExists(relative)) {                                            \
      GTEST_SKIP() << "skipped: " << ::freeloc::testing::SharedPath(relative)                     \
                   << " is absent (non-commercial data is read from ../shared, never committed)"; \
    }                                                                                             \
  } while (0)
