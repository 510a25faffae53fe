// The option families besides PipelineOptions (pipeline/option_table.def): the run's (RunSpec), the service's
// (ServiceOptions), the input limits (limits.h) and the environment switches (env.h). Each field is declared once,
// as a row — its name (the Python keyword, the JSON key of an options file, `--limit NAME=`), its flag, type, range
// and help — and every surface is made from the rows: the command's flags and --help, the checks at parse and in
// Validate, `freeloc options --family NAME` (its Markdown is the docs' table), Python's keywords and
// freeloc.option_families(). A test walks every family and compares them.
#pragma once

#include <cmath>
#include <functional>
#include <string>
#include <type_traits>
#include <vector>

#include "freeloc/core/error.h"

namespace freeloc {

enum class FieldType { kText, kInteger, kNumber, kSwitch, kList };

struct FamilyField {
  std::string name;  // "report_worst"
  std::string flag;  // "--report-worst"; "" when the field has none
  FieldType type = FieldType::kText;
  std::string default_text;  // the value before anything sets it ("" when none)
  std::string help;
  double min = -INFINITY, max = INFINITY;  // integers and numbers: the range, inclusive
};

struct OptionFamily {
  std::string name;    // run | service | limits | environment
  std::string set_by;  // how a user sets it: "freeloc run flags, freeloc.run keywords, an options file"
  std::vector<FamilyField> fields;
};

// The family "environment": the table of env.h, each variable's name its field name and its "flag".
const OptionFamily& EnvironmentFamily();

// `text` as one Markdown table cell ("|" would end it); every generated options table uses it.
std::string MarkdownCell(const std::string& text);
// One Markdown table of a family (the docs' tables are these, `freeloc options --family NAME --markdown`).
std::string FamilyMarkdown(const OptionFamily& family);
const char* FieldTypeText(FieldType type);

// A field's value checked against its row: a number in range, an integer, a switch 0/1; throws
// OptionError(field name, what is wrong).
void CheckFieldText(const FamilyField& f, const std::string& text);

// The rows of a family over a struct S: each with its field, how to read it as text and how to set it from text
// (checked against the row). The families' .cc files build their tables from these.
template <typename S>
struct FamilyRow {
  FamilyField field;
  std::function<std::string(const S&)> get;
  std::function<void(S*, const std::string&)> set;
};

std::string NumberToText(double v);  // the shortest text that reads back exactly
double TextToNumber(const std::string& text);
std::vector<std::string> SplitList(const std::string& text);  // comma-separated, empty items dropped
std::string JoinList(const std::vector<std::string>& items);

template <typename S, typename T>
FamilyRow<S> Row(const char* name, const char* flag, T S::*member, const char* help, double min = -INFINITY,
                 double max = INFINITY) {
  FamilyRow<S> r;
  r.field.name = name;
  r.field.flag = flag;
  r.field.help = help;
  r.field.min = min;
  r.field.max = max;
  if constexpr (std::is_same_v<T, bool>) {
    r.field.type = FieldType::kSwitch;
    r.get = [member](const S& s) { return std::string(s.*member ? "1" : "0"); };
    r.set = [member, f = r.field](S* s, const std::string& v) {
      CheckFieldText(f, v);
      s->*member = v == "1" || v == "true";
    };
  } else if constexpr (std::is_integral_v<T>) {
    r.field.type = FieldType::kInteger;
    r.get = [member](const S& s) { return std::to_string(s.*member); };
    r.set = [member, f = r.field](S* s, const std::string& v) {
      CheckFieldText(f, v);
      s->*member = static_cast<T>(TextToNumber(v));
    };
  } else if constexpr (std::is_floating_point_v<T>) {
    r.field.type = FieldType::kNumber;
    r.get = [member](const S& s) { return NumberToText(s.*member); };
    r.set = [member, f = r.field](S* s, const std::string& v) {
      CheckFieldText(f, v);
      s->*member = static_cast<T>(TextToNumber(v));
    };
  } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
    r.field.type = FieldType::kList;
    r.get = [member](const S& s) { return JoinList(s.*member); };
    r.set = [member](S* s, const std::string& v) { s->*member = SplitList(v); };
  } else {
    r.field.type = FieldType::kText;
    r.get = [member](const S& s) { return std::string(s.*member); };
    r.set = [member](S* s, const std::string& v) { s->*member = v; };
  }
  return r;
}

// The family of `rows` with each field's default from a default S.
template <typename S>
OptionFamily FamilyOf(const std::string& name, const std::string& set_by, const std::vector<FamilyRow<S>>& rows) {
  OptionFamily f{name, set_by, {}};
  const S defaults{};
  for (const auto& r : rows) {
    FamilyField field = r.field;
    field.default_text = r.get(defaults);
    f.fields.push_back(field);
  }
  return f;
}

template <typename S>
const FamilyRow<S>& FindRow(const std::vector<FamilyRow<S>>& rows, const std::string& family, const std::string& name) {
  for (const auto& r : rows)
    if (r.field.name == name) return r;
  std::string names;
  for (const auto& r : rows) names += (names.empty() ? "" : ", ") + r.field.name;
  FREELOC_THROW(name << ": not a " << family << " option; the " << family << " options are " << names);
}

}  // namespace freeloc
