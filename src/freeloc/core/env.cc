#include "freeloc/core/env.h"

#include <cstdio>
#include <cstdlib>

namespace freeloc {

const std::vector<EnvVariable>& EnvVariables() {
  static const std::vector<EnvVariable> table = {
      {"FREELOC_MODELS", "list",
       "folders (':'-separated) searched for weights files after the models option (docs/models.md)"},
      {"FREELOC_LIMIT_<NAME>", "integer",
       "an input limit by its name in capitals (FREELOC_LIMIT_MAX_IMAGE_PIXELS); the limit option overrides it"},
      {"FREELOC_BLAS_SELECT", "switch",
       "0: keep OpenBLAS's own kernel choice (freeloc otherwise picks the kernels for the CPU it runs on)"},
      {"FREELOC_BLAS_ASSUME_REPORTED", "text",
       "act as if OpenBLAS had reported this core when choosing its kernels (tests)"},
      {"FREELOC_BLAS_SELECTED", "text",
       "set by freeloc itself when it runs again with the kernels it chose (reported -> chosen; shown by the version "
       "and the benchmarks) "
       "— not by users"},
      {"FREELOC_BF16", "text",
       "force: the bf16 matrix kernels wherever the CPU runs them, without measuring that they are faster"},
      {"FREELOC_ATTENTION", "text", "unfused: the op-by-op attention instead of the fused kernel (for checking)"},
      {"FREELOC_TENSOR_POOL", "text", "off: allocate every tensor afresh (no reuse between passes)"},
      {"FREELOC_DEBUG_CHECKS", "switch",
       "set: every error message names the source line that raised it (for bug reports)"},
  };
  return table;
}

const char* EnvSwitch(const std::string& name) {
  bool known = name.rfind("FREELOC_LIMIT_", 0) == 0;
  for (const EnvVariable& v : EnvVariables()) known = known || name == v.name;
  if (!known) {  // a programming error, not an input: the table in env.cc lacks the name
    std::fprintf(stderr, "freeloc: internal error: %s is not in the environment table (core/env.cc)\n", name.c_str());
    std::abort();
  }
  return std::getenv(name.c_str());
}

}  // namespace freeloc
