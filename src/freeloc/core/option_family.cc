#include "freeloc/core/option_family.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "freeloc/core/env.h"

namespace freeloc {

const char* FieldTypeText(FieldType type) {
  switch (type) {
    case FieldType::kText: return "text";
    case FieldType::kInteger: return "integer";
    case FieldType::kNumber: return "number";
    case FieldType::kSwitch: return "switch";
    case FieldType::kList: return "list";
  }
  return "text";
}

std::string MarkdownCell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string NumberToText(double v) {
  char buf[32];
  // At least the integer digits, so that 120 is "120", not "1.2e+02".
  const int first =
      std::abs(v) >= 1 && std::abs(v) < 1e15 ? static_cast<int>(std::floor(std::log10(std::abs(v)))) + 1 : 1;
  for (int digits = first; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

double TextToNumber(const std::string& text) { return std::strtod(text.c_str(), nullptr); }

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

std::string JoinList(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& i : items) s += (s.empty() ? "" : ",") + i;
  return s;
}

void CheckFieldText(const FamilyField& f, const std::string& text) {
  if (f.type == FieldType::kSwitch) {
    FREELOC_OPTION_CHECK(f.name, text == "0" || text == "1" || text == "true" || text == "false",
                         ": '" << SafeText(text, 40) << "' is not 0 or 1");
    return;
  }
  if (f.type != FieldType::kInteger && f.type != FieldType::kNumber) return;
  errno = 0;
  char* end = nullptr;
  const double v = f.type == FieldType::kInteger ? static_cast<double>(std::strtoll(text.c_str(), &end, 10))
                                                 : std::strtod(text.c_str(), &end);
  FREELOC_OPTION_CHECK(
      f.name, !text.empty() && end && *end == 0 && errno == 0 && std::isfinite(v),
      ": '" << SafeText(text, 40) << "' is not " << (f.type == FieldType::kInteger ? "an integer" : "a finite number"));
  FREELOC_OPTION_CHECK(f.name, v >= f.min && v <= f.max,
                       ": " << SafeText(text, 40) << " is out of range (" << NumberToText(f.min) << " to "
                            << NumberToText(f.max) << ")");
}

namespace {
std::string Range(const FamilyField& f) {
  if (std::isinf(f.min) && std::isinf(f.max)) return "";
  if (std::isinf(f.max)) return " (≥ " + NumberToText(f.min) + ")";
  return " (" + NumberToText(f.min) + "–" + NumberToText(f.max) + ")";
}
}  // namespace

const OptionFamily& EnvironmentFamily() {
  static const OptionFamily family = [] {
    OptionFamily f;
    f.name = "environment";
    f.set_by = "the environment of freeloc, its Python module and the service";
    for (const EnvVariable& v : EnvVariables()) {
      FamilyField x;
      x.name = x.flag = v.name;
      const std::string t = v.type;
      x.type = t == "list"      ? FieldType::kList
               : t == "integer" ? FieldType::kInteger
               : t == "switch"  ? FieldType::kSwitch
                                : FieldType::kText;
      x.help = v.help;
      f.fields.push_back(x);
    }
    return f;
  }();
  return family;
}

std::string FamilyMarkdown(const OptionFamily& family) {
  std::string md = "| name | flag | type | default | what it sets |\n|---|---|---|---|---|\n";
  for (const FamilyField& f : family.fields)
    md += "| `" + f.name + "` | " + (f.flag.empty() ? "–" : "`" + f.flag + "`") + " | " + FieldTypeText(f.type) +
          " | " + (f.default_text.empty() ? "–" : "`" + f.default_text + "`") + " | " +
          MarkdownCell(f.help + Range(f)) + " |\n";
  return md;
}

}  // namespace freeloc
