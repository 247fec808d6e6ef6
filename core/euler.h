// Euler angles (roll, pitch, yaw): the one attitude convention of hetslam (robot logs, the
// simulator, the MARG filter, the state EKF, the 2.5D scan projection).
//
// Z-Y-X: R = R_z(yaw) R_y(pitch) R_x(roll), i.e. roll about the body x axis first, then pitch
// about y, then yaw about z, each right-handed. R maps body vectors into the parent frame
// (world_R_body). With the body frame x forward, y left, z up, pitch is positive nose down and
// roll positive left side up. A pose "x y z roll pitch yaw" is the transform a_T_b with
// translation (x, y, z) and this rotation. The MARG filter and the EKF call yaw "heading" (φ).
//
// Ranges of RollPitchYawFromRotation: roll and yaw in (-pi, pi], pitch in [-pi/2, pi/2]. At
// gimbal lock (|pitch| = pi/2) roll and yaw are not separable (only their sum or difference is
// defined): the split between them is arbitrary, but the angles still rebuild R.
#ifndef HETSLAM_CORE_EULER_H_
#define HETSLAM_CORE_EULER_H_

#include "Eigen/Core"

namespace hetslam {

// R_z(yaw) R_y(pitch) R_x(roll).
Eigen::Matrix3d RotationFromRollPitchYaw(double roll_radians, double pitch_radians,
                                         double yaw_radians);

// (roll, pitch, yaw) of a rotation matrix, the inverse of RotationFromRollPitchYaw: angles
// that rebuild `rotation` to rounding (~1e-15 per entry), also next to and at gimbal lock.
// Yaw is not wrapped: atan2's (-pi, pi]; wrap with WrapAngle (core/se2.h) for [-pi, pi).
Eigen::Vector3d RollPitchYawFromRotation(const Eigen::Matrix3d& rotation);

}  // namespace hetslam

#endif  // HETSLAM_CORE_EULER_H_
