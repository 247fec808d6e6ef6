#include "merger/landmark_pose.h"

#include <cmath>
#include <random>

#include "core/euler.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

void ExpectPoseNear(const Pose2& expected, const Pose2& actual, double meters = 1e-9, double radians = 1e-9) {
  EXPECT_NEAR(expected.x(), actual.x(), meters);
  EXPECT_NEAR(expected.y(), actual.y(), meters);
  EXPECT_NEAR(0.0, WrapAngle(expected.theta() - actual.theta()), radians);
}

// Eq. 4 by hand. The tag hangs at world (0, 5) facing east (+x). Robot 1 started at world
// (2, 2) facing north (90°); robot 2 at world (13, 7) facing west (180°).
//   robot1_T_L: the tag in robot 1's frame: p = R(-90°) ((0, 5) - (2, 2)) = R(-90°)(-2, 3) = (3, 2),
//               heading 0° - 90° = -90°.
//   robot2_T_L: p = R(-180°) ((0, 5) - (13, 7)) = -(-13, -2) = (13, 2), heading 0° - 180° = 180°.
//   robot1_T_robot2 = robot1_T_L (robot2_T_L)^-1 = world_T_1^-1 world_T_2:
//               p = R(-90°)((13, 7) - (2, 2)) = R(-90°)(11, 5) = (5, -11), heading 90°.
TEST(LandmarkPoseTest, EquationFourByHand) {
  const Pose2 robot1_T_tag(3.0, 2.0, -90 * kDeg);
  const Pose2 robot2_T_tag(13.0, 2.0, 180 * kDeg);
  const RelativePoseEstimate estimate =
      RelativePoseFromLandmark(robot1_T_tag, Eigen::Matrix3d::Identity(), robot2_T_tag, Eigen::Matrix3d::Identity());
  ExpectPoseNear(Pose2(5.0, -11.0, 90 * kDeg), estimate.robot1_T_robot2);
  // And from the world poses directly.
  const Pose2 world_T_1(2, 2, 90 * kDeg), world_T_2(13, 7, 180 * kDeg), world_T_tag(0, 5, 0);
  ExpectPoseNear(Between(world_T_1, world_T_tag), robot1_T_tag);
  ExpectPoseNear(Between(world_T_2, world_T_tag), robot2_T_tag);
  ExpectPoseNear(Between(world_T_1, world_T_2), estimate.robot1_T_robot2);
}

TEST(LandmarkPoseTest, SameRobotTwiceIsIdentity) {
  const Pose2 robot_T_tag(1.2, -0.7, 2.9);
  ExpectPoseNear(Pose2::Identity(),
                 RelativePoseFromLandmark(robot_T_tag, Eigen::Matrix3d::Identity(), robot_T_tag,
                                          Eigen::Matrix3d::Identity())
                     .robot1_T_robot2);
}

// The propagated covariance matches finite differences of eq. 4 at seeded random poses,
// across ±pi.
TEST(LandmarkPoseTest, CovarianceMatchesNumericalJacobian) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> position(-10, 10), angle(-M_PI, M_PI);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose2 a(position(rng), position(rng), angle(rng)), b(position(rng), position(rng), angle(rng));
    auto f = [&](const Eigen::Vector3d& da, const Eigen::Vector3d& db) {
      return (Pose2::FromVector(a.ToVector() + da) * Pose2::FromVector(b.ToVector() + db).inverse()).ToVector();
    };
    Eigen::Matrix<double, 3, 6> jacobian;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Eigen::Vector3d da = Eigen::Vector3d::Zero(), db = Eigen::Vector3d::Zero();
      (k < 3 ? da(k) : db(k - 3)) = h;
      Eigen::Vector3d diff = f(da, db) - f(-da, -db);
      diff(2) = WrapAngle(diff(2));
      jacobian.col(k) = diff / (2 * h);
    }
    Eigen::Matrix3d ca = Eigen::Vector3d(0.01, 0.02, 0.003).asDiagonal();
    ca(0, 1) = ca(1, 0) = 0.005;
    const Eigen::Matrix3d cb = Eigen::Vector3d(0.04, 0.01, 0.001).asDiagonal();
    Eigen::Matrix<double, 6, 6> joint = Eigen::Matrix<double, 6, 6>::Zero();
    joint.topLeftCorner<3, 3>() = ca;
    joint.bottomRightCorner<3, 3>() = cb;
    const Eigen::Matrix3d expected = jacobian * joint * jacobian.transpose();
    const Eigen::Matrix3d actual = RelativePoseFromLandmark(a, ca, b, cb).covariance;
    EXPECT_LT((expected - actual).cwiseAbs().maxCoeff(), 1e-6 * (1 + expected.cwiseAbs().maxCoeff())) << trial;
  }
}

