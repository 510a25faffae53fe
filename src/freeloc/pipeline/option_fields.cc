// The option fields by name (options.h): one row per field with its text form both ways. This table is what the
// JSON provenance records, the CLI overrides and the Python keywords go through.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <type_traits>
#include <utility>

#include "freeloc/core/error.h"
#include "freeloc/core/option_family.h"
#include "freeloc/pipeline/options.h"

namespace freeloc::pipeline {

// The shortest text that reads back as `v` exactly (0.3, not 0.29999999999999999; 100, not 1e+02): for people and
// for the records alike (core/option_family.h).
std::string NumberText(double v) { return NumberToText(v); }

namespace {

std::string Real(double v) { return NumberText(v); }

double ParseReal(const std::string& name, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  FREELOC_OPTION_CHECK(name, !text.empty() && end == text.c_str() + text.size() && errno == 0 && std::isfinite(v),
                       ": '" << text << "' is not a finite number");
  return v;
}

int ParseInt(const std::string& name, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  FREELOC_OPTION_CHECK(name, !text.empty() && end == text.c_str() + text.size(),
                       ": '" << SafeText(text, 40) << "' is not an integer");
  FREELOC_OPTION_CHECK(name, errno == 0 && v >= -(1L << 30) && v <= (1L << 30),
                       ": " << SafeText(text, 40) << " is out of range (an integer option takes at most 1073741824)");
  return static_cast<int>(v);
}

// A field's text form both ways and its type in the table, chosen by the field's C++ type.
std::string Format(const std::string& v) { return v; }
std::string Format(int v) { return std::to_string(v); }
std::string Format(double v) { return Real(v); }
// A number whose absence means "the component's own default" (solve.threshold_px): the word `default`.
constexpr const char* kDefaultText = "default";
std::string Format(const std::optional<double>& v) { return v ? Real(*v) : kDefaultText; }
std::string Format(const MatcherSpec& v) { return v.ToString(); }
std::string Format(const DepthSpec& v) { return v.ToString(); }
template <typename E, typename = std::enable_if_t<std::is_enum_v<E>>>
std::string Format(E v) {
  return ToString(v);
}

void Parse(const char*, const std::string& text, std::string* out) { *out = text; }
void Parse(const char* name, const std::string& text, int* out) { *out = ParseInt(name, text); }
void Parse(const char* name, const std::string& text, double* out) { *out = ParseReal(name, text); }
// `default` (or -1, the spelling of records before 0.2) unsets it.
void Parse(const char* name, const std::string& text, std::optional<double>* out) {
  if (text == kDefaultText || text == "-1") {
    out->reset();
    return;
  }
  *out = ParseReal(name, text);
}
void Parse(const char*, const std::string& text, MatcherSpec* out) { *out = MatcherSpec::FromString(text); }
void Parse(const char*, const std::string& text, DepthSpec* out) { *out = DepthSpec::FromString(text); }
template <typename E, typename = std::enable_if_t<std::is_enum_v<E>>>
void Parse(const char* name, const std::string& text, E* out) {
  FREELOC_OPTION_CHECK(name, TryParseEnum(text, out), ": '" << text << "' is not one of " << EnumNames<E>());
}

template <typename T>
OptionType TypeOf() {
  return std::is_same_v<T, int>                                                  ? OptionType::kInt
         : std::is_same_v<T, double> || std::is_same_v<T, std::optional<double>> ? OptionType::kReal
                                                                                 : OptionType::kText;
}
template <typename T>
std::string ChoicesOf() {
  if constexpr (std::is_enum_v<T>) return EnumNames<T>();
  if constexpr (std::is_same_v<T, MatcherSpec>) return kMatcherChoices;
  if constexpr (std::is_same_v<T, DepthSpec>) return kDepthChoices;
  return "";
}

// A flag: its spelling, where it is offered and a second spelling.
struct Flag {
  constexpr Flag(const char* name, FlagScope scope, const char* alias = nullptr)
      : name(name), scope(scope), alias(alias) {}
  const char* name;
  FlagScope scope;
  const char* alias;
};
constexpr Flag kNoFlag(nullptr, FlagScope::kNone);

struct Row {
  OptionField field;
  std::function<std::string(const PipelineOptions&)> get;
  std::function<void(PipelineOptions*, const std::string&)> set;
};

template <typename T>
OptionField Field(const char* name, Flag flag, const char* help) {
  return {name, flag.name, flag.scope, flag.alias, TypeOf<T>(), help, ChoicesOf<T>()};
}

// One option: PART is the options part it lives in ("solve.", "instances."; empty for the route at the top) and
// MEMBER the field inside it, whose spelling is the option's public name (options.h). Its type, text forms and
// choices follow from the field's C++ type.
#define FREELOC_OPTION(PART, MEMBER, FLAG, HELP)                                                      \
  Row {                                                                                               \
    Field<std::decay_t<decltype(std::declval<PipelineOptions&>().PART MEMBER)>>(#MEMBER, FLAG, HELP), \
        [](const PipelineOptions& o) { return Format(o.PART MEMBER); },                               \
        [](PipelineOptions* o, const std::string& v) { Parse(#MEMBER, v, &o->PART MEMBER); }          \
  }

const std::vector<Row>& Rows() {
  static const std::vector<Row> rows = {
#include "freeloc/pipeline/option_table.def"
  };
  return rows;
}

#undef FREELOC_OPTION

const Row* FindRow(const std::string& name) {
  for (const Row& r : Rows())
    if (name == r.field.name) return &r;
  return nullptr;
}

const Row& Find(const std::string& name) {
  if (const Row* r = FindRow(name)) return *r;
  std::string names;
  for (const Row& r : Rows()) names += (names.empty() ? "" : ", ") + std::string(r.field.name);
  FREELOC_THROW(name << ": not an option; the options are " << names);
}

}  // namespace

const std::vector<OptionField>& OptionFields() {
  static const std::vector<OptionField> fields = [] {
    std::vector<OptionField> f;
    for (const Row& r : Rows()) f.push_back(r.field);
    return f;
  }();
  return fields;
}

void SetOption(PipelineOptions* options, const std::string& name, const std::string& value) {
  Find(name).set(options, value);
}

std::string GetOption(const PipelineOptions& options, const std::string& name) { return Find(name).get(options); }

const OptionField& FindOptionField(const std::string& name) { return Find(name).field; }

const OptionField* FindOptionFieldOrNull(const std::string& name) {
  const Row* r = FindRow(name);
  return r ? &r->field : nullptr;
}

std::string OptionTableMarkdown() {
  const PipelineOptions defaults;
  std::string md =
      "| option (`--set NAME=…`, Python keyword, JSON key) | flag | type | default | what it sets |\n"
      "|---|---|---|---|---|\n";
  for (const Row& r : Rows()) {
    std::string value = r.get(defaults);
    if (r.field.type == OptionType::kReal && value != kDefaultText)
      value = NumberText(std::strtod(value.c_str(), nullptr));
    const char* type = r.field.type == OptionType::kInt    ? "integer"
                       : r.field.type == OptionType::kReal ? "number"
                                                           : "text";
    std::string flag = r.field.flag ? std::string("`") + r.field.flag + "`" : "–";
    if (r.field.alias) flag += std::string(", `") + r.field.alias + "`";
    const std::string help = r.field.help + (r.field.choices.empty() ? "" : "; one of " + r.field.choices);
    md += std::string("| `") + r.field.name + "` | " + flag + " | " + type + " | " +
          (value.empty() ? "–" : "`" + value + "`") + " | " + MarkdownCell(help) + " |\n";
  }
  return md;
}

}  // namespace freeloc::pipeline
