#include "factors/se2_manifold.h"

#include <algorithm>

#include "factors/angle.h"
#include "glog/logging.h"

namespace hetslam {

bool Se2Manifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  x_plus_delta[0] = x[0] + delta[0];
  x_plus_delta[1] = x[1] + delta[1];
  x_plus_delta[2] = WrapAngle<double>(x[2] + delta[2]);
  return true;
}

bool Se2Manifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  std::fill(jacobian, jacobian + kAmbientSize * kTangentSize, 0.0);
  jacobian[0] = jacobian[4] = jacobian[8] = 1.0;
  return true;
}

bool Se2Manifold::RightMultiplyByPlusJacobian(const double* /*x*/, int num_rows,
                                              const double* ambient_matrix,
                                              double* tangent_matrix) const {
  // The Plus Jacobian is the identity and ambient and tangent sizes agree: a plain copy.
  std::copy(ambient_matrix, ambient_matrix + num_rows * kAmbientSize, tangent_matrix);
  return true;
}

bool Se2Manifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  y_minus_x[0] = y[0] - x[0];
  y_minus_x[1] = y[1] - x[1];
  y_minus_x[2] = WrapAngle<double>(y[2] - x[2]);
  return true;
}

bool Se2Manifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  std::fill(jacobian, jacobian + kTangentSize * kAmbientSize, 0.0);
  jacobian[0] = jacobian[4] = jacobian[8] = 1.0;
  return true;
}

ceres::Manifold* CreateSe2Manifold() { return new Se2Manifold(); }

Se2HeldDirectionManifold::Se2HeldDirectionManifold(const Eigen::Vector2d& held_direction) {
  CHECK(held_direction.allFinite() && held_direction.squaredNorm() > 0)
      << "held direction must be finite and non-zero, got " << held_direction.transpose();
  const Eigen::Vector2d held = held_direction.normalized();
  free_ = Eigen::Vector2d(-held.y(), held.x());
}

bool Se2HeldDirectionManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  x_plus_delta[0] = x[0] + delta[0] * free_.x();
  x_plus_delta[1] = x[1] + delta[0] * free_.y();
  x_plus_delta[2] = WrapAngle<double>(x[2] + delta[1]);
  return true;
}

bool Se2HeldDirectionManifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  jacobian[0] = free_.x(), jacobian[1] = 0.0;
  jacobian[2] = free_.y(), jacobian[3] = 0.0;
  jacobian[4] = 0.0, jacobian[5] = 1.0;
  return true;
}

bool Se2HeldDirectionManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  y_minus_x[0] = (y[0] - x[0]) * free_.x() + (y[1] - x[1]) * free_.y();
  y_minus_x[1] = WrapAngle<double>(y[2] - x[2]);
  return true;
}

bool Se2HeldDirectionManifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  jacobian[0] = free_.x(), jacobian[1] = free_.y(), jacobian[2] = 0.0;
  jacobian[3] = 0.0, jacobian[4] = 0.0, jacobian[5] = 1.0;
  return true;
}

}  // namespace hetslam
