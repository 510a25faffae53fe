#include "freeloc/core/limits.h"

#include <cctype>
#include <cstdlib>

#include "freeloc/core/env.h"
#include "freeloc/core/error.h"

namespace freeloc {

namespace {

struct Field {
  const char* name;
  int64_t InputLimits::*member;
  const char* help;
};

constexpr Field kFields[] = {
    {"max_image_pixels", &InputLimits::max_image_pixels, "pixels a photo's header may declare (Pillow's bound)"},
    {"max_zip_member_bytes", &InputLimits::max_zip_member_bytes, "a ZIP member's decompressed size, bytes"},
    {"max_submission_bytes", &InputLimits::max_submission_bytes, "one pose_*.txt of a submission, bytes"},
    {"max_tensors", &InputLimits::max_tensors, "tensors in one safetensors, .pth or .npz file"},
    {"max_pickle_objects", &InputLimits::max_pickle_objects, "values a .pth pickle may push"}};

int64_t ParsePositive(const std::string& name, const std::string& value, const std::string& source) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(value.c_str(), &end, 10);
  FREELOC_CHECK(!value.empty() && end && *end == '\0' && errno == 0 && v > 0,
                source << ": limit " << name << " must be a positive integer, got '" << SafeText(value) << "'");
  return v;
}

const Field& FindField(const std::string& name) {
  for (const Field& f : kFields)
    if (name == f.name) return f;
  std::string choices;
  for (const Field& f : kFields) choices += std::string(choices.empty() ? "" : ", ") + f.name;
  FREELOC_THROW("limit: unknown limit '" << SafeText(name) << "'; the limits are " << choices);
}

// The environment variable of a limit: max_tensors → FREELOC_LIMIT_MAX_TENSORS.
std::string EnvName(const std::string& name) {
  std::string env = "FREELOC_LIMIT_";
  for (char c : name) env += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return env;
}

InputLimits& Mutable() {
  static InputLimits limits = [] {
    InputLimits l;
    for (const Field& f : kFields) {
      const std::string env = EnvName(f.name);
      if (const char* v = EnvSwitch(env)) l.*(f.member) = ParsePositive(f.name, v, env);
    }
    return l;
  }();
  return limits;
}

}  // namespace

const OptionFamily& LimitsFamily() {
  static const OptionFamily family = [] {
    OptionFamily f;
    f.name = "limits";
    f.set_by = "--limit NAME=N (every command), FREELOC_LIMIT_<NAME>, freeloc.set_limit(NAME, N)";
    const InputLimits defaults;
    for (const Field& k : kFields) {
      FamilyField v;
      v.name = k.name;
      v.flag = "--limit " + std::string(k.name) + "=N";
      v.type = FieldType::kInteger;
      v.default_text = std::to_string(defaults.*(k.member));
      v.help = k.help;
      v.min = 1;
      f.fields.push_back(v);
    }
    return f;
  }();
  return family;
}

const InputLimits& Limits() { return Mutable(); }

void SetLimit(const std::string& name, const std::string& value) {
  const Field& f = FindField(name);
  Mutable().*(f.member) = ParsePositive(name, value, "limit");
}

void CheckLimit(const std::string& name, const std::string& value) {
  FindField(name);
  ParsePositive(name, value, "limit");
}

std::vector<std::string> LimitNames() {
  std::vector<std::string> out;
  for (const Field& f : kFields) out.push_back(f.name);
  return out;
}

std::string LimitHint(const std::string& name) {
  const Field& f = FindField(name);
  const std::string env = EnvName(name);
  return "limit " + name + " = " + std::to_string(Limits().*(f.member)) + "; raise the limit " + name + " (" + env +
         "=N in the environment; docs/formats.md \"Limits and safety\")";
}

}  // namespace freeloc
