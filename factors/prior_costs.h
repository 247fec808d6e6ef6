// Prior costs on one planar pose block [x, y, yaw] (metres, metres, radians; carry the
// Se2Manifold of factors/se2_manifold.h).
//
// Robust losses: a pose prior that fixes or softly anchors the gauge takes NO loss. A MARG
// heading prior indoors may see magnetic disturbances (steel beams, motors) of tens of degrees:
// give it a ceres::HuberLoss (scale 1..2, in standard deviations; the residual is whitened) so a
// disturbed heading is down-weighted instead of rotating the map.
//
// Ownership: every Create*Cost returns a new ceres::CostFunction that the caller owns until it
// is handed to ceres::Problem::AddResidualBlock. Functors copy their measurement and weights.
#ifndef HETSLAM_FACTORS_PRIOR_COSTS_H_
#define HETSLAM_FACTORS_PRIOR_COSTS_H_

#include "Eigen/Core"
#include "ceres/cost_function.h"
#include "core/se2.h"
#include "factors/angle.h"

namespace hetslam {

// Pose prior with a world-aligned error (so S comes from a covariance of x, y, yaw as a GPS-like
// or motion-capture source reports it, not from one in the pose's own frame):
//   residual(3) = S [x - x_p, y - y_p, wrap(yaw - yaw_p)]
// Parameter block: world_T_pose[3].
class Pose2PriorResidual {
 public:
  Pose2PriorResidual(const Pose2& world_T_pose_prior, const Eigen::Matrix3d& sqrt_information);

  template <typename T>
  bool operator()(const T* world_T_pose, T* residual) const {
    Eigen::Matrix<T, 3, 1> error;
    error(0) = world_T_pose[0] - world_T_pose_prior_.x();
    error(1) = world_T_pose[1] - world_T_pose_prior_.y();
    error(2) = WrapAngle<T>(world_T_pose[2] - world_T_pose_prior_.theta());
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  const Pose2 world_T_pose_prior_;          // prior pose in the world frame; metres, radians
  const Eigen::Matrix3d sqrt_information_;  // S, world-aligned; rows 1/m, 1/m, 1/rad
};

// New autodiff cost (3 residuals; block world_T_pose[3]); caller owns it.
ceres::CostFunction* CreatePose2PriorCost(const Pose2& world_T_pose_prior,
                                          const Eigen::Matrix3d& sqrt_information);

// Heading prior from a MARG (gyro + accelerometer + magnetometer) yaw, 1 residual:
//   residual(1) = wrap(yaw - yaw_measured) / sigma_yaw
// Parameter block: world_T_pose[3] (x and y get zero Jacobian columns). The measured yaw must
// already be expressed in the frame of the pose block (rotate by the magnetic-north-to-world
// offset first if they differ).
class HeadingPriorResidual {
 public:
  HeadingPriorResidual(double world_yaw_measured_radians, double yaw_stddev_radians);

  template <typename T>
  bool operator()(const T* world_T_pose, T* residual) const {
    residual[0] = sqrt_information_per_radian_ *
                  WrapAngle<T>(world_T_pose[2] - world_yaw_measured_radians_);
    return true;
  }

 private:
  const double world_yaw_measured_radians_;   // yaw of the pose in the world frame; radians
  const double sqrt_information_per_radian_;  // 1 / sigma_yaw; 1/rad
};

// New autodiff cost (1 residual; block world_T_pose[3]); caller owns it. CHECK-fails unless
// yaw_stddev_radians is finite and > 0 and the measured yaw is finite.
ceres::CostFunction* CreateHeadingPriorCost(double world_yaw_measured_radians,
                                            double yaw_stddev_radians);

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_PRIOR_COSTS_H_
