#include "frontends/pose_graph_slam.h"

#include <random>

#include "core/trajectory_metrics.h"
#include "datasets/sim/scenario.h"
#include "datasets/sim/simulator.h"
#include "glog/logging.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

// A 14 m x 10 m floor with a 6 m x 2 m inner block: a ring corridor 3–4 m wide with a few
// boxes along its walls, driven once around and a quarter again, so the end revisits the start (a loop whose
// answer the simulator knows). No odometry is used.
constexpr char kRingScenario[] = R"(
wall 0 0 14 0
wall 14 0 14 10
wall 14 10 0 10
wall 0 10 0 0
box 7 5 6 2
box 0.4 5 0.6 0.8
box 13.6 3 0.5 0.9 30
box 7 9.6 1.0 0.4
box 5 0.4 0.6 0.6
box 10.5 6.5 0.8 0.5
waypoint 1.5 1.5
waypoint 12.5 1.5
waypoint 12.5 8.5
waypoint 1.5 8.5
waypoint 1.5 1.5
waypoint 10 1.5
laser 180 181 12 0.01 0.002 4
robot 0.6 45
)";

struct PipelineRun {
  sim::SimulationResult simulation;
  std::vector<StampedPose2> trajectory;
  std::vector<LoopClosureReport> loops;
  PoseGraphSlamStats stats;
};

sim::SimulationResult Simulate(uint64_t seed) {
  sim::Scenario scenario;
  const Status parsed = sim::ParseScenario(kRingScenario, "ring", &scenario);
  CHECK(parsed.ok()) << parsed.message();
  std::mt19937_64 rng(seed);
  sim::SimulationResult simulation;
  const Status simulated = sim::Simulate(scenario, sim::SimulatorOptions(), &rng, &simulation);
  CHECK(simulated.ok()) << simulated.message();
  return simulation;
}

PoseGraphSlamOptions TestOptions() {
  PoseGraphSlamOptions options;
  options.scans_per_submap = 20;
  return options;
}

PipelineRun RunPipeline(const sim::SimulationResult& simulation, const PoseGraphSlamOptions& options) {
  PipelineRun run;
  run.simulation = simulation;
  PoseGraphSlam slam(options);
  for (const LaserReading& reading : simulation.log.lasers) slam.AddScan(reading.scan);
  slam.Finish();
  run.trajectory = slam.trajectory();
  run.loops = slam.LoopClosures();
  run.stats = slam.stats();
  return run;
}

TEST(PoseGraphSlamTest, ClosesTheRingAndMatchesTruth) {
  const PipelineRun run = RunPipeline(Simulate(5), TestOptions());
  ASSERT_EQ(run.simulation.truth.size(), run.trajectory.size());
  EXPECT_EQ(0, run.stats.match_failures);
  EXPECT_GT(run.stats.loop_closures_accepted, 5);
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(run.trajectory, run.simulation.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.08);
  EXPECT_LT(ate.rotation_rmse_degrees, 1.0);
  // Loop-closure precision as Cartographer reports it: accepted closures the final graph
  // agrees with to 20 cm / 1 degree.
  int kept = 0, precise = 0;
  for (const LoopClosureReport& loop : run.loops) {
    if (loop.removed) continue;
    ++kept;
    const Pose2 error = Between(loop.measured_submap_T_node, loop.final_submap_T_node);
    precise += error.translation().norm() < 0.2 && std::abs(error.theta()) < M_PI / 180;
  }
  ASSERT_GT(kept, 0);
  EXPECT_GE(static_cast<double>(precise) / kept, 0.95);
}

TEST(PoseGraphSlamTest, SameInputSameTrajectory) {
  const sim::SimulationResult simulation = Simulate(6);
  const PipelineRun a = RunPipeline(simulation, TestOptions());
  const PipelineRun b = RunPipeline(simulation, TestOptions());
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    ASSERT_EQ(a.trajectory[i].pose.x(), b.trajectory[i].pose.x()) << i;
    ASSERT_EQ(a.trajectory[i].pose.y(), b.trajectory[i].pose.y()) << i;
    ASSERT_EQ(a.trajectory[i].pose.theta(), b.trajectory[i].pose.theta()) << i;
  }
  EXPECT_EQ(a.stats.loop_closures_accepted, b.stats.loop_closures_accepted);
}

// A wrong closure (2 m and 20 degrees off) among correct ones is removed by the consistency
// check and leaves the trajectory as accurate as without it.
TEST(PoseGraphSlamTest, RejectsWrongLoopClosure) {
  const sim::SimulationResult simulation = Simulate(5);
  PoseGraphSlam slam(TestOptions());
  for (const LaserReading& reading : simulation.log.lasers) slam.AddScan(reading.scan);
  const int node = slam.num_nodes() - 1;
  const Pose2 truth_submap0_T_node = Between(simulation.truth.front().pose, simulation.truth.back().pose);
  ASSERT_FALSE(slam.AddLoopClosure(slam.num_submaps(), node, Pose2(), 0.9));
  ASSERT_TRUE(slam.AddLoopClosure(0, node, truth_submap0_T_node * Pose2(2.0, 0.0, 0.35), 0.9));
  slam.Finish();
  const std::vector<LoopClosureReport> loops = slam.LoopClosures();
  ASSERT_FALSE(loops.empty());
  bool found = false;
  for (const LoopClosureReport& loop : loops) {
    if (loop.node == node && loop.submap == 0 && (loop.measured_submap_T_node.translation() -
                                                  truth_submap0_T_node.translation()).norm() > 1.5) {
      found = true;
      EXPECT_TRUE(loop.removed);
    }
  }
  EXPECT_TRUE(found);
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(slam.trajectory(), simulation.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.08);
}

