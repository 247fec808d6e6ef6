#include "core/camera_model.h"

#include "gtest/gtest.h"

namespace hetslam {
namespace {

TEST(CameraIntrinsicsTest, ProjectsByHand) {
  const CameraIntrinsics k{500.0, 400.0, 319.5, 239.5, 640, 480};
  // On the optical axis: the principal point, at any depth.
  EXPECT_EQ(Eigen::Vector2d(319.5, 239.5), k.Project(Eigen::Vector3d(0.0, 0.0, 3.0)));
  // 0.2 m right and 0.1 m down at 2 m: 500 * 0.1 = 50 px right, 400 * 0.05 = 20 px down.
  const Eigen::Vector2d uv = k.Project(Eigen::Vector3d(0.2, 0.1, 2.0));
  EXPECT_DOUBLE_EQ(369.5, uv.x());
  EXPECT_DOUBLE_EQ(259.5, uv.y());
  // Scaling the point along its ray does not move its pixel.
  const Eigen::Vector2d far = k.Project(Eigen::Vector3d(0.8, 0.4, 8.0));
  EXPECT_NEAR(0.0, (far - uv).norm(), 1e-12);
}

}  // namespace
}  // namespace hetslam
