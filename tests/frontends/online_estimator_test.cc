#include "frontends/online_estimator.h"

#include <random>

#include "core/measurement_log.h"
#include "core/robot_log.h"
#include "core/trajectory_metrics.h"
#include "datasets/sim/simulator.h"
#include "datasets/sim/team_simulator.h"
#include "datasets/sim/world.h"
#include "glog/logging.h"
#include "gtest/gtest.h"
#include "tests/frontends/sim_fixtures.h"
#include "tests/test_data.h"

namespace hetslam {
namespace {

struct PipelineRun {
  sim::SimulationResult simulation;
  std::vector<StampedPose2> trajectory;
  std::vector<LoopClosureReport> loops;
  OnlineEstimatorStats stats;
  SubmapGraphStats graph;
  LoopCloserStats loop;
  size_t finished_submap_bytes = 0;  // the map store at the end
  int finished_submaps_kept = 0;
  std::vector<double> retired_first_stamps;  // of each retired submap's first node
};

// A 14 m x 10 m floor with a 6 m x 2 m inner block: a ring corridor 3–4 m wide with a few
// boxes along its walls, driven once around and a quarter again, so the end revisits the start
// (a loop whose answer the simulator knows). No odometry is used.
sim::SimulationResult Simulate(uint64_t seed) { return testing_sim::SimulateRing(seed); }

OnlineEstimatorOptions TestOptions() {
  OnlineEstimatorOptions options;
  options.local.scans_per_submap = 20;
  return options;
}

void Feed(const sim::SimulationResult& simulation, OnlineEstimator* estimator) {
  for (const LaserReading& reading : simulation.log.lasers) {
    const Status status = estimator->Add(reading);
    ASSERT_TRUE(status.ok()) << status.message();
  }
}

void Collect(const OnlineEstimator& estimator, PipelineRun* run) {
  run->trajectory = estimator.Trajectory();
  run->loops = estimator.graph().LoopClosures();
  run->stats = estimator.stats();
  run->graph = estimator.graph().stats();
  run->loop = estimator.loop_closer().stats();
  const int robot = estimator.options().robot;
  run->finished_submap_bytes = estimator.graph().FinishedSubmapBytes(robot);
  const SubmapGraph& graph = estimator.graph();
  for (int i = 0; i < graph.num_submaps(robot); ++i) {
    const bool kept = graph.FinishedSubmapMap({robot, i}) != nullptr;
    run->finished_submaps_kept += kept;
    if (!kept && graph.SubmapFinished({robot, i})) {
      run->retired_first_stamps.push_back(graph.NodeStamp({robot, graph.SubmapFirstNode({robot, i})}));
    }
  }
}

PipelineRun RunPipeline(const sim::SimulationResult& simulation, const OnlineEstimatorOptions& options) {
  PipelineRun run;
  run.simulation = simulation;
  OnlineEstimator estimator(options);
  Feed(simulation, &estimator);
  estimator.Finish();
  Collect(estimator, &run);
  return run;
}

// A log's PARAM command_response_seconds sets the EKF's command lag; a bad value is an error
// naming the PARAM and leaves the options as they were; other params are left alone.
TEST(OnlineEstimatorTest, LogParamsSetTheCommandResponse) {
  OnlineEstimatorOptions options;
  ASSERT_TRUE(ApplyLogParams({{"robot_kind", "uav"}}, &options).ok());
  EXPECT_EQ(0.0, options.ekf.command_response_seconds);
  ASSERT_TRUE(ApplyLogParams({{"command_response_seconds", "0.250"}}, &options).ok());
  EXPECT_EQ(0.25, options.ekf.command_response_seconds);
  for (const char* bad : {"", "fast", "0.25s", "-1", "nan", "1e9"}) {
    const Status status = ApplyLogParams({{"command_response_seconds", bad}}, &options);
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_NE(std::string::npos, status.message().find("PARAM command_response_seconds")) << status.message();
    EXPECT_EQ(0.25, options.ekf.command_response_seconds) << bad;
  }
}

TEST(OnlineEstimatorTest, ClosesTheRingAndMatchesTruth) {
  const PipelineRun run = RunPipeline(Simulate(5), TestOptions());
  ASSERT_EQ(run.simulation.truth.size(), run.trajectory.size());
  EXPECT_EQ(0, run.stats.match_failures);
  EXPECT_FALSE(run.stats.lowest_ray_height_meters.has_value());  // a 2D laser: no heights
  EXPECT_GT(run.graph.loop_closures_accepted, 5);
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(run.trajectory, run.simulation.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.08);
  EXPECT_LT(ate.rotation_rmse_degrees, 1.0);
  // Loop-closure precision as Cartographer reports it: accepted closures the final graph
  // agrees with to 20 cm / 1 degree.
  int kept = 0, precise = 0;
  for (const LoopClosureReport& loop : run.loops) {
    if (loop.removed) continue;
    ++kept;
    precise += ClosureAgrees(loop, 0.2, M_PI / 180);
  }
  ASSERT_GT(kept, 0);
  EXPECT_GE(static_cast<double>(precise) / kept, 0.95);
}

// The robot's frame is its body at its first scan (OnlineEstimatorOptions::rematch_first_node):
// once the first submap is finished, the first node's heading in it is the refinement of its
// scan against that map (its position stays where the front end inserted it, the identity),
// and the robot's map was turned around it, so the trajectory still starts at the identity.
// Without the rematch the first node keeps the identity in the first submap.
TEST(OnlineEstimatorTest, TheFirstNodeSitsWhereTheFinishedFirstSubmapPutsIt) {
  const sim::SimulationResult simulation = Simulate(3);
  for (const bool rematch : {false, true}) {
    OnlineEstimatorOptions options = TestOptions();
    options.rematch_first_node = rematch;
    OnlineEstimator estimator(options);
    Feed(simulation, &estimator);
    estimator.Finish();
    const SubmapGraph& graph = estimator.graph();
    ASSERT_TRUE(graph.SubmapFinished({0, 0}));
    Pose2 first;
    ASSERT_TRUE(graph.IntraSubmapPose({0, 0}, {0, 0}, &first));
    const std::vector<StampedPose2> trajectory = estimator.Trajectory();
    ASSERT_FALSE(trajectory.empty());
    EXPECT_NEAR(0.0, trajectory.front().pose.translation().norm(), 1e-6) << "rematch " << rematch;
    EXPECT_NEAR(0.0, trajectory.front().pose.theta(), 1e-7) << "rematch " << rematch;
    if (!rematch) {
      EXPECT_EQ(Pose2::Identity().ToVector(), first.ToVector());
      EXPECT_FALSE(estimator.stats().first_node_rematch_radians.has_value());
      continue;
    }
    ASSERT_TRUE(estimator.stats().first_node_rematch_radians.has_value());
    EXPECT_EQ(first.theta(), *estimator.stats().first_node_rematch_radians);
    EXPECT_NE(0.0, first.theta()) << "the finished map turns the first scan a little";
    EXPECT_EQ(0.0, first.translation().norm());
    const SubmapGraph::MatchingPoints points = graph.NodeMatchingPoints({0, 0});
    const std::optional<Pose2> refined = ScanMatcher(options.loop.matcher)
                                             .Refine(*graph.FinishedSubmapMap({0, 0}), Pose2::Identity(), points.points,
                                                     points.weights, 4 * options.loop.matcher.max_angular_step_radians);
    ASSERT_TRUE(refined.has_value());
    EXPECT_EQ(refined->theta(), first.theta());
  }
}

// Issue #15: loop search within a budget. With at most two submaps per search (those the scan
// overlaps most), the ring still closes with the same accuracy bound, with fewer matches.
TEST(OnlineEstimatorTest, LoopSearchBudgetMatchesTheMostOverlappingSubmapsOnly) {
  const sim::SimulationResult simulation = Simulate(5);
  OnlineEstimatorOptions every = TestOptions();
  every.loop.max_submaps_per_search = 0;
  const PipelineRun all = RunPipeline(simulation, every);
  OnlineEstimatorOptions budget = TestOptions();
  budget.loop.max_submaps_per_search = 2;
  const PipelineRun nearest = RunPipeline(simulation, budget);
  EXPECT_EQ(0, all.loop.submaps_skipped);
  EXPECT_GT(nearest.loop.submaps_skipped, 0);
  EXPECT_LT(nearest.loop.searches, all.loop.searches);
  EXPECT_GT(nearest.graph.loop_closures_accepted, 5);
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(nearest.trajectory, simulation.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.08);
  EXPECT_LT(ate.rotation_rmse_degrees, 1.0);
}

// Issue #15, lifelong memory: with max_map_store_bytes the finished submaps' maps stay within
// the bound (submaps evicted, counted), and the run still maps the ring; a bound the run never
// reaches changes nothing.
TEST(OnlineEstimatorTest, BoundedMapStoreEvictsSubmapsAndStaysWithinTheBound) {
  const sim::SimulationResult simulation = Simulate(5);
  const PipelineRun unbounded = RunPipeline(simulation, TestOptions());
  ASSERT_GT(unbounded.finished_submaps_kept, 4);
  EXPECT_EQ(0, unbounded.graph.submaps_evicted);

  OnlineEstimatorOptions never = TestOptions();
  never.max_map_store_bytes = 4 * unbounded.finished_submap_bytes;
  const PipelineRun same = RunPipeline(simulation, never);
  EXPECT_EQ(0, same.graph.submaps_evicted);
  ASSERT_EQ(unbounded.trajectory.size(), same.trajectory.size());
  for (size_t i = 0; i < same.trajectory.size(); ++i) {
    ASSERT_EQ(unbounded.trajectory[i].pose.ToVector(), same.trajectory[i].pose.ToVector()) << i;
  }

  OnlineEstimatorOptions bounded = TestOptions();
  bounded.max_map_store_bytes = unbounded.finished_submap_bytes * 4 / 5;
  const PipelineRun evicting = RunPipeline(simulation, bounded);
  EXPECT_GT(evicting.graph.submaps_evicted, 0);
  EXPECT_LE(evicting.finished_submap_bytes, bounded.max_map_store_bytes);
  EXPECT_EQ(unbounded.finished_submaps_kept + unbounded.graph.submaps_retired,
            evicting.finished_submaps_kept + evicting.graph.submaps_evicted + evicting.graph.submaps_retired);
  EXPECT_GT(evicting.graph.evicted_bytes, 0u);
  EXPECT_EQ(unbounded.trajectory.size(), evicting.trajectory.size());
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(evicting.trajectory, simulation.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.08);
}

// Issue #15, revisits attach to the map they revisit: the ring's last quarter drives the first
// one again, and the submaps it makes are retired (their maps freed, the earlier submaps
// searched instead); none of the first lap is; the trajectory stays on the truth.
TEST(OnlineEstimatorTest, SubmapsOfARevisitAreRetired) {
  const sim::SimulationResult simulation = Simulate(5);
  OnlineEstimatorOptions keep_all = TestOptions();
  keep_all.retire_revisited_share = 0.0;
  const PipelineRun all = RunPipeline(simulation, keep_all);
  ASSERT_GT(TestOptions().retire_revisited_share, 0.0) << "on by default";
  const PipelineRun retiring = RunPipeline(simulation, TestOptions());

  EXPECT_EQ(0, all.graph.submaps_retired);
  EXPECT_GT(retiring.graph.submaps_retired, 0);
  EXPECT_EQ(0, retiring.graph.submaps_evicted);
  EXPECT_EQ(all.finished_submaps_kept, retiring.finished_submaps_kept + retiring.graph.submaps_retired);
  EXPECT_LT(retiring.finished_submap_bytes, all.finished_submap_bytes);
  // The revisit starts when the robot is back within 2 m of its start, having been 5 m away.
  const Eigen::Vector2d start = simulation.truth.front().pose.translation();
  double revisit_stamp = -1.0;
  bool away = false;
  for (const StampedPose2& truth : simulation.truth) {
    const double d = (truth.pose.translation() - start).norm();
    away |= d > 5.0;
    if (away && d < 2.0) {
      revisit_stamp = truth.stamp_seconds;
      break;
    }
  }
  ASSERT_GT(revisit_stamp, 0.0);
  ASSERT_EQ(static_cast<size_t>(retiring.graph.submaps_retired), retiring.retired_first_stamps.size());
  for (const double stamp : retiring.retired_first_stamps) EXPECT_GE(stamp, revisit_stamp - 5.0);
  ASSERT_EQ(simulation.truth.size(), retiring.trajectory.size());
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(retiring.trajectory, simulation.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.08);
  EXPECT_LT(ate.rotation_rmse_degrees, 1.0);
}

// Issue #15: after a solve, the scans of retired submaps leave the graph (AttachRevisits) but
// for those holding the best closures; they ride on their submap, so the trajectory keeps
// every scan and stays on the truth, with fewer closures in the graph.
TEST(OnlineEstimatorTest, ScansOfARevisitRideOnTheirSubmap) {
  const sim::SimulationResult simulation = Simulate(5);
  OnlineEstimatorOptions in_graph = TestOptions();
  in_graph.attach_revisits = false;
  const PipelineRun kept = RunPipeline(simulation, in_graph);
  ASSERT_TRUE(TestOptions().attach_revisits) << "on by default";
  const PipelineRun attached = RunPipeline(simulation, TestOptions());
  EXPECT_EQ(0, kept.graph.nodes_attached);
  EXPECT_GT(attached.graph.nodes_attached, 0);
  EXPECT_GT(attached.graph.closures_released, 0);
  EXPECT_EQ(kept.graph.submaps_retired, attached.graph.submaps_retired);
  ASSERT_EQ(simulation.truth.size(), attached.trajectory.size());
  const AbsoluteTrajectoryError with = ComputeAbsoluteTrajectoryError(attached.trajectory, simulation.truth);
  const AbsoluteTrajectoryError without = ComputeAbsoluteTrajectoryError(kept.trajectory, simulation.truth);
  EXPECT_LT(with.translation_rmse_meters, 0.08);
  EXPECT_LT(with.rotation_rmse_degrees, 1.0);
  EXPECT_NEAR(without.translation_rmse_meters, with.translation_rmse_meters, 0.01);
}

// Issue #15: the solves' spacing grows with the graph (solve_min_new_node_share): a solve
// waits for that share of the nodes as new ones, so a long run solves less often as it grows.
// The default's share changes nothing on a run this short; a large one solves less, still
// on the truth.
TEST(OnlineEstimatorTest, SolveSpacingGrowsWithTheGraph) {
  const sim::SimulationResult simulation = Simulate(5);
  OnlineEstimatorOptions fixed = TestOptions();
  fixed.solve_min_new_node_share = 0.0;
  const PipelineRun every = RunPipeline(simulation, fixed);
  const PipelineRun by_default = RunPipeline(simulation, TestOptions());
  ASSERT_LT(every.trajectory.size() * TestOptions().solve_min_new_node_share, TestOptions().solve_min_new_nodes);
  EXPECT_EQ(every.graph.solves, by_default.graph.solves);
  OnlineEstimatorOptions sparse = TestOptions();
  sparse.solve_min_new_node_share = 0.2;
  const PipelineRun fewer = RunPipeline(simulation, sparse);
  EXPECT_LT(fewer.graph.solves, every.graph.solves);
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(fewer.trajectory, simulation.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.08);
  EXPECT_LT(ate.rotation_rmse_degrees, 1.0);
  OnlineEstimatorOptions bad = TestOptions();
  bad.solve_min_new_node_share = 1.5;
  std::string error;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("solve_min_new_node_share"));
}

TEST(OnlineEstimatorTest, SameInputSameTrajectory) {
  const sim::SimulationResult simulation = Simulate(6);
  const PipelineRun a = RunPipeline(simulation, TestOptions());
  const PipelineRun b = RunPipeline(simulation, TestOptions());
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    ASSERT_EQ(a.trajectory[i].pose.x(), b.trajectory[i].pose.x()) << i;
    ASSERT_EQ(a.trajectory[i].pose.y(), b.trajectory[i].pose.y()) << i;
    ASSERT_EQ(a.trajectory[i].pose.theta(), b.trajectory[i].pose.theta()) << i;
  }
  EXPECT_EQ(a.graph.loop_closures_accepted, b.graph.loop_closures_accepted);
}

