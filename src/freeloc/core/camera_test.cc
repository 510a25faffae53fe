#include "freeloc/core/camera.h"

#include <gtest/gtest.h>

#include "freeloc/core/error.h"

namespace freeloc {
namespace {

TEST(Camera, ProjectUnprojectRoundTrip) {
  Camera c{500, 510, 320.5, 239.5, 640, 480};
  const Eigen::Vector3d p(0.3, -0.2, 2.5);
  const Eigen::Vector2d px = c.Project(p);
  const Eigen::Vector3d ray = c.Unproject(px.x(), px.y());
  EXPECT_NEAR((ray * p.z() - p).norm(), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(c.K()(0, 0), 500);
  EXPECT_DOUBLE_EQ(c.K()(1, 2), 239.5);
}

TEST(Camera, ScaledFollowsPixelCentreConvention) {
  Camera c{100, 100, 319.5, 239.5, 640, 480};  // principal point at the exact image centre
  Camera s = c.Scaled(320, 240);
  EXPECT_DOUBLE_EQ(s.fx, 50);
  EXPECT_DOUBLE_EQ(s.cx, 159.5);  // still the exact centre of a 320-wide image
  EXPECT_DOUBLE_EQ(s.cy, 119.5);
}

TEST(Camera, FromString) {
  Camera c = Camera::FromString("525,526.5,319.5,239.5", "--ref-intrinsics");
  EXPECT_DOUBLE_EQ(c.fy, 526.5);
  EXPECT_THROW(Camera::FromString("525,526.5,319.5", "--ref-intrinsics"), Error);
  EXPECT_THROW(Camera::FromString("525,abc,319.5,1", "--ref-intrinsics"), Error);
  EXPECT_THROW(Camera::FromString("0,1,1,1", "--ref-intrinsics"), Error);
  try {
    Camera::FromString("1,2", "--query-intrinsics");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--query-intrinsics"), std::string::npos);
  }
}

}  // namespace
}  // namespace freeloc
