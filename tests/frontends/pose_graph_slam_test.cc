#include "frontends/pose_graph_slam.h"

#include <random>

#include "core/trajectory_metrics.h"
#include "datasets/sim/simulator.h"
#include "datasets/sim/world.h"
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

TEST(PoseGraphSlamOptionsTest, RejectsBadValues) {
  PoseGraphSlamOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.scans_per_submap = 1;
  options.loop_min_score = 2;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("scans_per_submap"));
  EXPECT_NE(std::string::npos, error.find("loop_min_score"));
}

}  // namespace
}  // namespace hetslam