// A wrong closure (2 m and 20 degrees off) among correct ones is removed by the consistency
// check and leaves the trajectory as accurate as without it.
TEST(OnlineEstimatorTest, RejectsWrongLoopClosure) {
  const sim::SimulationResult simulation = Simulate(5);
  OnlineEstimator estimator(TestOptions());
  Feed(simulation, &estimator);
  SubmapGraph& graph = estimator.mutable_graph();
  const NodeId node{0, graph.num_nodes(0) - 1};
  const Pose2 truth_submap0_T_node = Between(simulation.truth.front().pose, simulation.truth.back().pose);
  ASSERT_FALSE(graph.AddConstraint({{0, graph.num_submaps(0)}, node, Pose2(), 0.9}));
  ASSERT_TRUE(graph.AddConstraint({{0, 0}, node, truth_submap0_T_node * Pose2(2.0, 0.0, 0.35), 0.9}));
  estimator.Finish();
  const std::vector<LoopClosureReport> loops = graph.LoopClosures();
  ASSERT_FALSE(loops.empty());
  bool found = false;
  for (const LoopClosureReport& loop : loops) {
    if (loop.node == node && loop.submap.index == 0 && (loop.measured_submap_T_node.translation() -
                                                  truth_submap0_T_node.translation()).norm() > 1.5) {
      found = true;
      EXPECT_TRUE(loop.removed);
    }
  }
  EXPECT_TRUE(found);
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(estimator.Trajectory(), simulation.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.08);
}

