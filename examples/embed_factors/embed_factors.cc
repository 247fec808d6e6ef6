// A small Ceres estimator built outside hetslam on its installed factor library: a robot drives
// around a 4 m square, sees a landmark (a tag on a wall) at the start and again at the end, and
// gets a MARG heading on its last pose. The measurements are exact, so we know the answer (the
// true square and tag); the initial guess is dead reckoning with a 5 % scale error and a 1 deg
// per step turn bias (16 deg of heading drift over the loop).
//
// Exit status: 0 when the solver converged and every pose and the landmark are within 1 mm /
// 0.01 deg of the truth, 1 otherwise (this program is a CI check of the installed package).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "ceres/ceres.h"
#include "core/se2.h"
#include "factors/landmark_observation_cost.h"
#include "factors/prior_costs.h"
#include "factors/relative_pose_cost.h"
#include "factors/se2_manifold.h"
#include "factors/sqrt_information.h"

int main() {
  using hetslam::Pose2;
  // Truth: 16 poses, 1 m apart, counter-clockwise around a 4 m square, then back at the start.
  std::vector<Pose2> truth;
  Pose2 pose;
  for (int k = 0; k <= 16; ++k) {
    truth.push_back(pose);
    const bool corner = (k + 1) % 4 == 0;
    pose = pose * Pose2(1.0, 0.0, corner ? M_PI / 2 : 0.0);
  }
  const Pose2 world_T_landmark(2.0, -1.0, M_PI / 2);  // a tag on a wall, facing +y

  // Parameter blocks [x, y, yaw], initialised by dead reckoning with biased odometry.
  std::vector<std::array<double, 3>> poses(truth.size());
  std::array<double, 3> landmark = {0.0, 0.0, 0.0};
  Pose2 dead_reckoned;
  std::vector<Pose2> odometry;  // exact relative poses: the measurements
  for (size_t k = 0; k < truth.size(); ++k) {
    poses[k] = {dead_reckoned.x(), dead_reckoned.y(), dead_reckoned.theta()};
    if (k + 1 == truth.size()) break;
    odometry.push_back(hetslam::Between(truth[k], truth[k + 1]));
    const Pose2& step = odometry.back();
    dead_reckoned = dead_reckoned * Pose2(1.05 * step.x(), 1.05 * step.y(),
                                          step.theta() + M_PI / 180.0);
  }

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // one shared manifold
  hetslam::Se2Manifold manifold;
  ceres::Problem problem(problem_options);
  for (auto& block : poses) problem.AddParameterBlock(block.data(), 3, &manifold);
  problem.AddParameterBlock(landmark.data(), 3, &manifold);

  // Odometry (sigma 10 cm, 3 deg); sequential edges take no robust loss.
  const Eigen::Matrix3d odometry_sqrt_info =
      hetslam::SqrtInformationFromStddev(0.1, 0.1, 3.0 * M_PI / 180.0);
  for (size_t k = 0; k + 1 < poses.size(); ++k) {
    problem.AddResidualBlock(hetslam::CreateRelativePose2Cost(odometry[k], odometry_sqrt_info),
                             nullptr, poses[k].data(), poses[k + 1].data());
  }
  // Landmark seen from the first and from the last pose; tag observations get a robust loss.
  const Eigen::Matrix3d tag_sqrt_info =
      hetslam::SqrtInformationFromCovariance(Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal());
  for (const size_t k : {size_t{0}, poses.size() - 1}) {
    problem.AddResidualBlock(
        hetslam::CreateLandmarkObservationCost(hetslam::Between(truth[k], world_T_landmark),
                                               tag_sqrt_info),
        new ceres::CauchyLoss(1.0), poses[k].data(), landmark.data());
  }
  // MARG heading on the last pose: 0 rad, 0.5 deg.
  problem.AddResidualBlock(hetslam::CreateHeadingPriorCost(0.0, 0.5 * M_PI / 180.0),
                           new ceres::HuberLoss(1.0), poses.back().data());
  // Gauge: the first pose is the world origin.
  problem.SetParameterBlockConstant(poses.front().data());

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.function_tolerance = 1e-10;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  std::printf("%s\n", summary.BriefReport().c_str());

  auto error = [](const std::array<double, 3>& estimate, const Pose2& expected,
                  double* meters, double* degrees) {
    *meters = std::hypot(estimate[0] - expected.x(), estimate[1] - expected.y());
    *degrees = std::abs(hetslam::WrapAngle(estimate[2] - expected.theta())) * 180.0 / M_PI;
  };
  double max_m = 0.0, max_deg = 0.0, m = 0.0, deg = 0.0;
  for (size_t k = 0; k < poses.size(); ++k) {
    error(poses[k], truth[k], &m, &deg);
    max_m = std::max(max_m, m);
    max_deg = std::max(max_deg, deg);
  }
  const std::array<double, 3>& start = poses.front();
  const std::array<double, 3>& end = poses.back();
  std::printf("poses: max error %.2e m, %.2e deg; end pose (%.4f, %.4f, %.4f), start (%.4f, %.4f, %.4f)\n",
              max_m, max_deg, end[0], end[1], end[2], start[0], start[1], start[2]);
  error(landmark, world_T_landmark, &m, &deg);
  std::printf("landmark: (%.4f, %.4f, %.4f), truth (%.4f, %.4f, %.4f), error %.2e m, %.2e deg\n",
              landmark[0], landmark[1], landmark[2], world_T_landmark.x(), world_T_landmark.y(),
              world_T_landmark.theta(), m, deg);
  const bool ok = summary.termination_type == ceres::CONVERGENCE && max_m < 1e-3 &&
                  max_deg < 1e-2 && m < 1e-3 && deg < 1e-2;
  std::printf("%s\n", ok ? "OK: converged to the known answer" : "FAILED: not the known answer");
  return ok ? 0 : 1;
}
