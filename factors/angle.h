// Angle wrapping usable inside Ceres cost functors (double and ceres::Jet).
//
// This is the one Jet-friendly angle helper of hetslam; every factor that forms an angle
// difference wraps it with WrapAngle<T>. The plain-double version used outside Ceres is
// hetslam::WrapAngle(double) in core/se2.h; both wrap to the same half-open interval [-pi, pi).
#ifndef HETSLAM_FACTORS_ANGLE_H_
#define HETSLAM_FACTORS_ANGLE_H_

#include <cmath>

#include "ceres/jet.h"

namespace hetslam {

// Returns angle_radians wrapped to [-pi, pi):
//   wrap(a) = a - 2 pi * floor((a + pi) / (2 pi)).
// floor() is piecewise constant, so for a Jet the derivative passes through unchanged
// (d wrap / d a = 1 everywhere except on the branch cut a = pi + 2 pi k, where the value jumps).
// Residuals therefore stay smooth as long as the wrapped quantity is an error that is small at
// the optimum (for example yaw_estimated - yaw_measured), never a raw pose angle near +-pi.
//
// For T = double an exact double overload in core/se2.h is preferred by overload resolution
// when both headers are included; both give the same value (up to rounding).
template <typename T>
T WrapAngle(const T& angle_radians) {
  const double kTwoPi = 2.0 * M_PI;
  T wrapped = angle_radians - kTwoPi * ceres::floor((angle_radians + M_PI) / kTwoPi);
  // Rounding can land exactly on +pi for inputs a hair below -pi; keep the interval half-open.
  if (wrapped >= T(M_PI)) wrapped -= kTwoPi;
  return wrapped;
}

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_ANGLE_H_