// Dead reckoning with odometry that overestimates distance by 12% and turns 0.12 degrees per
// scan too far (the front end's matches are switched off, so the chain between closures keeps
// that distortion): back at the start the estimate is metres from the truth, beyond the
// standard loop window (narrowed to ±1 m here). The drift bound has grown past that window, so
// the wide search runs, finds the start again, and its closures bring the estimate close
// enough for the standard search to take over; without it the loop stays open.
PipelineRun RunDeadReckoning(const sim::SimulationResult& simulation, bool wide_search) {
  OnlineEstimatorOptions options = TestOptions();
  options.local.prediction = MotionPrediction::kOdometry;
  options.use_odometry = true;
  options.local.matcher.min_correlative_score = 0.999;  // every front-end match "fails"
  options.loop.matcher.linear_search_window_meters = 1.0;
  options.loop.wide_search = wide_search;
  PipelineRun run;
  run.simulation = simulation;
  OnlineEstimator estimator(options);
  Pose2 biased;
  for (size_t i = 0; i < simulation.log.lasers.size(); ++i) {
    const LaserReading& reading = simulation.log.lasers[i];
    if (i > 0) {
      const Pose2 step = Between(simulation.log.lasers[i - 1].odometry_pose, reading.odometry_pose);
      biased = biased * Pose2(1.12 * step.translation(), step.theta() + 0.12 * M_PI / 180);
    }
    LaserReading dead_reckoned = reading;
    dead_reckoned.odometry_pose = biased;
    dead_reckoned.has_odometry_pose = true;
    EXPECT_TRUE(estimator.Add(dead_reckoned).ok());
  }
  estimator.Finish();
  Collect(estimator, &run);
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

TEST(OnlineEstimatorTest, WideSearchClosesALoopBeyondTheStandardWindow) {
  const sim::SimulationResult simulation = Simulate(5);
  ASSERT_FALSE(simulation.log.lasers.empty());
  ASSERT_TRUE(simulation.log.lasers.front().has_odometry_pose);

  const PipelineRun narrow = RunDeadReckoning(simulation, /*wide_search=*/false);
  EXPECT_EQ(0, narrow.loop.wide_searches);
  EXPECT_GT(LoopError(narrow), 1.5);

  const PipelineRun wide = RunDeadReckoning(simulation, /*wide_search=*/true);
  EXPECT_GT(wide.loop.wide_searches, 0);
  EXPECT_GE(wide.loop.wide_accepted, 2);
  EXPECT_GT(wide.graph.loop_closures_accepted, wide.loop.wide_accepted);  // the standard search took over
  EXPECT_LT(LoopError(wide), 0.2);
  LOG(INFO) << "dead reckoning: loop error " << LoopError(narrow) << " m without the wide search, " << LoopError(wide)
            << " m with it (" << wide.loop.wide_searches << " wide matches, " << wide.loop.wide_candidates
            << " candidates, " << wide.loop.wide_accepted << " wide closures, "
            << wide.graph.loop_closures_accepted << " closures in all)";
}

// Issue #15: a robot standing still stops growing. The ring's first scan repeated 300 and 3000
// times (10 Hz): with the motion filter, the same nodes, submaps and map memory either way, and
// still one pose per scan, on the spot; without it, a node per scan.
TEST(OnlineEstimatorTest, MotionFilterKeepsAStandingRobotFromGrowing) {
  const sim::SimulationResult simulation = Simulate(1);
  struct Standing {
    int nodes = 0;
    int submaps = 0;
    size_t finished_bytes = 0;
    size_t poses = 0;
    double max_offset_meters = 0.0;
    int filtered = 0;
  };
  auto stand = [&](int repeats, double filter_meters) {
    OnlineEstimatorOptions options = TestOptions();
    options.local.motion_filter_distance_meters = filter_meters;
    OnlineEstimator estimator(options);
    LaserReading reading = simulation.log.lasers.front();
    for (int k = 0; k < repeats; ++k) {
      reading.scan.stamp_seconds = 0.1 * k;
      const Status status = estimator.Add(reading);
      EXPECT_TRUE(status.ok()) << status.message();
    }
    estimator.Finish();
    Standing s;
    s.nodes = estimator.graph().num_nodes(0);
    s.submaps = estimator.graph().num_submaps(0);
    s.finished_bytes = estimator.graph().FinishedSubmapBytes(0);
    const std::vector<StampedPose2> trajectory = estimator.Trajectory();
    s.poses = trajectory.size();
    for (const StampedPose2& p : trajectory) s.max_offset_meters = std::max(s.max_offset_meters, p.pose.translation().norm());
    s.filtered = estimator.stats().filtered_scans;
    return s;
  };
  const Standing few = stand(300, 0.05);
  const Standing many = stand(3000, 0.05);
  EXPECT_EQ(1, few.nodes);
  EXPECT_EQ(few.nodes, many.nodes);
  EXPECT_EQ(few.submaps, many.submaps);
  EXPECT_EQ(few.finished_bytes, many.finished_bytes);
  EXPECT_EQ(300u, few.poses);
  EXPECT_EQ(3000u, many.poses);
  EXPECT_EQ(2999, many.filtered);
  EXPECT_LT(many.max_offset_meters, 0.01);
  const Standing unfiltered = stand(300, 0.0);
  EXPECT_EQ(300, unfiltered.nodes);
  EXPECT_GT(unfiltered.submaps, 10);
}

TEST(OnlineEstimatorOptionsTest, RejectsBadValues) {
  OnlineEstimatorOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.local.scans_per_submap = 1;
  options.loop.min_score = 2;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("scans_per_submap"));
  EXPECT_NE(std::string::npos, error.find("min_score"));

  OnlineEstimatorOptions tilt;
  tilt.floor_tilt_gain = 1.5;
  tilt.floor_tilt_min_depression_radians = 0.0;
  tilt.floor_tilt_max_correction_radians = -1.0;
  EXPECT_FALSE(tilt.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("floor_tilt_max_correction_radians"));
  EXPECT_NE(std::string::npos, error.find("floor_tilt_gain"));
  EXPECT_NE(std::string::npos, error.find("floor_tilt_min_depression_radians"));

  OnlineEstimatorOptions wide;
  wide.loop.wide_window_meters = 0;
  wide.loop.wide_min_score = 1.5;
  EXPECT_FALSE(wide.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("wide search windows"));
  EXPECT_NE(std::string::npos, error.find("wide_min_score"));
}


