// Enums with one string table each (COLMAP-style): the table is the only place an enum's text forms are written.
// Text enters the library once, where it is read (CLI flags, presets, JSON, Python keywords), through
// ParseEnum<E>; everything after that is typed. Errors name the option field and list the allowed values — never a
// command-line flag, so they read the same from C++, the CLI and Python.
//
//   enum class Fruit { kApple, kPear };
//   template <> struct EnumTable<Fruit> {
//     static constexpr const char* kField = "fruit";
//     static constexpr EnumEntry<Fruit> kEntries[] = {{Fruit::kApple, "apple"}, {Fruit::kPear, "pear"}};
//   };
//   ToString(Fruit::kPear) == "pear"; ParseEnum<Fruit>("apple") == Fruit::kApple;
//   ParseEnum<Fruit>("fig") throws "fruit: 'fig' is not one of apple, pear".
#pragma once

#include <string>
#include <type_traits>

#include "freeloc/core/error.h"

namespace freeloc {

template <typename E>
struct EnumEntry {
  E value;
  const char* name;
};

// Specialised next to each enum (see above).
template <typename E>
struct EnumTable;

// "a, b, c": the allowed text forms, in table order.
template <typename E>
std::string EnumNames() {
  std::string s;
  for (const auto& e : EnumTable<E>::kEntries) s += (s.empty() ? "" : ", ") + std::string(e.name);
  return s;
}

template <typename E, typename = std::enable_if_t<std::is_enum_v<E>>>
std::string ToString(E value) {
  for (const auto& e : EnumTable<E>::kEntries)
    if (e.value == value) return e.name;
  FREELOC_THROW(EnumTable<E>::kField << ": value " << static_cast<int>(value) << " has no name");
}

// Returns false (out untouched) when `text` is not a name of E.
template <typename E>
bool TryParseEnum(const std::string& text, E* out) {
  for (const auto& e : EnumTable<E>::kEntries)
    if (text == e.name) {
      *out = e.value;
      return true;
    }
  return false;
}

// Throws freeloc::Error "<field>: '<text>' is not one of <names>". `field` overrides the table's field name.
template <typename E>
E ParseEnum(const std::string& text, const char* field = nullptr) {
  E v{};
  FREELOC_CHECK(TryParseEnum(text, &v), (field ? field : EnumTable<E>::kField)
                                            << ": '" << text << "' is not one of " << EnumNames<E>());
  return v;
}

}  // namespace freeloc
