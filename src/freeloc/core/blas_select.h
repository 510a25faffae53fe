// The machine's speed by default: Debian's OpenBLAS 0.3.21 does not know recent CPUs (a 6th-generation
// Xeon is "Prescott" to it) and then runs its generic SSE kernels, 3–5× slower than the AVX-512 ones. This decides,
// from the CPU's flags and the core OpenBLAS reported, which OPENBLAS_CORETYPE would run the right kernels — never
// one the CPU cannot execute, nothing when OpenBLAS already chose well. Applied before OpenBLAS initialises: the CLI
// re-executes itself once with the variable set (cli/main.cc), the Python package sets it before loading its
// extension (python/freeloc/_blas.py, the same table). A user-set OPENBLAS_CORETYPE is always respected.
#pragma once

#include <set>
#include <string>

namespace freeloc {

struct CpuDescription {
  std::string vendor;           // "GenuineIntel", "AuthenticAMD", …
  std::string model_name;       // "Intel(R) Xeon(R) …"
  std::set<std::string> flags;  // /proc/cpuinfo "flags" of the first processor
  bool Has(const std::string& flag) const { return flags.count(flag) > 0; }
};

// Parses /proc/cpuinfo text (the first processor's fields).
CpuDescription ParseCpuInfo(const std::string& cpuinfo);
// This machine (/proc/cpuinfo; empty fields when unreadable).
CpuDescription ThisCpu();

// The OPENBLAS_CORETYPE to set, or "" to leave OpenBLAS's choice: `reported` is openblas_get_corename() ("" when
// the BLAS is not OpenBLAS). Generic cores (Prescott, Core2, Nehalem, Barcelona, …) on a CPU with AVX-512 F/BW/VL/DQ
// become Cooperlake (with AVX512-BF16) or SkylakeX, with AVX2 + FMA Haswell (Intel) or Zen (AMD), with AVX
// Sandybridge.
std::string ChooseOpenBlasCoretype(const CpuDescription& cpu, const std::string& reported);

// openblas_get_corename() of the OpenBLAS loaded in this process; "" when none is.
std::string LoadedOpenBlasCore();

}  // namespace freeloc