// The first `seconds` of the shipped humanoid_explore scenario (seed 1) as a measurement stream:
// a walking humanoid whose head pitches, with MARG samples at 100 Hz, commands and scans at 10 Hz.
// The first robot of a shipped scenario (seed 1), `seconds` of it.
MeasurementLog ShippedStream(const std::string& name, double seconds) {
  sim::TeamSimulationResult result = testing_sim::SimulateShippedScenario(name, 1, seconds);
  return MeasurementLogFromRobotLog(std::move(result.robots.front().log));
}

MeasurementLog HumanoidStream(double seconds, const std::string& name = "humanoid_explore") {
  return ShippedStream(name, seconds);
}

std::vector<StampedPose2> RunStream(const std::vector<Measurement>& stream, OnlineEstimatorStats* stats = nullptr,
                                    int64_t* replayed = nullptr) {
  OnlineEstimator estimator{OnlineEstimatorOptions()};
  for (const Measurement& m : stream) {
    const Status status = estimator.Add(m);
    EXPECT_TRUE(status.ok()) << status.message();
  }
  estimator.Finish();
  if (stats != nullptr) *stats = estimator.stats();
  if (replayed != nullptr) *replayed = estimator.ekf().num_replayed();
  return estimator.Trajectory();
}

// Done-when of the online-estimator issue: every scan delayed 50–150 ms behind the MARG samples
// (a laser driver's latency; scans keep their order among themselves) gives the trajectory of
// the stamp-ordered stream, because every scan is predicted and projected from measurements
// stamped at or before it and the EKF rewinds to insert each match.
TEST(OnlineEstimatorStreamingTest, DelayedScansGiveTheStampOrderTrajectory) {
  const MeasurementLog log = HumanoidStream(20.0);
  ASSERT_GT(log.num_scans, 150);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> delay(0.05, 0.15);
  struct Arrival {
    double time;
    size_t index;
  };
  std::vector<Arrival> arrivals;
  double last_scan_arrival = -1e9;
  for (size_t i = 0; i < log.measurements.size(); ++i) {
    double time = StampOf(log.measurements[i]);
    if (std::holds_alternative<LaserReading>(log.measurements[i])) {
      time = std::max(time + delay(rng), last_scan_arrival + 1e-6);
      last_scan_arrival = time;
    }
    arrivals.push_back({time, i});
  }
  std::stable_sort(arrivals.begin(), arrivals.end(), [](const Arrival& a, const Arrival& b) { return a.time < b.time; });
  std::vector<Measurement> delayed;
  for (const Arrival& a : arrivals) delayed.push_back(log.measurements[a.index]);

  OnlineEstimatorStats in_order_stats, delayed_stats;
  int64_t in_order_replayed = 0, delayed_replayed = 0;
  const std::vector<StampedPose2> in_order = RunStream(log.measurements, &in_order_stats, &in_order_replayed);
  const std::vector<StampedPose2> late = RunStream(delayed, &delayed_stats, &delayed_replayed);
  EXPECT_EQ(log.num_scans, in_order_stats.scans);
  EXPECT_EQ(in_order_stats.scans, in_order_stats.ekf_predicted_scans);  // the EKF predicted every scan
  EXPECT_GT(delayed_replayed, 1000);  // the EKF did rewind: ~5-15 MARG samples per scan
  EXPECT_EQ(0, in_order_replayed);
  ASSERT_EQ(in_order.size(), late.size());
  for (size_t i = 0; i < in_order.size(); ++i) {
    ASSERT_EQ(in_order[i].stamp_seconds, late[i].stamp_seconds);
    EXPECT_NEAR(in_order[i].pose.x(), late[i].pose.x(), 1e-9) << i;
    EXPECT_NEAR(in_order[i].pose.y(), late[i].pose.y(), 1e-9) << i;
    EXPECT_NEAR(in_order[i].pose.theta(), late[i].pose.theta(), 1e-9) << i;
  }
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(late, log.truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.15);
}

