#include "datasets/sim/robot_spec.h"

#include <cmath>
#include <vector>

#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

TEST(LaserOptionsTest, BeamAnglesFollowTheFlaserConvention) {
  LaserOptions laser;
  laser.field_of_view_radians = M_PI;
  laser.num_beams = 361;  // odd: both ends included
  std::vector<double> angles = laser.BeamAnglesRadians();
  ASSERT_EQ(angles.size(), 361u);
  EXPECT_NEAR(angles.front(), -M_PI / 2, 1e-12);
  EXPECT_NEAR(angles.back(), M_PI / 2, 1e-12);
  EXPECT_NEAR(angles[180], 0.0, 1e-12);
  laser.num_beams = 360;  // even: fov / n steps, last beam at +89.5°
  angles = laser.BeamAnglesRadians();
  EXPECT_NEAR(angles.front(), -M_PI / 2, 1e-12);
  EXPECT_NEAR(angles.back(), 89.5 * kDeg, 1e-12);
  EXPECT_NEAR(laser.AngleIncrementRadians(), 0.5 * kDeg, 1e-12);
}

TEST(CameraOptionsTest, DefaultCameraLooksAlongTheLaser) {
  const CameraOptions camera;
  // The optical z axis is the laser's x axis, optical x is the laser's -y (right).
  EXPECT_TRUE(camera.laser_T_camera.linear().col(2).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_TRUE(camera.laser_T_camera.linear().col(0).isApprox(-Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_NEAR(camera.laser_T_camera.linear().determinant(), 1.0, 1e-12);
}

}  // namespace
}  // namespace sim
}  // namespace hetslam
