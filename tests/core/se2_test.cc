#include "core/se2.h"

#include <random>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

void ExpectPoseNear(const Pose2& expected, const Pose2& actual, double translation_tol,
                    double rotation_tol) {
  EXPECT_NEAR(expected.x(), actual.x(), translation_tol);
  EXPECT_NEAR(expected.y(), actual.y(), translation_tol);
  EXPECT_NEAR(0.0, WrapAngle(expected.theta() - actual.theta()), rotation_tol)
      << "expected " << expected << " actual " << actual;
}

Pose2 RandomPose(std::mt19937* rng) {
  std::uniform_real_distribution<double> xy(-50.0, 50.0), th(-M_PI, M_PI);
  return Pose2(xy(*rng), xy(*rng), th(*rng));
}

TEST(WrapAngleTest, MapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(0.0, WrapAngle(0.0));
  EXPECT_DOUBLE_EQ(-M_PI, WrapAngle(M_PI));
  EXPECT_DOUBLE_EQ(-M_PI, WrapAngle(-M_PI));
  EXPECT_NEAR(0.5, WrapAngle(0.5 + 4 * M_PI), 1e-12);
  EXPECT_NEAR(-0.5, WrapAngle(-0.5 - 6 * M_PI), 1e-12);
  EXPECT_NEAR(M_PI - 1e-9, WrapAngle(M_PI - 1e-9), 1e-15);
  EXPECT_NEAR(-M_PI + 1e-9, WrapAngle(M_PI + 1e-9), 1e-12);
}

TEST(Pose2Test, IdentityIsNeutral) {
  const Pose2 a(1.0, -2.0, 0.3);
  ExpectPoseNear(a, Pose2::Identity() * a, 1e-12, 1e-12);
  ExpectPoseNear(a, a * Pose2::Identity(), 1e-12, 1e-12);
  ExpectPoseNear(Pose2::Identity(), a * a.inverse(), 1e-12, 1e-12);
}

TEST(Pose2Test, ComposeByHand) {
  // Robot at (1, 0) facing +y; a point 2 m ahead is at (1, 2).
  const Pose2 world_T_robot(1.0, 0.0, M_PI / 2);
  const Eigen::Vector2d p = world_T_robot * Eigen::Vector2d(2.0, 0.0);
  EXPECT_NEAR(1.0, p.x(), 1e-12);
  EXPECT_NEAR(2.0, p.y(), 1e-12);
  const Pose2 c = world_T_robot * Pose2(2.0, 0.0, M_PI / 2);
  ExpectPoseNear(Pose2(1.0, 2.0, M_PI), c, 1e-12, 1e-12);
}

TEST(Pose2Test, NearIdentity) {
  const Pose2 a(1e-9, -1e-9, 1e-10);
  ExpectPoseNear(Pose2::Identity(), a * a.inverse(), 1e-15, 1e-15);
  ExpectPoseNear(a, Between(Pose2::Identity(), a), 1e-15, 1e-15);
}

TEST(Pose2Test, AcrossPi) {
  const Pose2 a(0.0, 0.0, M_PI - 0.01);
  const Pose2 b(0.0, 0.0, -M_PI + 0.01);
  ExpectPoseNear(Pose2(0, 0, 0.02), Between(a, b), 1e-12, 1e-12);
  ExpectPoseNear(Pose2(0, 0, -0.02), Between(b, a), 1e-12, 1e-12);
  const Pose2 mid = Interpolate(a, b, 0.5);
  EXPECT_NEAR(M_PI, std::abs(mid.theta()), 1e-12);
}

TEST(Pose2Test, RandomPosesSatisfyGroupLaws) {
  std::mt19937 rng(42);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 a = RandomPose(&rng), b = RandomPose(&rng), c = RandomPose(&rng);
    ExpectPoseNear((a * b) * c, a * (b * c), 1e-9, 1e-12);
    ExpectPoseNear(b, a * Between(a, b), 1e-9, 1e-12);
    ExpectPoseNear(a.inverse().inverse(), a, 1e-9, 1e-12);
    const Eigen::Vector2d p(3.0, -4.0);
    EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 1e-9);
    EXPECT_LT((a.inverse() * (a * p) - p).norm(), 1e-9);
  }
}

}  // namespace
}  // namespace hetslam