// Paper §III-A/E, Fig. 1-2: a standing humanoid tilts its head level -> 40° down -> level. While
// the floor dominates the scans, matching and map updates stop and the EKF (zero commands) holds
// the pose; when the walls come back, matching resumes. The estimate never leaves the start.
TEST(OnlineEstimatorStreamingTest, SuspendPredictResumeKeepsAStandingHumanoidInPlace) {
  const MeasurementLog log = HumanoidStream(0.0, "humanoid_static_tilt");
  OnlineEstimator estimator{OnlineEstimatorOptions()};
  int scans = 0, suspended_before = 0, resumed = 0;
  for (const Measurement& m : log.measurements) {
    ASSERT_TRUE(estimator.Add(m).ok());
    if (!std::holds_alternative<LaserReading>(m)) continue;
    ++scans;
    if (estimator.stats().suspended_scans > suspended_before) {
      suspended_before = estimator.stats().suspended_scans;
    } else if (suspended_before > 0) {
      ++resumed;  // inserted after a suspension
    }
  }
  estimator.Finish();
  EXPECT_GT(estimator.stats().suspended_scans, 20);
  EXPECT_GT(resumed, 10);
  EXPECT_GT(estimator.stats().floor_obstacle_points, 0);
  // The head's rays reached the floor: nothing stands under them (merger/map_merge.h, MapHeights).
  ASSERT_TRUE(estimator.stats().lowest_ray_height_meters.has_value());
  EXPECT_EQ(0.0, *estimator.stats().lowest_ray_height_meters);
  const std::vector<StampedPose2> trajectory = estimator.Trajectory();
  ASSERT_EQ(static_cast<size_t>(scans), trajectory.size());  // every scan has a pose, suspended or not
  const Pose2 start = trajectory.front().pose;
  for (const StampedPose2& p : trajectory) {
    const Pose2 moved = Between(start, p.pose);
    EXPECT_LT(moved.translation().norm(), 0.04) << "t=" << p.stamp_seconds;
    EXPECT_LT(std::abs(moved.theta()), 0.6 * M_PI / 180) << "t=" << p.stamp_seconds;
  }
}

