// The environment switches freeloc reads (docs/formats.md "Option families"): one registry, so that a variable is
// declared once with its help and every read goes through it. EnvSwitch("FREELOC_MODELS") is std::getenv for a
// registered name; an unregistered one is a programming error (it throws).
#pragma once

#include <string>

#include "freeloc/core/option_family.h"

namespace freeloc {

// The family "environment": each variable (its name is the field's name and its "flag") with its values and help.
const OptionFamily& EnvironmentFamily();

// The variable's value, or nullptr when it is not set.
const char* EnvSwitch(const std::string& name);

}  // namespace freeloc
