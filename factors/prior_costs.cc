#include "factors/prior_costs.h"

#include <cmath>

#include "ceres/autodiff_cost_function.h"
#include "glog/logging.h"

namespace hetslam {

Pose2PriorResidual::Pose2PriorResidual(const Pose2& world_T_pose_prior,
                                       const Eigen::Matrix3d& sqrt_information)
    : world_T_pose_prior_(world_T_pose_prior), sqrt_information_(sqrt_information) {
  CHECK(world_T_pose_prior_.ToVector().allFinite()) << "non-finite prior " << world_T_pose_prior_;
  CHECK(sqrt_information_.allFinite()) << "non-finite sqrt information:\n" << sqrt_information_;
}

ceres::CostFunction* CreatePose2PriorCost(const Pose2& world_T_pose_prior,
                                          const Eigen::Matrix3d& sqrt_information) {
  return new ceres::AutoDiffCostFunction<Pose2PriorResidual, 3, 3>(
      new Pose2PriorResidual(world_T_pose_prior, sqrt_information));
}

HeadingPriorResidual::HeadingPriorResidual(double world_yaw_measured_radians,
                                           double yaw_stddev_radians)
    : world_yaw_measured_radians_(world_yaw_measured_radians),
      sqrt_information_per_radian_(1.0 / yaw_stddev_radians) {
  CHECK(std::isfinite(world_yaw_measured_radians))
      << "non-finite measured yaw " << world_yaw_measured_radians;
  CHECK(std::isfinite(yaw_stddev_radians) && yaw_stddev_radians > 0.0)
      << "yaw standard deviation must be finite and > 0, got " << yaw_stddev_radians;
}

ceres::CostFunction* CreateHeadingPriorCost(double world_yaw_measured_radians,
                                            double yaw_stddev_radians) {
  return new ceres::AutoDiffCostFunction<HeadingPriorResidual, 1, 3>(
      new HeadingPriorResidual(world_yaw_measured_radians, yaw_stddev_radians));
}

}  // namespace hetslam