// A UAV flying at 1.2-1.8 m (uav_flight) never sees the floor: its lowest ray is its lowest flight
// height less what its tilt lowers the far end points by, well above a wheeled robot's 0.3 m
// laser. A box under it is passed over (merger/map_merge.h, MapHeights).
TEST(OnlineEstimatorStreamingTest, TheLowestRayOfAUavIsNearItsLowestFlightHeight) {
  OnlineEstimatorStats stats;
  RunStream(ShippedStream("uav_flight", 40.0).measurements, &stats);
  EXPECT_EQ(0, stats.floor_points);
  EXPECT_GT(stats.projected_scans, 100);
  ASSERT_TRUE(stats.lowest_ray_height_meters.has_value());
  EXPECT_GT(*stats.lowest_ray_height_meters, 0.6);
  EXPECT_LE(*stats.lowest_ray_height_meters, 1.5);
}

// An accelerometer bias tilts the MARG filter's attitude for good (paper §III-A's filter cannot
// tell it from a tilt); the floor the tilted head sees measures it (FloorTiltError). The same
// 40 s of humanoid_explore with (0.1, -0.06, 0) m/s² added to every accelerometer sample: the
// filter's pitch comes out 0.1 / g too small and its roll 0.06 / g too large, and the floor's
// correction grows by just that (to within 0.15°).
TEST(OnlineEstimatorStreamingTest, TheFloorCorrectsTheTiltOfABiasedAccelerometer) {
  const MeasurementLog log = HumanoidStream(40.0);
  const Eigen::Vector3d bias(0.1, -0.06, 0.0);
  std::vector<Measurement> biased = log.measurements;
  for (Measurement& m : biased) {
    if (MargSample* sample = std::get_if<MargSample>(&m)) sample->accel_mps2 += bias;
  }
  OnlineEstimatorStats plain, corrected;
  RunStream(log.measurements, &plain);
  RunStream(biased, &corrected);
  ASSERT_GT(OnlineEstimatorOptions().floor_tilt_gain, 0.0);
  EXPECT_GT(plain.floor_tilt_updates, 100);
  EXPECT_GT(corrected.floor_tilt_updates, 100);
  const double g = OnlineEstimatorOptions().marg.gravity_mps2;
  const Eigen::Vector2d grown = corrected.floor_tilt_radians - plain.floor_tilt_radians;
  EXPECT_NEAR(-bias.y() / g, grown.x(), 0.15 * M_PI / 180.0);  // roll
  EXPECT_NEAR(bias.x() / g, grown.y(), 0.15 * M_PI / 180.0);   // pitch
  // The correction stays within its bound (a floor that is not level cannot tilt it further).
  OnlineEstimatorOptions bounded;
  bounded.floor_tilt_max_correction_radians = 0.1 * M_PI / 180.0;
  OnlineEstimator clamped(bounded);
  for (const Measurement& m : biased) ASSERT_TRUE(clamped.Add(m).ok());
  EXPECT_GT(clamped.stats().floor_tilt_updates, 100);
  EXPECT_NEAR(bounded.floor_tilt_max_correction_radians, clamped.stats().floor_tilt_radians.y(), 1e-12);
  EXPECT_LE(clamped.stats().floor_tilt_radians.cwiseAbs().maxCoeff(), bounded.floor_tilt_max_correction_radians);
  // Off, the attitude is the filter's own.
  OnlineEstimatorOptions off;
  off.floor_tilt_gain = 0.0;
  OnlineEstimator estimator(off);
  for (const Measurement& m : biased) ASSERT_TRUE(estimator.Add(m).ok());
  EXPECT_EQ(0, estimator.stats().floor_tilt_updates);
  EXPECT_EQ(Eigen::Vector2d::Zero(), estimator.stats().floor_tilt_radians);
}

