// The particle filter inside the online estimator (the ambiguity issue): on the shipped
// humanoid_explore scenario (the head faces the floor now and then, matching is suspended, the
// EKF carries the pose) with spawning on degenerate matches forced on, particles spawn and
// collapse, the trajectory always has one pose per scan (deferred scans at the best particle's
// pose), every scan becomes one node once the estimator finishes, and the same seed gives the
// same bytes. With one particle nothing spawns.

#include "core/measurement_log.h"
#include "core/trajectory_metrics.h"
#include "frontends/online_estimator.h"
#include "glog/logging.h"
#include "gtest/gtest.h"
#include "tests/frontends/sim_fixtures.h"

namespace hetslam {
namespace {

struct ParticleRun {
  std::vector<StampedPose2> trajectory;
  std::vector<OnlineEstimator::ParticleCount> counts;
  ParticleFilterStats particles;
  OnlineEstimatorStats stats;
  int nodes = 0;
  size_t map_bytes = 0;  // finished and active submaps at the end
  int scans_with_one_pose_each = 0;  // before Finish: Trajectory() had one pose per scan so far
  int scans_with_particles = 0;      // ... of which while several particles lived
  AbsoluteTrajectoryError ate;
};

const RobotLog& HumanoidLog() {
  static const RobotLog* log =
      new RobotLog(std::move(testing_sim::SimulateShippedScenario("humanoid_explore", 1).robots.front().log));
  return *log;
}

ParticleRun RunHumanoid(int max_particles, bool spawn_on_degenerate) {
  RobotLog log = HumanoidLog();
  const std::vector<StampedPose2> truth = testing_sim::PlanarTruth(log);
  OnlineEstimatorOptions options;
  options.particles.max_particles = max_particles;
  options.particles.spawn_on_degenerate = spawn_on_degenerate;
  OnlineEstimator estimator(options);
  const MeasurementLog stream = MeasurementLogFromRobotLog(std::move(log));
  ParticleRun run;
  for (const Measurement& m : stream.measurements) {
    const Status status = estimator.Add(m);
    EXPECT_TRUE(status.ok()) << status.message();
    if (std::holds_alternative<LaserReading>(m)) {
      const bool one_pose_each = estimator.Trajectory().size() == static_cast<size_t>(estimator.stats().scans);
      run.scans_with_one_pose_each += one_pose_each;
      run.scans_with_particles += one_pose_each && estimator.particle_filter().num_particles() > 1;
    }
  }
  estimator.Finish();
  run.trajectory = estimator.Trajectory();
  run.counts = estimator.particle_counts();
  run.particles = estimator.particle_filter().stats();
  run.stats = estimator.stats();
  run.nodes = estimator.graph().num_nodes(0);
  run.map_bytes = estimator.graph().FinishedSubmapBytes(0);
  run.map_bytes += estimator.stats().active_submap_bytes_at_finish;  // Finish() freed the active submaps
  EXPECT_TRUE(estimator.particle_filter().state().active.empty());
  run.ate = ComputeAbsoluteTrajectoryError(run.trajectory, truth);
  return run;
}

TEST(OnlineEstimatorParticlesTest, SpawnDeferCollapseAndOnePosePerScan) {
  const ParticleRun run = RunHumanoid(6, true);
  LOG(INFO) << "spawns " << run.particles.spawns << ", mean particles " << run.particles.mean_particles()
            << ", extra particle " << run.particles.max_extra_particle_bytes / 1048576.0 << " MiB, ATE "
            << run.ate.translation_rmse_meters << " m";
  EXPECT_GT(run.particles.spawns, 0);
  EXPECT_EQ(run.particles.spawns, run.particles.collapses);  // Finish collapses the last ones
  EXPECT_EQ(6, run.particles.max_particles);
  ASSERT_GT(run.counts.size(), 2u);
  EXPECT_EQ(1, run.counts.front().particles);
  for (size_t i = 1; i < run.counts.size(); ++i) {
    EXPECT_NE(run.counts[i - 1].particles, run.counts[i].particles);
    EXPECT_LT(run.counts[i - 1].stamp_seconds, run.counts[i].stamp_seconds);
  }
  // One pose per scan, deferred or not, midway and at the end; every inserted scan is a node
  // (the motion filter's are not).
  EXPECT_EQ(run.stats.scans, run.scans_with_one_pose_each);
  EXPECT_GT(run.scans_with_particles, 50);
  EXPECT_EQ(static_cast<size_t>(run.stats.scans), run.trajectory.size());
  EXPECT_EQ(run.stats.scans - run.stats.suspended_scans - run.stats.skipped_too_few_points - run.stats.filtered_scans,
            run.nodes);
  EXPECT_LT(run.ate.translation_rmse_meters, 0.05);
  // One extra particle: its deferred poses and matching subsets (it changes no cell while it
  // lives, and the scans' points are shared): measured 0.05 MiB of a 3.4 MiB map.
  EXPECT_GT(run.particles.max_extra_particle_bytes, 0u);
  EXPECT_LT(run.particles.max_extra_particle_bytes, run.map_bytes / 10);
}

TEST(OnlineEstimatorParticlesTest, SameSeedSameTrajectory) {
  const ParticleRun a = RunHumanoid(6, true);
  const ParticleRun b = RunHumanoid(6, true);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    ASSERT_EQ(a.trajectory[i].pose.x(), b.trajectory[i].pose.x()) << i;
    ASSERT_EQ(a.trajectory[i].pose.y(), b.trajectory[i].pose.y()) << i;
    ASSERT_EQ(a.trajectory[i].pose.theta(), b.trajectory[i].pose.theta()) << i;
  }
  EXPECT_EQ(a.particles.resamples, b.particles.resamples);
}

TEST(OnlineEstimatorParticlesTest, OneParticleNeverSpawns) {
  const ParticleRun run = RunHumanoid(1, true);
  EXPECT_EQ(0, run.particles.spawns);
  ASSERT_EQ(1u, run.counts.size());
  EXPECT_EQ(1, run.counts.front().particles);
  EXPECT_DOUBLE_EQ(1.0, run.particles.mean_particles());
}

}  // namespace
}  // namespace hetslam
