// The manifold of one planar pose parameter block [x, y, yaw] (metres, metres, radians).
//
// Every pose block in hetslam has this layout and this manifold: a robot pose world_T_robot,
// an anchor world_T_robot_origin, a landmark pose world_T_landmark. Give each such block to
// ceres::Problem::SetManifold(block, &manifold) (or AddParameterBlock(block, 3, manifold)).
//
// Choice of Plus: R^2 x SO(2) with additive translation, NOT the SE(2) group exponential.
//   Plus(x, delta)  = [x + dx, y + dy, wrap(yaw + dyaw)]
//   Minus(y, x)     = [y_x - x_x, y_y - x_y, wrap(y_yaw - x_yaw)]
// with wrap() to [-pi, pi) (factors/angle.h). Both choices are valid retractions (they agree
// with the group exponential to first order at delta = 0), so the solver converges to the same
// minimum; what differs is the meaning of the tangent space, and we pick the additive one
// because:
//   * the tangent coordinates are world-aligned (dx, dy in the block's parent frame, dyaw), so
//     a covariance from ceres::Covariance for a block is directly the covariance of
//     (x, y, yaw) as users and g2o/trajectory files read it, without a frame change;
//   * PlusJacobian and MinusJacobian are the identity, so the manifold costs nothing per
//     iteration, and the numerics of long chains do not depend on the yaw of each pose;
//   * the exponential map's coupling of translation and rotation buys nothing in 2D pose
//     graphs: the residuals already carry the rotation (they compose poses exactly).
// The yaw wrap is what makes this a manifold and not R^3: yaw stays in [-pi, pi) during the
// solve, and Minus always returns the shorter angular difference (|dyaw| <= pi).
//
// Pitfall: Plus is discontinuous in its ambient output at yaw = +-pi (the wrap), as any chart of
// SO(2) stored as one angle must be; the tangent-space behaviour (Minus(Plus(x, d), x) = d for
// |dyaw| < pi) is smooth everywhere, which is all Ceres uses.
//
// Thread-safety: stateless; one instance may be shared by any number of blocks and problems.
// Ownership: ceres::Problem deletes the manifolds it is given (once each, even when one is shared
// by many blocks) unless Problem::Options::manifold_ownership is DO_NOT_TAKE_OWNERSHIP: so either
// give each problem a heap object (CreateSe2Manifold(), which returns a new object the caller
// owns until handed over), or keep one that outlives the problem and set DO_NOT_TAKE_OWNERSHIP.
#ifndef HETSLAM_FACTORS_SE2_MANIFOLD_H_
#define HETSLAM_FACTORS_SE2_MANIFOLD_H_

#include "Eigen/Core"
#include "ceres/manifold.h"

namespace hetslam {

class Se2Manifold final : public ceres::Manifold {
 public:
  static constexpr int kAmbientSize = 3;  // [x, y, yaw]
  static constexpr int kTangentSize = 3;  // [dx, dy, dyaw], world-aligned

  int AmbientSize() const override { return kAmbientSize; }
  int TangentSize() const override { return kTangentSize; }

  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // 3x3 row-major identity.
  bool PlusJacobian(const double* x, double* jacobian) const override;
  // ambient_matrix * PlusJacobian = ambient_matrix (copied).
  bool RightMultiplyByPlusJacobian(const double* x, int num_rows, const double* ambient_matrix,
                                   double* tangent_matrix) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // 3x3 row-major identity.
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// A new Se2Manifold; the caller (or the ceres::Problem it is given to) owns it.
ceres::Manifold* CreateSe2Manifold();

// SE(2) poses [x, y, yaw] whose translation along one world direction is held: the tangent is
// [d, dyaw], moving the translation by d along the free direction (the held one turned by
// +90°) and the yaw by dyaw. For a match that cannot place a scan along a direction (a
// corridor, a single wall: the degeneracy tests of frontends/local_slam.h) while another
// source (a motion model) knows where the robot is along it: the scan decides across it and in
// yaw only, so a pull along the flat direction cannot leak into the other two.
class Se2HeldDirectionManifold final : public ceres::Manifold {
 public:
  static constexpr int kAmbientSize = 3;  // [x, y, yaw]
  static constexpr int kTangentSize = 2;  // [along the free direction, dyaw]

  // `held_direction`: world frame, non-zero (normalised here).
  explicit Se2HeldDirectionManifold(const Eigen::Vector2d& held_direction);

  int AmbientSize() const override { return kAmbientSize; }
  int TangentSize() const override { return kTangentSize; }

  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // 3x2 row-major [f_x 0; f_y 0; 0 1], f the free direction.
  bool PlusJacobian(const double* x, double* jacobian) const override;
  // The part of y - x along the free direction (what is along the held one is dropped) and the
  // wrapped yaw difference.
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // 2x3 row-major [f_x f_y 0; 0 0 1].
  bool MinusJacobian(const double* x, double* jacobian) const override;

  const Eigen::Vector2d& free_direction() const { return free_; }

 private:
  Eigen::Vector2d free_;  // unit, world frame
};

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_SE2_MANIFOLD_H_
