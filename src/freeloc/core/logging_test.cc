#include "freeloc/core/logging.h"

#include <gtest/gtest.h>

namespace freeloc {
namespace {

TEST(Logging, LevelsFilterAndStreamIsLazy) {
  const LogLevel saved = GetLogLevel();
  SetLogLevel(LogLevel::kWarning);
  EXPECT_TRUE(LogEnabled(LogLevel::kError));
  EXPECT_TRUE(LogEnabled(LogLevel::kWarning));
  EXPECT_FALSE(LogEnabled(LogLevel::kInfo));
  int evaluated = 0;
  auto side_effect = [&] { return ++evaluated; };
  FREELOC_LOG(INFO) << side_effect();
  EXPECT_EQ(evaluated, 0);
  testing::internal::CaptureStderr();
  FREELOC_LOG(WARNING) << "value " << side_effect();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(evaluated, 1);
  EXPECT_EQ(err, "freeloc warning: value 1\n");
  SetLogLevel(saved);
}

}  // namespace
}  // namespace freeloc
