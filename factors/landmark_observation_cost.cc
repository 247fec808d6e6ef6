#include "factors/landmark_observation_cost.h"

#include "ceres/autodiff_cost_function.h"
#include "glog/logging.h"

namespace hetslam {

LandmarkObservationResidual::LandmarkObservationResidual(
    const Pose2& robot_T_landmark_measured, const Eigen::Matrix3d& sqrt_information)
    : robot_T_landmark_measured_(robot_T_landmark_measured), sqrt_information_(sqrt_information) {
  CHECK(robot_T_landmark_measured_.ToVector().allFinite())
      << "non-finite landmark observation " << robot_T_landmark_measured_;
  CHECK(sqrt_information_.allFinite()) << "non-finite sqrt information:\n" << sqrt_information_;
}

ceres::CostFunction* CreateLandmarkObservationCost(const Pose2& robot_T_landmark_measured,
                                                   const Eigen::Matrix3d& sqrt_information) {
  return new ceres::AutoDiffCostFunction<LandmarkObservationResidual, 3, 3, 3>(
      new LandmarkObservationResidual(robot_T_landmark_measured, sqrt_information));
}

}  // namespace hetslam
