// Small helpers for the benchmark programs: timing, medians, peak RSS, Markdown tables.
#pragma once

#include <dlfcn.h>
#include <link.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace freeloc::bench {

// "CPU: <model name> (<n> threads; avx512f avx512_vnni avx512_bf16 …) · BLAS: <the libblas/libopenblas loaded, or
// none loaded>" — printed above every benchmark table (the machine differs between sessions).
inline std::string MachineLine() {
  std::ifstream f("/proc/cpuinfo");
  std::string line, model = "unknown", flags;
  int n = 0;
  while (std::getline(f, line)) {
    if (line.rfind("model name", 0) == 0 && model == "unknown") model = line.substr(line.find(':') + 2);
    if (line.rfind("processor", 0) == 0) ++n;
    if (line.rfind("flags", 0) == 0 && flags.empty()) flags = " " + line.substr(line.find(':') + 1) + " ";
  }
  std::string isa;
  for (const char* fl : {"avx2", "avx512f", "avx512_vnni", "avx512_bf16", "amx_tile"})
    if (flags.find(std::string(" ") + fl + " ") != std::string::npos) isa += std::string(isa.empty() ? "" : " ") + fl;
  std::string blas;
  dl_iterate_phdr(
      [](struct dl_phdr_info* info, size_t, void* data) {
        const std::string name = info->dlpi_name ? info->dlpi_name : "";
        if (name.find("blas") != std::string::npos || name.find("mkl") != std::string::npos) {
          auto* out = static_cast<std::string*>(data);
          *out += (out->empty() ? "" : ", ") + name;
        }
        return 0;
      },
      &blas);
  using CoreName = char* (*)();
  const auto corename = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  if (corename && corename()) {
    blas += std::string(" (OpenBLAS ") + corename() + " kernels";
    const char* sel = std::getenv("FREELOC_BLAS_SELECTED");
    const char* user = std::getenv("OPENBLAS_CORETYPE");
    blas += sel ? std::string(", selected by freeloc: ") + sel : user ? std::string(", OPENBLAS_CORETYPE=") + user : "";
    blas += ")";
  }
  return "CPU: " + model + " (" + std::to_string(n) + " threads; " + isa +
         ") · BLAS: " + (blas.empty() ? "none loaded by this program" : blas);
}

// "a,b,,c" → {"a", "b", "c"} (the benchmarks' comma-separated flags).
inline std::vector<std::string> SplitList(const std::string& s) {
  std::vector<std::string> v;
  std::stringstream ss(s);
  for (std::string x; std::getline(ss, x, ',');)
    if (!x.empty()) v.push_back(x);
  return v;
}

// The bundled TUM photos (data/demo/val/…) that texture the synthetic rooms of bench/baseline and bench/multiframe.
inline const std::vector<std::string>& DemoTexturePhotos() {
  static const std::vector<std::string> paths = {"s00001/seq0/frame_00000.png", "s00001/seq1/frame_00002.png",
                                                 "s00001/seq1/frame_00004.png", "s00002/seq0/frame_00000.png",
                                                 "s00003/seq0/frame_00000.png", "s00003/seq1/frame_00000.png",
                                                 "s00001/seq1/frame_00000.png"};
  return paths;
}

inline double NowSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

inline double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Peak resident set size of this process, in MB.
inline double PeakRssMB() {
  struct rusage ru {};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024.0;
}

// /proc/self/status's VmRSS (resident now) or VmHWM (the peak since start or since ResetPeakRss()), in MB; 0 where
// the file is absent.
inline double ProcStatusMB(const char* key) {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return 0;
  char line[256];
  double kb = 0;
  const size_t n = std::strlen(key);
  while (std::fgets(line, sizeof(line), f))
    if (!std::strncmp(line, key, n) && line[n] == ':') kb = std::atof(line + n + 1);
  std::fclose(f);
  return kb / 1024.0;
}
// Resets VmHWM to the present RSS (Linux: "5" to /proc/self/clear_refs), so a later ProcStatusMB("VmHWM") is the
// peak of what ran in between. False where the kernel does not allow it.
inline bool ResetPeakRss() {
  std::FILE* f = std::fopen("/proc/self/clear_refs", "w");
  if (!f) return false;
  const bool ok = std::fputs("5", f) >= 0;
  return std::fclose(f) == 0 && ok;
}

class MarkdownTable {
 public:
  explicit MarkdownTable(std::vector<std::string> header) : header_(std::move(header)) {}
  void Row(std::vector<std::string> cells) { rows_.push_back(std::move(cells)); }
  void Print() const {
    auto line = [](const std::vector<std::string>& c) {
      std::string s = "|";
      for (const auto& x : c) s += " " + x + " |";
      std::printf("%s\n", s.c_str());
    };
    line(header_);
    std::string sep = "|";
    for (size_t i = 0; i < header_.size(); ++i) sep += "---|";
    std::printf("%s\n", sep.c_str());
    for (const auto& r : rows_) line(r);
    std::fflush(stdout);
  }

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

inline std::string Fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), f, v);
  return buf;
}

// A deterministic pair of normalised (−1…1) 3×H×W network inputs, the same pixels in every network bench.
inline void SyntheticImagePair(int H, int W, std::vector<float>* img1, std::vector<float>* img2) {
  img1->resize(3 * static_cast<size_t>(H) * W);
  img2->resize(img1->size());
  for (size_t i = 0; i < img1->size(); ++i) {
    (*img1)[i] = static_cast<float>((i * 7919 % 255) / 127.5 - 1.0);
    (*img2)[i] = static_cast<float>((i * 104729 % 255) / 127.5 - 1.0);
  }
}

}  // namespace freeloc::bench
