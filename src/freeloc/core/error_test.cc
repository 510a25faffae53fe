#include "freeloc/core/error.h"

#include <gtest/gtest.h>

namespace freeloc {
namespace {

TEST(Error, CheckThrowsWithMessage) {
  const int w = 0;
  try {
    FREELOC_CHECK(w > 0, "img.png: width is " << w << "; re-export the image");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "img.png: width is 0; re-export the image");
  }
}

// The condition is evaluated once; the message only when the check fails (it may be costly to build).
TEST(Error, CheckEvaluatesItsConditionOnceAndItsMessageOnlyOnFailure) {
  int conditions = 0, messages = 0;
  const auto message = [&] { return ++messages, "failed"; };
  EXPECT_NO_THROW(FREELOC_CHECK(++conditions == 1, message()));
  EXPECT_EQ(conditions, 1);
  EXPECT_EQ(messages, 0);
  EXPECT_THROW(FREELOC_CHECK(++conditions == 1, message()), Error);
  EXPECT_EQ(conditions, 2);
  EXPECT_EQ(messages, 1);
}

TEST(Error, CheckOpShowsValues) {
  try {
    FREELOC_CHECK_EQ(3, 4, "shape mismatch");
    FAIL();
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("shape mismatch"), std::string::npos);
    EXPECT_NE(m.find("got 3 vs 4"), std::string::npos) << m;
  }
}

TEST(Error, FormatError) {
  EXPECT_EQ(FormatError("a.pth", "bad magic", "re-download it"), "a.pth: bad magic; re-download it");
  EXPECT_EQ(FormatError("", "bad magic"), "bad magic");
}

TEST(Error, IsRuntimeError) { EXPECT_THROW(FREELOC_THROW("x" << 1), std::runtime_error); }

}  // namespace
}  // namespace freeloc
