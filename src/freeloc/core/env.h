// The environment switches freeloc reads (docs/formats.md "Option families"): one table, so that a variable is
// declared once with its help and every read goes through it. EnvSwitch("FREELOC_MODELS") is std::getenv for a
// registered name; an unregistered one is a programming error (tests/docs/test_option_families.py finds every read;
// at run time it ends the process with a message). The family "environment" (option_family.h) is made from the table.
#pragma once

#include <string>
#include <vector>

namespace freeloc {

struct EnvVariable {
  const char* name;  // FREELOC_MODELS; FREELOC_LIMIT_<NAME> stands for every limit's
  const char* type;  // switch | text | list | integer
  const char* help;
};
const std::vector<EnvVariable>& EnvVariables();

// The variable's value, or nullptr when it is not set.
const char* EnvSwitch(const std::string& name);

}  // namespace freeloc
