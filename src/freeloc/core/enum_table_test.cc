#include "freeloc/core/enum_table.h"

#include <gtest/gtest.h>

#include "freeloc/core/version.h"

namespace freeloc {

enum class Fruit { kApple, kPear };
template <>
struct EnumTable<Fruit> {
  static constexpr const char* kField = "fruit";
  static constexpr EnumEntry<Fruit> kEntries[] = {{Fruit::kApple, "apple"}, {Fruit::kPear, "pear"}};
};

namespace {

TEST(EnumTable, RoundTripsEveryEntry) {
  for (const auto& e : EnumTable<Fruit>::kEntries) {
    EXPECT_EQ(ToString(e.value), e.name);
    EXPECT_EQ(ParseEnum<Fruit>(e.name), e.value);
  }
  EXPECT_EQ(EnumNames<Fruit>(), "apple, pear");
}

TEST(EnumTable, UnknownTextNamesTheFieldAndTheChoices) {
  try {
    ParseEnum<Fruit>("fig");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "fruit: 'fig' is not one of apple, pear");
  }
  try {
    ParseEnum<Fruit>("Apple", "basket.fruit");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "basket.fruit: 'Apple' is not one of apple, pear");
  }
  Fruit f = Fruit::kPear;
  EXPECT_FALSE(TryParseEnum<Fruit>("", &f));
  EXPECT_EQ(f, Fruit::kPear);
  EXPECT_THROW(ToString(static_cast<Fruit>(7)), Error);
}

TEST(Version, IsTheProjectVersion) { EXPECT_STREQ(Version(), FREELOC_TEST_PROJECT_VERSION); }

}  // namespace
}  // namespace freeloc
