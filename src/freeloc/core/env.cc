#include "freeloc/core/env.h"

#include <cstdlib>

namespace freeloc {

const OptionFamily& EnvironmentFamily() {
  static const OptionFamily family = [] {
    OptionFamily f;
    f.name = "environment";
    f.set_by = "the environment of freeloc, its Python module and the service";
    const auto add = [&](const char* name, FieldType type, const char* help) {
      FamilyField v;
      v.name = v.flag = name;
      v.type = type;
      v.help = help;
      f.fields.push_back(v);
    };
    add("FREELOC_MODELS", FieldType::kList,
        "folders (':'-separated) searched for weights files after the models option (docs/models.md)");
    add("FREELOC_LIMIT_<NAME>", FieldType::kInteger,
        "an input limit by its name in capitals (FREELOC_LIMIT_MAX_IMAGE_PIXELS); the limit option overrides it");
    add("FREELOC_BLAS_SELECT", FieldType::kSwitch,
        "0: keep OpenBLAS's own kernel choice (freeloc otherwise picks the kernels for the CPU it runs on)");
    add("FREELOC_BLAS_ASSUME_REPORTED", FieldType::kText,
        "act as if OpenBLAS had reported this core when choosing its kernels (tests)");
    add("FREELOC_BLAS_SELECTED", FieldType::kText,
        "set by freeloc itself when it runs again with the kernels it chose (reported -> chosen; shown by the version "
        "and the benchmarks) "
        "— not by users");
    add("FREELOC_BF16", FieldType::kText,
        "force: the bf16 matrix kernels wherever the CPU runs them, without measuring that they are faster");
    add("FREELOC_ATTENTION", FieldType::kText,
        "unfused: the op-by-op attention instead of the fused kernel (for checking)");
    add("FREELOC_TENSOR_POOL", FieldType::kText, "off: allocate every tensor afresh (no reuse between passes)");
    add("FREELOC_DEBUG_CHECKS", FieldType::kSwitch,
        "set: every error message names the source line that raised it (for bug reports)");
    return f;
  }();
  return family;
}

const char* EnvSwitch(const std::string& name) {
  bool known = false;
  for (const FamilyField& f : EnvironmentFamily().fields) known = known || f.name == name;
  const std::string prefix = "FREELOC_LIMIT_";
  known = known || name.rfind(prefix, 0) == 0;
  FREELOC_CHECK(known, name << ": not a registered environment switch (core/env.cc)");
  return std::getenv(name.c_str());
}

}  // namespace freeloc