// Dead reckoning with odometry that overestimates distance by 12% and turns 0.12 degrees per
// scan too far (the front end's matches are switched off, so the chain between closures keeps
// that distortion): back at the start the estimate is metres from the truth, beyond the
// standard loop window (narrowed to ±1 m here). The drift bound has grown past that window, so
// the wide search runs, finds the start again, and its closures bring the estimate close
// enough for the standard search to take over; without it the loop stays open.
PipelineRun RunDeadReckoning(const sim::SimulationResult& simulation, bool wide_search) {
  PoseGraphSlamOptions options = TestOptions();
  options.local.prediction = MotionPrediction::kOdometry;
  options.local.matcher.min_correlative_score = 0.999;  // every front-end match "fails"
  options.loop_matcher.linear_search_window_meters = 1.0;
  options.loop_wide_search = wide_search;
  PipelineRun run;
  run.simulation = simulation;
  PoseGraphSlam slam(options);
  Pose2 biased;
  for (size_t i = 0; i < simulation.log.lasers.size(); ++i) {
    const LaserReading& reading = simulation.log.lasers[i];
    if (i > 0) {
      const Pose2 step = Between(simulation.log.lasers[i - 1].odometry_pose, reading.odometry_pose);
      biased = biased * Pose2(1.12 * step.translation(), step.theta() + 0.12 * M_PI / 180);
    }
    slam.AddScan(reading.scan, biased);
  }
  slam.Finish();
  run.trajectory = slam.trajectory();
  run.loops = slam.LoopClosures();
  run.stats = slam.stats();
  return run;
}

// Error (metres) of the pose where the robot is back at its start (the truth's nearest
// approach to the start in the second half), relative to the first pose: the loop's closure.
// (Poses farther on carry the distortion of the dead-reckoned first lap they are tied to.)
double LoopError(const PipelineRun& run) {
  const std::vector<StampedPose2>& truth = run.simulation.truth;
  size_t back = truth.size() / 2;
  for (size_t i = back; i < truth.size(); ++i) {
    if ((truth[i].pose.translation() - truth.front().pose.translation()).norm() <
        (truth[back].pose.translation() - truth.front().pose.translation()).norm()) {
      back = i;
    }
  }
  const Pose2 estimate = Between(run.trajectory.front().pose, run.trajectory[back].pose);
  const Pose2 truth_delta = Between(truth.front().pose, truth[back].pose);
  return (estimate.translation() - truth_delta.translation()).norm();
}

TEST(PoseGraphSlamTest, WideSearchClosesALoopBeyondTheStandardWindow) {
  const sim::SimulationResult simulation = Simulate(5);
  ASSERT_FALSE(simulation.log.lasers.empty());
  ASSERT_TRUE(simulation.log.lasers.front().has_odometry_pose);

  const PipelineRun narrow = RunDeadReckoning(simulation, /*wide_search=*/false);
  EXPECT_EQ(0, narrow.stats.loop_wide_searches);
  EXPECT_GT(LoopError(narrow), 1.5);

  const PipelineRun wide = RunDeadReckoning(simulation, /*wide_search=*/true);
  EXPECT_GT(wide.stats.loop_wide_searches, 0);
  EXPECT_GE(wide.stats.loop_closures_accepted_wide, 2);
  EXPECT_GT(wide.stats.loop_closures_accepted, wide.stats.loop_closures_accepted_wide);  // the standard search took over
  EXPECT_LT(LoopError(wide), 0.2);
  LOG(INFO) << "dead reckoning: loop error " << LoopError(narrow) << " m without the wide search, " << LoopError(wide)
            << " m with it (" << wide.stats.loop_wide_searches << " wide matches, " << wide.stats.loop_wide_candidates
            << " candidates, " << wide.stats.loop_closures_accepted_wide << " wide closures, "
            << wide.stats.loop_closures_accepted << " closures in all)";
}

TEST(PoseGraphSlamOptionsTest, RejectsBadValues) {
  PoseGraphSlamOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.scans_per_submap = 1;
  options.loop_min_score = 2;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("scans_per_submap"));
  EXPECT_NE(std::string::npos, error.find("loop_min_score"));

  PoseGraphSlamOptions wide;
  wide.loop_wide_window_meters = 0;
  wide.loop_wide_min_score = 1.5;
  EXPECT_FALSE(wide.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("wide search windows"));
  EXPECT_NE(std::string::npos, error.find("loop_wide_min_score"));
}

}  // namespace
}  // namespace hetslam