// A level camera looking along the body's x axis (optical z = body x, optical x = -body y,
// optical y = -body z) sees a tag 2 m ahead and 0.5 m left on a wall facing it.
Eigen::Isometry3d ForwardCamera() {
  Eigen::Isometry3d body_T_camera = Eigen::Isometry3d::Identity();
  body_T_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  body_T_camera.translation() = Eigen::Vector3d(0.1, 0.0, 0.5);
  return body_T_camera;
}

Eigen::Isometry3d TagInBody(const Eigen::Vector3d& position, double normal_heading_radians) {
  // Tag frame: z = outward normal (horizontal, at the heading), y up, x = y cross z.
  const Eigen::Vector3d z(std::cos(normal_heading_radians), std::sin(normal_heading_radians), 0.0);
  const Eigen::Vector3d y(0, 0, 1);
  Eigen::Isometry3d body_T_tag = Eigen::Isometry3d::Identity();
  body_T_tag.linear().col(0) = y.cross(z);
  body_T_tag.linear().col(1) = y;
  body_T_tag.linear().col(2) = z;
  body_T_tag.translation() = position;
  return body_T_tag;
}

TEST(LandmarkPoseTest, PlanarPoseOfATagOnAWall) {
  const Eigen::Isometry3d body_T_camera = ForwardCamera();
  // The wall faces back at the robot (normal heading 180°), turned 20° away.
  const Eigen::Isometry3d body_T_tag = TagInBody(Eigen::Vector3d(2.1, 0.5, 0.9), 160 * kDeg);
  PlanarTagSighting sighting;
  ASSERT_TRUE(PlanarTagPose(body_T_camera, body_T_camera.inverse() * body_T_tag, 0.0, 0.0, TagSightingOptions(),
                            &sighting)
                  .ok());
  ExpectPoseNear(Pose2(2.1, 0.5, 160 * kDeg), sighting.body_T_tag, 1e-9, 1e-9);
  EXPECT_NEAR(std::sqrt(4.0 + 0.25 + 0.16), sighting.range_meters, 1e-9);
  // The viewing angle: between the tag's normal and the direction from the tag to the camera.
  const Eigen::Vector3d to_camera = (body_T_camera.translation() - body_T_tag.translation()).normalized();
  EXPECT_NEAR(std::acos(body_T_tag.linear().col(2).dot(to_camera)), sighting.view_angle_radians, 1e-9);
}

