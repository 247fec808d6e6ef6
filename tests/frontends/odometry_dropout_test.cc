// The ambiguity issue's wrong-prediction case: wheel odometry that freezes for half a second
// while the robot turns (the readings repeat the last pose, then jump), on the shipped
// wheeled_corridor scenario (seed 1) mapped with the odometry as the prediction. The search
// windows follow the odometry's covariance (LocalSlamOptions::odometry_noise_fraction), so the
// jump after the freeze (up to 22°) is found inside them and the map survives. Closures matched in the
// corridor hold the node only across it (LoopCloserOptions::degenerate_max_drop_ratio), so none
// contradicts the graph: seed 1 (the one tested here) 0.052 m ATE, 13 of 13 kept closures
// agree with the final graph to 20 cm / 1° across their weak direction. Before that change it
// was 0.303 m with 3 of 5 (seeds 2-5 then: 0.077, 0.093, 0.103, 0.096 m). With the former
// windows (narrow, full, then a ±92° fallback whatever the prediction) a corridor corner matched
// 90° off and the map was lost, on this log with or without the freeze (7.55 m, 7.41 m ATE).
// Those figures are from the scenario's former route, which cut the inner block's corners
// diagonally (through its walls: the simulator now refuses such routes). On the corrected route
// the robot turns on the spot in the corridor's corners; the freeze is placed where it first
// turns faster than 20°/s, and the map survives it with or without the covariance windows
// (0.052 m, 0.048 m ATE), so the former test that the corner is lost without them is gone.
#include <cmath>
#include <random>

#include "core/measurement_log.h"
#include "core/trajectory_metrics.h"
#include "datasets/sim/scenario.h"
#include "datasets/sim/team_simulator.h"
#include "frontends/online_estimator.h"
#include "glog/logging.h"
#include "gtest/gtest.h"
#include "tests/frontends/sim_fixtures.h"

namespace hetslam {
namespace {

struct DropoutRun {
  AbsoluteTrajectoryError ate;
  int kept_closures = 0;
  int agreeing_closures = 0;
  int removed_closures = 0;
};

DropoutRun MapCorridorWithFrozenOdometry(double odometry_noise_fraction) {
  sim::TeamSimulationResult result = testing_sim::SimulateShippedScenario("wheeled_corridor", 1);
  RobotLog log = std::move(result.robots.front().log);
  const std::vector<StampedPose2> truth = testing_sim::PlanarTruth(log);
  // The first corner: where the robot first turns faster than 20°/s (it turns on the spot at up
  // to 45°/s). Readings in (t0, t0 + 0.5] s repeat the one at t0 (t0 on the 0.1 s grid).
  double turn_start = -1.0;
  for (size_t i = 1; i < truth.size() && turn_start < 0; ++i) {
    const double dt = truth[i].stamp_seconds - truth[i - 1].stamp_seconds;
    const double rate = WrapAngle(truth[i].pose.theta() - truth[i - 1].pose.theta()) / dt;
    if (dt > 0 && std::abs(rate) > 20.0 * M_PI / 180.0) turn_start = std::round(truth[i - 1].stamp_seconds * 10.0) / 10.0;
  }
  CHECK_GT(turn_start, 10.0) << "no turn in the corridor's first leg";
  const OdometryReading* frozen = nullptr;
  int frozen_readings = 0;
  for (OdometryReading& reading : log.odometry) {
    if (std::abs(reading.stamp_seconds - turn_start) < 1e-9) frozen = &reading;
    if (frozen != nullptr && reading.stamp_seconds > turn_start && reading.stamp_seconds <= turn_start + 0.5 + 1e-9) {
      reading.pose = frozen->pose;
      ++frozen_readings;
    }
  }
  CHECK_EQ(10, frozen_readings);

  OnlineEstimatorOptions options;
  options.use_odometry = true;
  options.use_commands = false;
  options.local.prediction = MotionPrediction::kOdometry;
  options.local.odometry_noise_fraction = odometry_noise_fraction;
  OnlineEstimator estimator(options);
  const MeasurementLog stream = MeasurementLogFromRobotLog(std::move(log));
  for (const Measurement& m : stream.measurements) {
    const Status status = estimator.Add(m);
    EXPECT_TRUE(status.ok()) << status.message();
  }
  estimator.Finish();
  DropoutRun run;
  run.ate = ComputeAbsoluteTrajectoryError(estimator.Trajectory(), truth);
  for (const LoopClosureReport& loop : estimator.graph().LoopClosures()) {
    if (loop.removed) {
      ++run.removed_closures;
      continue;
    }
    ++run.kept_closures;
    run.agreeing_closures += ClosureAgrees(loop, 0.2, M_PI / 180.0);
  }
  return run;
}

TEST(OdometryDropoutTest, FrozenOdometryInATurnLeavesTheMapConsistent) {
  const DropoutRun run = MapCorridorWithFrozenOdometry(LocalSlamOptions().odometry_noise_fraction);
  LOG(INFO) << "ATE " << run.ate.translation_rmse_meters << " m, " << run.ate.rotation_rmse_degrees << " deg; closures "
            << run.agreeing_closures << " of " << run.kept_closures << " kept agree, " << run.removed_closures
            << " removed";
  ASSERT_GT(run.ate.matched, 800);
  EXPECT_LT(run.ate.translation_rmse_meters, 0.15);
  EXPECT_LT(run.ate.rotation_rmse_degrees, 1.5);
  ASSERT_GT(run.kept_closures, 5);
  EXPECT_GE(run.agreeing_closures, 0.9 * run.kept_closures);
}

}  // namespace
}  // namespace hetslam