// Bad data is returned as an error and leaves the estimator usable.
TEST(OnlineEstimatorStreamingTest, BadMeasurementsAreErrorsNotAborts) {
  const MeasurementLog log = HumanoidStream(3.0);
  OnlineEstimator estimator{OnlineEstimatorOptions()};
  int scans = 0;
  for (const Measurement& m : log.measurements) {
    ASSERT_TRUE(estimator.Add(m).ok());
    scans += std::holds_alternative<LaserReading>(m);
    if (scans == 10) break;
  }
  MargSample nan_sample;
  nan_sample.stamp_seconds = 1e9;
  nan_sample.gyro_radps.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(estimator.Add(nan_sample).ok());
  VelocityCommand no_stamp;
  no_stamp.stamp_seconds = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(estimator.Add(no_stamp).ok());
  LaserReading ancient;  // far older than the EKF's history
  ancient.scan.stamp_seconds = -100.0;
  ancient.scan.angles_radians = {0.0};
  ancient.scan.ranges_meters = {1.0};
  EXPECT_FALSE(estimator.Add(ancient).ok());
  EXPECT_EQ(1, estimator.stats().scans_refused);
  const int nodes = static_cast<int>(estimator.Trajectory().size());
  EXPECT_EQ(10, nodes);
  Pose2 pose;
  EXPECT_TRUE(estimator.PoseAt(estimator.Trajectory().back().stamp_seconds, &pose).ok());
  EXPECT_LT((pose.translation() - estimator.Trajectory().back().pose.translation()).norm(), 0.005);  // EKF vs match
  // Constant-rate output: one pose every 10 ms up to the newest stamp, ending near the last node.
  const std::vector<StampedPose2> rate = estimator.AdvanceTo(estimator.Trajectory().back().stamp_seconds);
  ASSERT_GT(rate.size(), 50u);
  EXPECT_NEAR(0.01, rate[1].stamp_seconds - rate[0].stamp_seconds, 1e-9);
  EXPECT_LT((rate.back().pose.translation() - estimator.Trajectory().back().pose.translation()).norm(), 0.02);
  // A MARG stream that stops for 2 s and comes back: the filter restarts, later samples are used.
  double last_marg = 0.0;
  for (const Measurement& m : log.measurements) {
    if (const auto* s = std::get_if<MargSample>(&m)) last_marg = std::max(last_marg, s->stamp_seconds);
  }
  MargSample resumed;
  resumed.stamp_seconds = last_marg + 2.0;
  resumed.accel_mps2 = Eigen::Vector3d(0, 0, 9.81);
  resumed.magnetometer = Eigen::Vector3d(20, 0, -40);
  EXPECT_TRUE(estimator.Add(resumed).ok());
  EXPECT_EQ(1, estimator.stats().marg_restarts);
  resumed.stamp_seconds += 0.01;
  EXPECT_TRUE(estimator.Add(resumed).ok());
  EXPECT_FALSE(estimator.Add(resumed).ok());  // the same stamp again: refused
  estimator.Finish();
  EXPECT_FALSE(estimator.Add(log.measurements.back()).ok());  // after Finish
}

}  // namespace
}  // namespace hetslam
