// The service family (core/option_family.h): every ServiceOptions field a user sets — `freeloc serve`'s flags and
// their ranges (checked at parse and by ServiceOptions::Validate) — declared once in service_fields.cc.
#pragma once

#include <string>

#include "freeloc/core/option_family.h"
#include "freeloc/service/server.h"

namespace freeloc::service {

const OptionFamily& ServiceFamily();
// Sets one field from its text form, checked against its row; throws OptionError naming the field.
void SetServiceField(ServiceOptions* options, const std::string& name, const std::string& text);
std::string GetServiceField(const ServiceOptions& options, const std::string& name);

}  // namespace freeloc::service
