#include "core/euler.h"

#include <cmath>

#include "Eigen/Geometry"

namespace hetslam {

Eigen::Matrix3d RotationFromRollPitchYaw(double roll_radians, double pitch_radians,
                                         double yaw_radians) {
  return (Eigen::AngleAxisd(yaw_radians, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch_radians, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_radians, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d RollPitchYawFromRotation(const Eigen::Matrix3d& R) {
  // R = R_z(y) R_y(p) R_x(r) has first column (cp cy, cp sy, -sp): yaw from it (0 at gimbal
  // lock, where only roll -+ yaw is defined). Then R_z(-y) R = R_y(p) R_x(r) has first column
  // (cp, 0, -sp) and second row (0, cr, -sr), both of unit length, so pitch and roll come out
  // well conditioned even next to +-90° pitch (asin(-R20) would lose half the digits there)
  // and the angles rebuild R to rounding.
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const Eigen::Matrix3d level =
      Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R;
  const double pitch = std::atan2(-level(2, 0), level(0, 0));
  const double roll = std::atan2(-level(1, 2), level(1, 1));
  return Eigen::Vector3d(roll, pitch, yaw);
}

}  // namespace hetslam
