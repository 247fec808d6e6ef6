// Landmark observation cost: a robot observes the full planar pose of a landmark (an AprilTag
// projected to the ground plane) relative to itself.
//
//   robot_T_landmark_estimated = world_T_robot^-1 * world_T_landmark
//   residual(3) = S [E_x, E_y, wrap(E_yaw)],
//                 E = robot_T_landmark_measured^-1 * robot_T_landmark_estimated
// (the between error of factors/pose2_math.h). Parameter blocks: world_T_robot[3],
// world_T_landmark[3], both [x, y, yaw] (metres, metres, radians) with the Se2Manifold. Two
// robots that observe the same landmark block are tied together through it (paper eq. 4).
//
// Robust loss: tag detections can be wrong (mis-decoded id, bad corner) and their range error
// grows with distance: give each observation a ceres::CauchyLoss(1.0) or HuberLoss.
//
// Ownership: CreateLandmarkObservationCost returns a new ceres::CostFunction owned by the
// caller until it is handed to ceres::Problem::AddResidualBlock. The functor copies its data.
#ifndef HETSLAM_FACTORS_LANDMARK_OBSERVATION_COST_H_
#define HETSLAM_FACTORS_LANDMARK_OBSERVATION_COST_H_

#include "Eigen/Core"
#include "ceres/cost_function.h"
#include "core/se2.h"
#include "factors/pose2_math.h"

namespace hetslam {

class LandmarkObservationResidual {
 public:
  LandmarkObservationResidual(const Pose2& robot_T_landmark_measured,
                              const Eigen::Matrix3d& sqrt_information);

  template <typename T>
  bool operator()(const T* world_T_robot, const T* world_T_landmark, T* residual) const {
    T robot_T_landmark[3];
    BetweenPose2(world_T_robot, world_T_landmark, robot_T_landmark);
    RelativePose2Error(robot_T_landmark, robot_T_landmark_measured_, sqrt_information_,
                       residual);
    return true;
  }

 private:
  const Pose2 robot_T_landmark_measured_;   // landmark pose in the robot frame; metres, radians
  const Eigen::Matrix3d sqrt_information_;  // S of E; rows 1/m, 1/m, 1/rad
};

// New autodiff cost (3 residuals; blocks world_T_robot[3], world_T_landmark[3]); caller owns it.
ceres::CostFunction* CreateLandmarkObservationCost(const Pose2& robot_T_landmark_measured,
                                                   const Eigen::Matrix3d& sqrt_information);

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_LANDMARK_OBSERVATION_COST_H_
