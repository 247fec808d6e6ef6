// Templated SE(2) algebra on raw [x, y, yaw] arrays, for use inside Ceres functors (T = double
// or ceres::Jet). Shared by every pose factor so they all use one error definition.
//
// Layout of every pose array: [x, y, yaw] in metres, metres, radians; the array `a_T_b` maps
// b-frame points into frame a: p_a = R(yaw) p_b + [x, y].
#ifndef HETSLAM_FACTORS_POSE2_MATH_H_
#define HETSLAM_FACTORS_POSE2_MATH_H_

#include <cmath>

#include "Eigen/Core"
#include "ceres/jet.h"
#include "core/se2.h"
#include "factors/angle.h"

namespace hetslam {

// a_T_c = a_T_b * b_T_c. The output yaw is the plain sum (not wrapped): every consumer here
// wraps the final error, and leaving intermediate angles unwrapped keeps them smooth.
template <typename T>
void ComposePose2(const T* a_T_b, const T* b_T_c, T* a_T_c) {
  using std::cos;
  using std::sin;
  const T c = cos(a_T_b[2]);
  const T s = sin(a_T_b[2]);
  a_T_c[0] = a_T_b[0] + c * b_T_c[0] - s * b_T_c[1];
  a_T_c[1] = a_T_b[1] + s * b_T_c[0] + c * b_T_c[1];
  a_T_c[2] = a_T_b[2] + b_T_c[2];
}

// a_T_b = world_T_a^-1 * world_T_b: translation R_a^T (t_b - t_a), yaw yaw_b - yaw_a (unwrapped).
template <typename T>
void BetweenPose2(const T* world_T_a, const T* world_T_b, T* a_T_b) {
  using std::cos;
  using std::sin;
  const T c = cos(world_T_a[2]);
  const T s = sin(world_T_a[2]);
  const T dx = world_T_b[0] - world_T_a[0];
  const T dy = world_T_b[1] - world_T_a[1];
  a_T_b[0] = c * dx + s * dy;
  a_T_b[1] = -s * dx + c * dy;
  a_T_b[2] = world_T_b[2] - world_T_a[2];
}

// The relative pose error of every between-type factor (the error of g2o's EDGE_SE2):
//   E = a_T_b_measured^-1 * a_T_b_estimated
//   e = [E_x, E_y, wrap(E_yaw)]
//     = [R_m^T (t_est - t_m), wrap(yaw_est - yaw_m)]
//   residual = S e
// where R_m, t_m, yaw_m belong to the measurement, S is the 3x3 square-root information. The
// translation error is expressed in the measured b frame, so S (and an information matrix
// read from a g2o file) weighs errors along and across the measured b axes.
template <typename T>
void RelativePose2Error(const T* a_T_b_estimated, const Pose2& a_T_b_measured,
                        const Eigen::Matrix3d& sqrt_information, T* residual) {
  const double c = std::cos(a_T_b_measured.theta());
  const double s = std::sin(a_T_b_measured.theta());
  const T dx = a_T_b_estimated[0] - a_T_b_measured.x();
  const T dy = a_T_b_estimated[1] - a_T_b_measured.y();
  Eigen::Matrix<T, 3, 1> error;
  error(0) = c * dx + s * dy;
  error(1) = -s * dx + c * dy;
  error(2) = WrapAngle<T>(a_T_b_estimated[2] - a_T_b_measured.theta());
  Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
  r = sqrt_information.cast<T>() * error;
}

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_POSE2_MATH_H_
