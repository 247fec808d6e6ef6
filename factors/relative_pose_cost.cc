#include "factors/relative_pose_cost.h"

#include <cmath>

#include "ceres/autodiff_cost_function.h"
#include "ceres/sized_cost_function.h"
#include "factors/angle.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

void CheckMeasurement(const Pose2& measured, const Eigen::Matrix3d& sqrt_information) {
  CHECK(measured.ToVector().allFinite()) << "non-finite measurement " << measured;
  CHECK(sqrt_information.allFinite()) << "non-finite sqrt information:\n" << sqrt_information;
}

// RelativePose2Residual with an analytic Jacobian. With a = world_T_a, b = world_T_b,
// R(.) the 2D rotation, m the measurement:
//   t = R_a^T (t_b - t_a)                  (translation of a_T_b)
//   e = [R_m^T (t - t_m), wrap(yaw_b - yaw_a - yaw_m)],   residual = S e
//   de/d(t_b)   = [R_m^T R_a^T; 0]            de/d(yaw_b) = [0, 0, 1]
//   de/d(t_a)   = -[R_m^T R_a^T; 0]           de/d(yaw_a) = [R_m^T [t_y, -t_x], -1]
// (d R_a^T / d yaw_a (t_b - t_a) = [t_y, -t_x]; wrap has slope 1 away from its cut).
class RelativePose2Cost final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  RelativePose2Cost(const Pose2& a_T_b_measured, const Eigen::Matrix3d& sqrt_information)
      : a_T_b_measured_(a_T_b_measured),
        cos_measured_(std::cos(a_T_b_measured.theta())),
        sin_measured_(std::sin(a_T_b_measured.theta())),
        sqrt_information_(sqrt_information) {
    CheckMeasurement(a_T_b_measured_, sqrt_information_);
  }

  const Pose2& measurement() const { return a_T_b_measured_; }
  const Eigen::Matrix3d& sqrt_information() const { return sqrt_information_; }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* a = parameters[0];
    const double* b = parameters[1];
    const double cm = cos_measured_, sm = sin_measured_;
    const double ca = std::cos(a[2]), sa = std::sin(a[2]);
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    const double tx = ca * dx + sa * dy, ty = -sa * dx + ca * dy;  // a_T_b translation
    const double ux = tx - a_T_b_measured_.x(), uy = ty - a_T_b_measured_.y();
    const Eigen::Vector3d error(cm * ux + sm * uy, -sm * ux + cm * uy,
                                WrapAngle<double>((b[2] - a[2]) - a_T_b_measured_.theta()));
    Eigen::Map<Eigen::Vector3d> residual(residuals);
    residual = sqrt_information_ * error;
    if (jacobians == nullptr) return true;
    // M = R_m^T R_a^T.
    const double m00 = cm * ca - sm * sa, m01 = cm * sa + sm * ca;
    const double m10 = -sm * ca - cm * sa, m11 = -sm * sa + cm * ca;
    using Jacobian = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
    if (jacobians[0] != nullptr) {
      Jacobian de_da;
      de_da << -m00, -m01, cm * ty - sm * tx,
               -m10, -m11, -sm * ty - cm * tx,
               0.0, 0.0, -1.0;
      Eigen::Map<Jacobian> jacobian(jacobians[0]);
      jacobian = sqrt_information_ * de_da;
    }
    if (jacobians[1] != nullptr) {
      Jacobian de_db;
      de_db << m00, m01, 0.0,
               m10, m11, 0.0,
               0.0, 0.0, 1.0;
      Eigen::Map<Jacobian> jacobian(jacobians[1]);
      jacobian = sqrt_information_ * de_db;
    }
    return true;
  }

 private:
  const Pose2 a_T_b_measured_;              // pose of b in frame a; metres, radians
  const double cos_measured_;               // cos of a_T_b_measured_'s yaw
  const double sin_measured_;               // sin of a_T_b_measured_'s yaw
  const Eigen::Matrix3d sqrt_information_;  // S, S^T S = Sigma^-1 of E; rows 1/m, 1/m, 1/rad
};

using AnchoredRelativePose2Cost = ceres::AutoDiffCostFunction<AnchoredRelativePose2Residual, 3, 3, 3, 3, 3>;

}  // namespace

RelativePose2Residual::RelativePose2Residual(const Pose2& a_T_b_measured,
                                             const Eigen::Matrix3d& sqrt_information)
    : a_T_b_measured_(a_T_b_measured), sqrt_information_(sqrt_information) {
  CheckMeasurement(a_T_b_measured_, sqrt_information_);
}

ceres::CostFunction* CreateRelativePose2Cost(const Pose2& a_T_b_measured,
                                             const Eigen::Matrix3d& sqrt_information) {
  return new RelativePose2Cost(a_T_b_measured, sqrt_information);
}

AnchoredRelativePose2Residual::AnchoredRelativePose2Residual(
    const Pose2& ai_T_bj_measured, const Eigen::Matrix3d& sqrt_information)
    : ai_T_bj_measured_(ai_T_bj_measured), sqrt_information_(sqrt_information) {
  CheckMeasurement(ai_T_bj_measured_, sqrt_information_);
}

ceres::CostFunction* CreateAnchoredRelativePose2Cost(const Pose2& ai_T_bj_measured,
                                                     const Eigen::Matrix3d& sqrt_information) {
  return new AnchoredRelativePose2Cost(new AnchoredRelativePose2Residual(ai_T_bj_measured, sqrt_information));
}

bool RelativePose2CostMeasurement(const ceres::CostFunction& cost, Pose2* measurement,
                                  Eigen::Matrix3d* sqrt_information) {
  if (const auto* between = dynamic_cast<const RelativePose2Cost*>(&cost)) {
    *measurement = between->measurement();
    *sqrt_information = between->sqrt_information();
    return true;
  }
  if (const auto* anchored = dynamic_cast<const AnchoredRelativePose2Cost*>(&cost)) {
    *measurement = anchored->functor().measurement();
    *sqrt_information = anchored->functor().sqrt_information();
    return true;
  }
  return false;
}

}  // namespace hetslam
