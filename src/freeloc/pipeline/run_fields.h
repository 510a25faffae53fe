// The run family (core/option_family.h): every RunSpec field a user sets — `freeloc run`'s flags, Python's
// freeloc.run keywords and the run fields of an options file (`--options FILE`: a run's provenance read back) —
// declared once in run_fields.cc.
#pragma once

#include <string>

#include "freeloc/core/option_family.h"
#include "freeloc/pipeline/run_controller.h"

namespace freeloc::pipeline {

const OptionFamily& RunFamily();
// Sets one run field from its text form; throws OptionError naming the field (or the fields, for an unknown name).
void SetRunField(RunSpec* spec, const std::string& name, const std::string& text);
std::string GetRunField(const RunSpec& spec, const std::string& name);

}  // namespace freeloc::pipeline
