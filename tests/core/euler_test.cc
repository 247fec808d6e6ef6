#include "core/euler.h"

#include <cmath>
#include <random>

#include "Eigen/Geometry"
#include "core/se2.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

// Angle-free comparison of rotations: the largest entry of R_a - R_b.
double RotationGap(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

// Uniform in [lo, hi) from the top 53 bits of one draw (the same on every standard library).
double Uniform(std::mt19937_64* rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>((*rng)() >> 11) * (1.0 / 9007199254740992.0);
}

TEST(RollPitchYawTest, IdentityAndAxes) {
  EXPECT_LT(RotationGap(Eigen::Matrix3d::Identity(), RotationFromRollPitchYaw(0, 0, 0)), 1e-15);
  EXPECT_LT(RollPitchYawFromRotation(Eigen::Matrix3d::Identity()).norm(), 1e-15);
  // Positive pitch is nose down: the body x axis gets a negative z component.
  const Eigen::Vector3d nose = RotationFromRollPitchYaw(0.0, 0.3, 0.0) * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(-std::sin(0.3), nose.z(), 1e-15);
  // Positive yaw turns x towards y; positive roll turns y towards z.
  EXPECT_NEAR(1.0, (RotationFromRollPitchYaw(0, 0, M_PI / 2) * Eigen::Vector3d::UnitX()).y(),
              1e-15);
  EXPECT_NEAR(1.0, (RotationFromRollPitchYaw(M_PI / 2, 0, 0) * Eigen::Vector3d::UnitY()).z(),
              1e-15);
  // Z-Y-X order: R = R_z(yaw) R_y(pitch) R_x(roll).
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      Eigen::AngleAxisd(-0.4, Eigen::Vector3d::UnitY()).toRotationMatrix() *
      Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_LT(RotationGap(expected, RotationFromRollPitchYaw(0.2, -0.4, 0.7)), 1e-15);
}

TEST(RollPitchYawTest, RandomAnglesRoundTrip) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 1000; ++i) {
    const double roll = Uniform(&rng, -M_PI + 1e-6, M_PI - 1e-6);
    const double pitch = Uniform(&rng, -M_PI / 2 + 1e-3, M_PI / 2 - 1e-3);
    const double yaw = Uniform(&rng, -M_PI + 1e-6, M_PI - 1e-6);
    const Eigen::Matrix3d R = RotationFromRollPitchYaw(roll, pitch, yaw);
    const Eigen::Vector3d rpy = RollPitchYawFromRotation(R);
    EXPECT_NEAR(roll, rpy.x(), 1e-12) << i;
    EXPECT_NEAR(pitch, rpy.y(), 1e-12) << i;
    EXPECT_NEAR(yaw, rpy.z(), 1e-12) << i;
    EXPECT_LT(RotationGap(R, RotationFromRollPitchYaw(rpy.x(), rpy.y(), rpy.z())), 1e-15 * 8);
  }
}

TEST(RollPitchYawTest, NearAndAtGimbalLockRebuildsTheRotation) {
  std::mt19937_64 rng(11);
  for (double pitch : {M_PI / 2, -M_PI / 2, M_PI / 2 - 1e-9, -M_PI / 2 + 1e-7, M_PI / 2 - 1e-4}) {
    for (int i = 0; i < 50; ++i) {
      const double roll = Uniform(&rng, -M_PI, M_PI);
      const double yaw = Uniform(&rng, -M_PI, M_PI);
      const Eigen::Matrix3d R = RotationFromRollPitchYaw(roll, pitch, yaw);
      const Eigen::Vector3d rpy = RollPitchYawFromRotation(R);
      // Roll and yaw are not separable at the lock; the rotation they give back must be R.
      EXPECT_LT(RotationGap(R, RotationFromRollPitchYaw(rpy.x(), rpy.y(), rpy.z())), 1e-14)
          << "pitch " << pitch << " roll " << roll << " yaw " << yaw;
      EXPECT_NEAR(pitch, rpy.y(), 1e-7) << "pitch " << pitch;
    }
  }
}

TEST(RollPitchYawTest, YawAcrossPlusMinusPiRoundTrips) {
  // atan2 gives yaw in (-pi, pi]: compare wrapped. Roll and pitch are well away from the lock,
  // so each angle comes back to rounding (a few 1e-16 rad; 1e-12 leaves room).
  for (double yaw : {M_PI, -M_PI, M_PI - 1e-9, -M_PI + 1e-9, M_PI - 1e-3, -M_PI + 1e-3}) {
    for (double roll : {0.0, 0.3, -2.0}) {
      const Eigen::Matrix3d R = RotationFromRollPitchYaw(roll, -0.2, yaw);
      const Eigen::Vector3d rpy = RollPitchYawFromRotation(R);
      EXPECT_NEAR(roll, rpy.x(), 1e-12) << "yaw " << yaw << " roll " << roll;
      EXPECT_NEAR(-0.2, rpy.y(), 1e-12) << "yaw " << yaw << " roll " << roll;
      EXPECT_NEAR(0.0, WrapAngle(rpy.z() - yaw), 1e-12) << "yaw " << yaw << " roll " << roll;
      EXPECT_LE(std::abs(rpy.z()), M_PI);
      EXPECT_LT(RotationGap(R, RotationFromRollPitchYaw(rpy.x(), rpy.y(), rpy.z())), 1e-15 * 8);
    }
  }
}

TEST(RollPitchYawTest, PitchNextToGimbalLockKeepsItsDigits) {
  // At pitch pi/2 - d the pitch comes from atan2 of the first column of R_z(-yaw) R, of unit
  // length, so it is recovered to rounding for any d (1e-15 rad: a few ulps of pi/2). An
  // asin(-R20) form would lose up to half the digits (about sqrt(eps) = 1.5e-8 rad for
  // d <= 1e-8, where 1 - cos(d) rounds away). Roll and yaw separately are ill-conditioned there
  // (their error grows as eps / d), so they are checked only through the rotation they rebuild.
  std::mt19937_64 rng(5);
  for (double d : {1e-3, 1e-5, 1e-8, 1e-10}) {
    for (double sign : {1.0, -1.0}) {
      const double pitch = sign * (M_PI / 2 - d);
      for (int i = 0; i < 20; ++i) {
        const double roll = Uniform(&rng, -M_PI, M_PI);
        const double yaw = Uniform(&rng, -M_PI, M_PI);
        const Eigen::Matrix3d R = RotationFromRollPitchYaw(roll, pitch, yaw);
        const Eigen::Vector3d rpy = RollPitchYawFromRotation(R);
        EXPECT_NEAR(pitch, rpy.y(), 1e-15) << "d " << d << " roll " << roll << " yaw " << yaw;
        EXPECT_LT(RotationGap(R, RotationFromRollPitchYaw(rpy.x(), rpy.y(), rpy.z())), 1e-14)
            << "d " << d << " roll " << roll << " yaw " << yaw;
      }
    }
  }
}

}  // namespace
}  // namespace hetslam