TEST(LandmarkPoseTest, TiltedBodyIsLevelledByItsAttitude) {
  // The same tag, the body pitched 10° nose down and rolled 5°: the camera sees the tag where
  // the tilted body puts it; with the attitude the planar pose is the level one.
  const Eigen::Isometry3d body_T_camera = ForwardCamera();
  const double roll = 5 * kDeg, pitch = 10 * kDeg;
  Eigen::Isometry3d heading_T_body = Eigen::Isometry3d::Identity();
  heading_T_body.linear() = RotationFromRollPitchYaw(roll, pitch, 0.0);
  const Eigen::Isometry3d heading_T_tag = TagInBody(Eigen::Vector3d(2.1, 0.5, 0.9), 160 * kDeg);
  const Eigen::Isometry3d camera_T_tag = (heading_T_body * body_T_camera).inverse() * heading_T_tag;
  PlanarTagSighting levelled, ignored;
  ASSERT_TRUE(PlanarTagPose(body_T_camera, camera_T_tag, roll, pitch, TagSightingOptions(), &levelled).ok());
  ASSERT_TRUE(PlanarTagPose(body_T_camera, camera_T_tag, 0.0, 0.0, TagSightingOptions(), &ignored).ok());
  ExpectPoseNear(Pose2(2.1, 0.5, 160 * kDeg), levelled.body_T_tag, 1e-9, 1e-9);
  EXPECT_GT((ignored.body_T_tag.translation() - levelled.body_T_tag.translation()).norm(), 0.05);
}

TEST(LandmarkPoseTest, CovarianceGrowsWithRangeAndViewingAngle) {
  const Eigen::Isometry3d body_T_camera = ForwardCamera();
  auto covariance = [&](double range, double turn_degrees) {
    PlanarTagSighting sighting;
    const Eigen::Isometry3d body_T_tag = TagInBody(Eigen::Vector3d(0.1 + range, 0.0, 0.5), (180 - turn_degrees) * kDeg);
    EXPECT_TRUE(PlanarTagPose(body_T_camera, body_T_camera.inverse() * body_T_tag, 0, 0, TagSightingOptions(), &sighting)
                    .ok());
    return sighting.covariance;
  };
  const Eigen::Matrix3d near = covariance(1.0, 0), far = covariance(4.0, 0), oblique = covariance(1.0, 50);
  EXPECT_GT(far(0, 0), near(0, 0));  // along the line of sight (body x)
  EXPECT_GT(far(1, 1), near(1, 1));
  EXPECT_GT(far(2, 2), near(2, 2));
  EXPECT_GT(oblique(2, 2), near(2, 2));
  EXPECT_GT(oblique(0, 0), near(0, 0));
  // Depth grows faster than the across-track error: s^2 against s.
  EXPECT_GT(far(0, 0) / near(0, 0), far(1, 1) / near(1, 1));
}

TEST(LandmarkPoseTest, RefusesFarObliqueAndFlatTags) {
  const Eigen::Isometry3d body_T_camera = ForwardCamera();
  PlanarTagSighting sighting;
  const TagSightingOptions options;
  const Eigen::Isometry3d far = TagInBody(Eigen::Vector3d(9.0, 0, 0.5), M_PI);
  EXPECT_FALSE(PlanarTagPose(body_T_camera, body_T_camera.inverse() * far, 0, 0, options, &sighting).ok());
  const Eigen::Isometry3d oblique = TagInBody(Eigen::Vector3d(2.0, 0, 0.5), M_PI - 80 * kDeg);
  EXPECT_FALSE(PlanarTagPose(body_T_camera, body_T_camera.inverse() * oblique, 0, 0, options, &sighting).ok());
  // On the floor 2 m ahead, facing up: no heading.
  Eigen::Isometry3d flat = Eigen::Isometry3d::Identity();
  flat.translation() = Eigen::Vector3d(2.0, 0, 0);
  flat.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Status status = PlanarTagPose(body_T_camera, body_T_camera.inverse() * flat, 0, 0, options, &sighting);
  EXPECT_FALSE(status.ok());
}

TEST(LandmarkPoseTest, RotateCovarianceTurnsTheTranslationBlock) {
  const Eigen::Matrix3d c = Eigen::Vector3d(4.0, 1.0, 0.5).asDiagonal();
  const Eigen::Matrix3d turned = RotateCovariance(Pose2(3, -2, M_PI / 2), c);
  EXPECT_NEAR(1.0, turned(0, 0), 1e-12);
  EXPECT_NEAR(4.0, turned(1, 1), 1e-12);
  EXPECT_NEAR(0.5, turned(2, 2), 1e-12);
}

}  // namespace
}  // namespace hetslam
