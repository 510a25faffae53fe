#include "freeloc/core/blas_select.h"

#include <dlfcn.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

namespace freeloc {

namespace {

std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  const size_t e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

}  // namespace

CpuDescription ParseCpuInfo(const std::string& text) {
  CpuDescription cpu;
  std::istringstream in(text);
  std::string line;
  int processors = 0;
  while (std::getline(in, line)) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = Trim(line.substr(0, colon)), value = Trim(line.substr(colon + 1));
    if (key == "processor" && ++processors > 1) break;  // the first processor's fields only
    if (key == "vendor_id") cpu.vendor = value;
    if (key == "model name") cpu.model_name = value;
    if (key == "flags") {
      std::istringstream fl(value);
      for (std::string f; fl >> f;) cpu.flags.insert(f);
    }
  }
  return cpu;
}

CpuDescription ThisCpu() {
  std::ifstream f("/proc/cpuinfo");
  std::stringstream ss;
  ss << f.rdbuf();
  return ParseCpuInfo(ss.str());
}

std::string ChooseOpenBlasCoretype(const CpuDescription& cpu, const std::string& reported) {
  if (reported.empty()) return "";  // not OpenBLAS
  // Cores whose kernels predate AVX: OpenBLAS reports them for CPUs it does not know (its fallback is by family).
  static const char* kGeneric[] = {"prescott",  "core2",      "penryn",    "dunnington", "nehalem", "atom",
                                   "katmai",    "coppermine", "northwood", "banias",     "opteron", "opteron_sse3",
                                   "barcelona", "bobcat",     "nano",      "unknown",    "generic"};
  const std::string r = Lower(reported);
  const bool generic = std::find_if(std::begin(kGeneric), std::end(kGeneric), [&](const char* g) { return r == g; }) !=
                       std::end(kGeneric);
  if (!generic) return "";
  const bool avx512 = cpu.Has("avx512f") && cpu.Has("avx512bw") && cpu.Has("avx512vl") && cpu.Has("avx512dq");
  if (avx512) return cpu.Has("avx512_bf16") ? "Cooperlake" : "SkylakeX";
  if (cpu.Has("avx2") && cpu.Has("fma")) return cpu.vendor == "AuthenticAMD" ? "Zen" : "Haswell";
  if (cpu.Has("avx")) return "Sandybridge";
  return "";
}

std::string LoadedOpenBlasCore() {
  using CoreName = char* (*)();
  const auto fn = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  if (!fn) return "";
  const char* s = fn();
  return s ? Trim(s) : "";
}

}  // namespace freeloc
