#include "freeloc/core/progress.h"

#include <gtest/gtest.h>

namespace freeloc {
namespace {

TEST(Progress, RenderShowsCountRateAndEta) {
  const std::string s = ProgressBar::Render("queries", 10, 40, 5.0, 20);
  EXPECT_EQ(s, "queries [#####...............] 10/40 2.0/s ETA 15s");
}

TEST(Progress, RenderSlowRateAndDone) {
  EXPECT_EQ(ProgressBar::Render("scenes", 1, 4, 30.0, 4), "scenes [#...] 1/4 30.0s/it ETA 1m30s");
  EXPECT_EQ(ProgressBar::Render("scenes", 4, 4, 120.0, 4), "scenes [####] 4/4 30.0s/it ETA done in 2m00s");
  EXPECT_EQ(ProgressBar::Render("x", 0, 0, 0.0, 2), "x [..] 0/0 0.0/s ETA ?");
}

TEST(Progress, DisabledBarPrintsNothing) {
  testing::internal::CaptureStderr();
  {
    ProgressBar bar("work", 3, /*enabled=*/0);
    for (int i = 0; i < 3; ++i) bar.Increment();
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

TEST(Progress, EnabledBarDrawsFinalLine) {
  testing::internal::CaptureStderr();
  {
    ProgressBar bar("work", 2, /*enabled=*/1);
    bar.Increment();
    bar.SetLabel("scene 1/1, queries");  // `run` counts scenes in the label and queries in the bar
    bar.Increment();
  }
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("scene 1/1, queries [##############################] 2/2"), std::string::npos) << err;
  EXPECT_EQ(err.back(), '\n');
}

TEST(Progress, DurationFormat) {
  EXPECT_EQ(ProgressBar::FormatDuration(59.4), "59s");
  EXPECT_EQ(ProgressBar::FormatDuration(3725), "1h02m");
}

}  // namespace
}  // namespace freeloc
