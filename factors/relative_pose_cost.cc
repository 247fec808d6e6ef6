#include "factors/relative_pose_cost.h"

#include "ceres/autodiff_cost_function.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

void CheckMeasurement(const Pose2& measured, const Eigen::Matrix3d& sqrt_information) {
  CHECK(measured.ToVector().allFinite()) << "non-finite measurement " << measured;
  CHECK(sqrt_information.allFinite()) << "non-finite sqrt information:\n" << sqrt_information;
}

}  // namespace

RelativePose2Residual::RelativePose2Residual(const Pose2& a_T_b_measured,
                                             const Eigen::Matrix3d& sqrt_information)
    : a_T_b_measured_(a_T_b_measured), sqrt_information_(sqrt_information) {
  CheckMeasurement(a_T_b_measured_, sqrt_information_);
}

ceres::CostFunction* CreateRelativePose2Cost(const Pose2& a_T_b_measured,
                                             const Eigen::Matrix3d& sqrt_information) {
  return new ceres::AutoDiffCostFunction<RelativePose2Residual, 3, 3, 3>(
      new RelativePose2Residual(a_T_b_measured, sqrt_information));
}

AnchoredRelativePose2Residual::AnchoredRelativePose2Residual(
    const Pose2& ai_T_bj_measured, const Eigen::Matrix3d& sqrt_information)
    : ai_T_bj_measured_(ai_T_bj_measured), sqrt_information_(sqrt_information) {
  CheckMeasurement(ai_T_bj_measured_, sqrt_information_);
}

ceres::CostFunction* CreateAnchoredRelativePose2Cost(const Pose2& ai_T_bj_measured,
                                                     const Eigen::Matrix3d& sqrt_information) {
  return new ceres::AutoDiffCostFunction<AnchoredRelativePose2Residual, 3, 3, 3, 3, 3>(
      new AnchoredRelativePose2Residual(ai_T_bj_measured, sqrt_information));
}

}  // namespace hetslam
