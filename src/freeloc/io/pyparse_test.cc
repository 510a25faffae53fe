#include "freeloc/io/pyparse.h"

#include <gtest/gtest.h>

#include <cmath>

namespace freeloc::io::py {
namespace {

TEST(PyParse, FloatFollowsPythonRules) {
  double v;
  EXPECT_TRUE(ParseFloat("1.5", &v) && v == 1.5);
  EXPECT_TRUE(ParseFloat(" -2e-3\t", &v) && v == -2e-3);
  EXPECT_TRUE(ParseFloat("1_000.5", &v) && v == 1000.5);
  EXPECT_TRUE(ParseFloat(".5", &v) && v == 0.5);
  EXPECT_TRUE(ParseFloat("5.", &v) && v == 5.0);
  EXPECT_TRUE(ParseFloat("+3", &v) && v == 3.0);
  EXPECT_TRUE(ParseFloat("-Infinity", &v) && std::isinf(v) && v < 0);
  EXPECT_TRUE(ParseFloat("nan", &v) && std::isnan(v));
  EXPECT_TRUE(ParseFloat("NaN", &v) && std::isnan(v));
  for (const char* bad :
       {"", " ", "1__0", "_1", "1_", "0x10", "1e", "1.5.2", "abc", "1,5", ".", "e5", "nan(1)", "infinit", "--1"}) {
    EXPECT_FALSE(ParseFloat(bad, &v)) << bad;
  }
}

TEST(PyParse, IntAndFrameKey) {
  int64_t k;
  EXPECT_TRUE(ParseInt("00042", &k) && k == 42);
  EXPECT_TRUE(ParseInt(" +7 ", &k) && k == 7);
  EXPECT_TRUE(ParseInt("1_2", &k) && k == 12);
  EXPECT_FALSE(ParseInt("4.0", &k));
  EXPECT_FALSE(ParseInt("", &k));
  EXPECT_TRUE(FrameKey("seq1/frame_00123.jpg", &k) && k == 123);
  EXPECT_TRUE(FrameKey("seq1/frame_00123.png", &k) && k == 123);  // the extension is not checked
  EXPECT_TRUE(FrameKey("frame_-0012.jpg", &k) && k == -12);       // Python int() accepts a sign
  EXPECT_FALSE(FrameKey("seq1/frame_abcde.jpg", &k));
  EXPECT_FALSE(FrameKey(".jpg", &k));
  EXPECT_EQ(FrameSlice("ab"), "");
  EXPECT_EQ(FrameSlice("é0001x.jpg"), "0001x");  // code points, not bytes
  EXPECT_EQ(FrameSlice("12345678"), "1234");
}

TEST(PyParse, SplitAndStrip) {
  EXPECT_EQ(SplitSpace("a  b"), (std::vector<std::string>{"a", "", "b"}));
  EXPECT_EQ(SplitSpace(""), (std::vector<std::string>{""}));
  EXPECT_EQ(Strip("\t a b \r\n"), "a b");
  EXPECT_EQ(SplitLines("a\r\nb\rc\n\nd"), (std::vector<std::string>{"a", "b", "c", "", "d"}));
  EXPECT_EQ(SplitLines("a\n"), (std::vector<std::string>{"a"}));
}

TEST(PyParse, Utf8Validation) {
  EXPECT_TRUE(IsValidUtf8("plain"));
  EXPECT_TRUE(IsValidUtf8("h\xc3\xa9llo"));
  EXPECT_FALSE(IsValidUtf8("\xff\xfe"));
  EXPECT_FALSE(IsValidUtf8("\xc3"));          // truncated
  EXPECT_FALSE(IsValidUtf8("\xc0\xaf"));      // overlong
  EXPECT_FALSE(IsValidUtf8("\xed\xa0\x80"));  // surrogate
}

}  // namespace
}  // namespace freeloc::io::py
