#include "datasets/sim/simulator.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "core/carmen_log.h"
#include "core/trajectory_io.h"
#include "glog/logging.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

using ::testing::HasSubstr;

constexpr double kDeg = M_PI / 180.0;

std::string OfficeLoopPath() {
  return std::string(HETSLAM_SOURCE_DIR) + "/datasets/scenarios/office_loop.scenario";
}

Scenario OfficeLoop() {
  Scenario scenario;
  const Status status = ReadScenarioFile(OfficeLoopPath(), &scenario);
  CHECK(status.ok()) << status.message();
  return scenario;
}

// The office loop simulated once with seed 42, shared by the tests that only inspect a run.
const SimulationResult& OfficeLoopSeed42() {
  static const SimulationResult* const result = [] {
    auto* r = new SimulationResult;
    std::mt19937_64 rng(42);
    const Status status = Simulate(OfficeLoop(), SimulatorOptions(), &rng, r);
    CHECK(status.ok()) << status.message();
    return r;
  }();
  return *result;
}

World SquareRoom() {
  World world;
  world.AddBox(Eigen::Vector2d::Zero(), Eigen::Vector2d(4.0, 4.0), 0.0);
  return world;
}

LaserOptions NoiseFreeLaser() {
  LaserOptions laser;
  laser.field_of_view_radians = M_PI;
  laser.num_beams = 361;
  laser.max_range_meters = 30.0;
  laser.range_noise_std_meters = 0.0;
  laser.dropout_probability = 0.0;
  return laser;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << file.rdbuf();
  return bytes.str();
}

// A fresh, empty folder under the test temp dir.
std::string FreshDir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

TEST(SimulateScanTest, SquareRoomRangesFromTheCentre) {
  const World world = SquareRoom();
  const LaserOptions laser = NoiseFreeLaser();
  std::mt19937_64 rng(1);
  const LaserScan scan = SimulateScan(world, laser, Pose2::Identity(), 12.5, &rng);
  ASSERT_EQ(scan.ranges_meters.size(), 361u);
  EXPECT_EQ(scan.stamp_seconds, 12.5);
  EXPECT_EQ(scan.range_max_meters, 30.0);
  EXPECT_NEAR(scan.angles_radians[180], 0.0, 1e-12);
  EXPECT_NEAR(scan.ranges_meters[180], 2.0, 1e-12);                     // straight ahead
  EXPECT_NEAR(scan.ranges_meters[270], 2.0 * std::sqrt(2.0), 1e-12);    // +45°: the corner
  EXPECT_NEAR(scan.ranges_meters[90], 2.0 * std::sqrt(2.0), 1e-12);     // -45°
  EXPECT_NEAR(scan.ranges_meters[0], 2.0, 1e-12);                       // -90°
  EXPECT_NEAR(scan.ranges_meters[360], 2.0, 1e-12);                     // +90°
  // Every beam: distance to the square's boundary, 2 / max(|cos a|, |sin a|).
  for (size_t i = 0; i < scan.ranges_meters.size(); ++i) {
    const double a = scan.angles_radians[i];
    EXPECT_NEAR(scan.ranges_meters[i], 2.0 / std::max(std::abs(std::cos(a)), std::abs(std::sin(a))),
                1e-9)
        << "beam " << i;
  }
}

TEST(SimulateScanTest, BeamsTurnWithTheRobot) {
  const World world = SquareRoom();
  std::mt19937_64 rng(1);
  // Facing 30°, 0.5 m east of the centre: the beam at -30° points along world +x.
  const LaserScan scan =
      SimulateScan(world, NoiseFreeLaser(), Pose2(0.5, 0.0, 30.0 * kDeg), 0.0, &rng);
  EXPECT_NEAR(scan.angles_radians[120], -30.0 * kDeg, 1e-12);
  EXPECT_NEAR(scan.ranges_meters[120], 1.5, 1e-12);
  // The beam at +60° points along world +y.
  EXPECT_NEAR(scan.ranges_meters[300], 2.0, 1e-12);
}

TEST(SimulateScanTest, NothingInRangeIsNoReturnWrittenAsMaxRange) {
  const World world = SquareRoom();
  LaserOptions laser = NoiseFreeLaser();
  laser.max_range_meters = 2.5;  // only beams within ±36.87° of an axis reach a wall
  std::mt19937_64 rng(1);
  int no_return = 0;
  const LaserScan scan = SimulateScan(world, laser, Pose2::Identity(), 0.0, &rng, &no_return);
  EXPECT_EQ(scan.ranges_meters[270], 2.5);  // corner at 2.83 m
  EXPECT_FALSE(scan.IsValidRange(scan.ranges_meters[270]));
  EXPECT_NEAR(scan.ranges_meters[180], 2.0, 1e-12);
  int expected = 0;
  for (double a : scan.angles_radians) {
    expected += 2.0 / std::max(std::abs(std::cos(a)), std::abs(std::sin(a))) > 2.5 ? 1 : 0;
  }
  EXPECT_EQ(no_return, expected);
  EXPECT_EQ(scan.NumValidBeams(), 361 - expected);
}

TEST(SimulateScanTest, NoiseAndDropoutsHaveTheConfiguredStatistics) {
  const World world = SquareRoom();
  LaserOptions laser = NoiseFreeLaser();
  laser.range_noise_std_meters = 0.05;
  laser.dropout_probability = 0.1;
  std::mt19937_64 rng(123);
  const LaserScan exact = SimulateScan(world, NoiseFreeLaser(), Pose2::Identity(), 0.0, &rng);
  double sum = 0.0, sum2 = 0.0;
  int returned = 0, dropped = 0;
  constexpr int kScans = 100;
  for (int k = 0; k < kScans; ++k) {
    const LaserScan scan = SimulateScan(world, laser, Pose2::Identity(), 0.0, &rng);
    for (size_t i = 0; i < scan.ranges_meters.size(); ++i) {
      if (!scan.IsValidRange(scan.ranges_meters[i])) {
        EXPECT_EQ(scan.ranges_meters[i], laser.max_range_meters);
        ++dropped;
        continue;
      }
      const double error = scan.ranges_meters[i] - exact.ranges_meters[i];
      sum += error;
      sum2 += error * error;
      ++returned;
    }
  }
  const int total = kScans * 361;
  // 36100 beams: the dropout fraction's standard error is 0.0016, the mean's 0.0003 m.
  EXPECT_NEAR(static_cast<double>(dropped) / total, 0.1, 0.01);
  const double mean = sum / returned;
  EXPECT_NEAR(mean, 0.0, 0.002);
  EXPECT_NEAR(std::sqrt(sum2 / returned - mean * mean), 0.05, 0.002);
}

TEST(SimulateScanTest, ScansReadBackWithTheSameGeometryThroughCarmenLogs) {
  // Both the default FLASER geometry (180°, 361 beams) and a 360° fan round-trip.
  for (const auto& [fov_degrees, beams] : {std::pair<double, int>{180.0, 361},
                                           std::pair<double, int>{180.0, 360},
                                           std::pair<double, int>{360.0, 720}}) {
    LaserOptions laser = NoiseFreeLaser();
    laser.field_of_view_radians = fov_degrees * kDeg;
    laser.num_beams = beams;
    laser.max_range_meters = 2.2;  // beams towards the room's corners give no return
    std::mt19937_64 rng(5);
    CarmenLog log;
    LaserReading reading;
    reading.scan = SimulateScan(SquareRoom(), laser, Pose2(0.2, -0.1, 0.3), 7.25, &rng);
    reading.odometry_pose = Pose2(1.0, 2.0, 0.5);
    reading.has_odometry_pose = true;
    log.lasers.push_back(reading);
    const std::string path = FreshDir("roundtrip") + "/scan.clf";
    Status status = WriteCarmenLog(path, log, {"round trip"});
    ASSERT_TRUE(status.ok()) << status.message();
    CarmenLog read;
    status = ReadCarmenLog(path, CarmenReadOptions(), &read);
    ASSERT_TRUE(status.ok()) << status.message();
    ASSERT_EQ(read.lasers.size(), 1u);
    const LaserScan& in = read.lasers[0].scan;
    const LaserScan& out = reading.scan;
    ASSERT_EQ(in.angles_radians.size(), out.angles_radians.size());
    EXPECT_EQ(in.range_max_meters, laser.max_range_meters);
    EXPECT_NEAR(in.stamp_seconds, 7.25, 1e-9);
    int invalid = 0;
    for (size_t i = 0; i < out.angles_radians.size(); ++i) {
      EXPECT_NEAR(in.angles_radians[i], out.angles_radians[i], 1e-9) << fov_degrees << "° beam " << i;
      EXPECT_EQ(in.IsValidRange(in.ranges_meters[i]), out.IsValidRange(out.ranges_meters[i]));
      if (out.IsValidRange(out.ranges_meters[i])) {
        EXPECT_NEAR(in.ranges_meters[i], out.ranges_meters[i], 1e-6);
      } else {
        ++invalid;
      }
    }
    EXPECT_GT(invalid, 0);  // the no-return encoding was exercised
  }
}

TEST(SimulateTest, OfficeLoopReachesItsWaypointsAndClosesTheLoop) {
  const Scenario scenario = OfficeLoop();
  const SimulationResult& result = OfficeLoopSeed42();
  EXPECT_TRUE(result.completed);
  EXPECT_EQ(result.waypoints_reached, static_cast<int>(scenario.waypoints.size()));
  const Pose2 start = result.truth.front().pose;
  const Pose2 end = result.truth.back().pose;
  EXPECT_LT((end.translation() - scenario.waypoints.back()).norm(),
            SimulatorOptions().goal_reached_radius_meters + 0.01);
  EXPECT_LT((end.translation() - start.translation()).norm(), 1.0);  // a closed loop
  // ~150-300 s of data at ~0.5 m/s, one scan per 0.1 s.
  EXPECT_GE(result.duration_seconds, 150.0);
  EXPECT_LE(result.duration_seconds, 300.0);
  EXPECT_EQ(result.num_scans, static_cast<int>(std::lround(result.duration_seconds * 10.0)) + 1);
  // The driven path is at least the sum of the straight legs (minus corner cutting).
  double legs = 0.0;
  Eigen::Vector2d from = scenario.InitialPose().translation();
  for (const Eigen::Vector2d& to : scenario.waypoints) {
    legs += (to - from).norm();
    from = to;
  }
  EXPECT_GT(result.path_length_meters, 0.95 * legs);
  EXPECT_LT(result.path_length_meters, 1.10 * legs);
  // The robot never drives through or scrapes a wall.
  for (size_t i = 1; i < result.truth_dense.size(); ++i) {
    const Eigen::Vector2d& p = result.truth_dense[i - 1].pose.translation();
    const Eigen::Vector2d& q = result.truth_dense[i].pose.translation();
    ASSERT_FALSE(scenario.world.SegmentHitsWall(p, q)) << "at t=" << result.truth_dense[i].stamp_seconds;
    ASSERT_GT(scenario.world.DistanceToNearestWall(q), 0.3) << "at t=" << result.truth_dense[i].stamp_seconds;
  }
}

TEST(SimulateTest, TruthStampsAreTheScanStampsAndCommandsRespectLimits) {
  const Scenario scenario = OfficeLoop();
  const SimulationResult& result = OfficeLoopSeed42();
  ASSERT_EQ(result.truth.size(), result.log.lasers.size());
  for (size_t i = 0; i < result.truth.size(); ++i) {
    ASSERT_EQ(result.truth[i].stamp_seconds, result.log.lasers[i].scan.stamp_seconds);
    ASSERT_NEAR(result.truth[i].stamp_seconds, 0.1 * i, 1e-9);
  }
  // Odometry at the odometry rate, over the same span.
  EXPECT_NEAR(static_cast<double>(result.log.odometry.size()),
              result.duration_seconds * scenario.odometry.rate_hz, 2.0);
  double slow_turning_speed = 0.0;
  int turning = 0;
  for (const StampedCommand& c : result.commands) {
    ASSERT_GE(c.forward_velocity_mps, 0.0);
    ASSERT_LE(c.forward_velocity_mps, scenario.robot.max_speed_mps + 1e-12);
    ASSERT_LE(std::abs(c.yaw_rate_radps), scenario.robot.max_turn_rate_radps + 1e-12);
    if (std::abs(c.yaw_rate_radps) > 0.5 * scenario.robot.max_turn_rate_radps) {
      slow_turning_speed += c.forward_velocity_mps;
      ++turning;
    }
  }
  // It slows down in turns.
  ASSERT_GT(turning, 0);
  EXPECT_LT(slow_turning_speed / turning, 0.6 * scenario.robot.max_speed_mps);
  // Commands change smoothly (acceleration limits), except for the final stop, where a
  // command below the stopped speed is zeroed.
  const SimulatorOptions options;
  ASSERT_EQ(result.commands.back().forward_velocity_mps, 0.0);
  ASSERT_EQ(result.commands.back().yaw_rate_radps, 0.0);
  for (size_t i = 1; i + 1 < result.commands.size(); ++i) {
    const double dt = result.commands[i].stamp_seconds - result.commands[i - 1].stamp_seconds;
    ASSERT_LE(std::abs(result.commands[i].forward_velocity_mps -
                       result.commands[i - 1].forward_velocity_mps),
              options.max_acceleration_mps2 * dt + 1e-9);
    ASSERT_LE(std::abs(result.commands[i].yaw_rate_radps - result.commands[i - 1].yaw_rate_radps),
              options.max_yaw_acceleration_radps2 * dt + 1e-9);
  }
}

TEST(SimulateTest, OdometryDriftsButStaysPlausible) {
  const Scenario scenario = OfficeLoop();
  for (uint64_t seed : {42u, 1u, 2u}) {
    SimulationResult run;
    if (seed != 42u) {
      std::mt19937_64 rng(seed);
      ASSERT_TRUE(Simulate(scenario, SimulatorOptions(), &rng, &run).ok());
    }
    const SimulationResult& result = seed == 42u ? OfficeLoopSeed42() : run;
    const LaserReading& first = result.log.lasers.front();
    EXPECT_NEAR((first.odometry_pose.translation() - result.truth.front().pose.translation()).norm(),
                0.0, 1e-12);
    const Pose2 truth_end = result.truth.back().pose;
    const Pose2 odom_end = result.log.lasers.back().odometry_pose;
    const double position_error = (odom_end.translation() - truth_end.translation()).norm();
    EXPECT_GT(position_error, 0.05) << "seed " << seed << ": odometry does not drift";
    EXPECT_LT(position_error, 0.1 * result.path_length_meters) << "seed " << seed;
    EXPECT_LT(std::abs(WrapAngle(odom_end.theta() - truth_end.theta())), 20.0 * kDeg);
    // Locally accurate: scan-to-scan odometry increments are close to the true ones.
    for (size_t i = 1; i < result.truth.size(); ++i) {
      const Pose2 true_step = Between(result.truth[i - 1].pose, result.truth[i].pose);
      const Pose2 odom_step = Between(result.log.lasers[i - 1].odometry_pose,
                                      result.log.lasers[i].odometry_pose);
      ASSERT_LT((true_step.translation() - odom_step.translation()).norm(), 0.03);
      ASSERT_LT(std::abs(WrapAngle(true_step.theta() - odom_step.theta())), 2.0 * kDeg);
    }
  }
}

TEST(SimulateTest, NoiseFreeOdometryEqualsTruth) {
  Scenario scenario = OfficeLoop();
  scenario.odometry.trans_noise_meters_per_sqrt_meter = 0.0;
  scenario.odometry.rot_noise_radians_per_sqrt_meter = 0.0;
  scenario.odometry.rot_noise_radians_per_sqrt_radian = 0.0;
  std::mt19937_64 rng(9);
  SimulationResult result;
  ASSERT_TRUE(Simulate(scenario, SimulatorOptions(), &rng, &result).ok());
  for (size_t i = 0; i < result.truth.size(); ++i) {
    const Pose2& odom = result.log.lasers[i].odometry_pose;
    ASSERT_NEAR((odom.translation() - result.truth[i].pose.translation()).norm(), 0.0, 1e-9);
    ASSERT_NEAR(WrapAngle(odom.theta() - result.truth[i].pose.theta()), 0.0, 1e-9);
  }
}

TEST(SimulateTest, SameSeedSameBytesDifferentSeedDifferentBytes) {
  const Scenario scenario = OfficeLoop();
  auto run = [&](uint64_t seed, const std::string& name) {
    std::mt19937_64 rng(seed);
    SimulationResult result;
    Status status = Simulate(scenario, SimulatorOptions(), &rng, &result);
    CHECK(status.ok()) << status.message();
    SimulationFiles files;
    status = WriteSimulationOutputs(FreshDir(name), scenario, result, {"seed"}, &files);
    CHECK(status.ok()) << status.message();
    return files;
  };
  const SimulationFiles a = run(11, "det_a");
  const SimulationFiles b = run(11, "det_b");
  const SimulationFiles c = run(12, "det_c");
  const std::string log_a = ReadBytes(a.log_path);
  ASSERT_GT(log_a.size(), 1000000u);
  EXPECT_TRUE(log_a == ReadBytes(b.log_path)) << "same seed, different log bytes";
  EXPECT_TRUE(ReadBytes(a.truth_path) == ReadBytes(b.truth_path));
  EXPECT_TRUE(ReadBytes(a.commands_path) == ReadBytes(b.commands_path));
  EXPECT_TRUE(ReadBytes(a.image_path) == ReadBytes(b.image_path));
  EXPECT_FALSE(log_a == ReadBytes(c.log_path)) << "different seeds, same log bytes";
}

TEST(SimulateTest, WrittenFilesReadBackConsistently) {
  const Scenario scenario = OfficeLoop();
  const SimulationResult& result = OfficeLoopSeed42();
  SimulationFiles files;
  Status status = WriteSimulationOutputs(FreshDir("readback"), scenario, result, {}, &files);
  ASSERT_TRUE(status.ok()) << status.message();
  CarmenLog log;
  status = ReadCarmenLog(files.log_path, CarmenReadOptions(), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  std::vector<StampedPose2> truth;
  status = ReadTrajectory(files.truth_path, &truth);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(log.lasers.size(), truth.size());
  EXPECT_EQ(log.odometry.size(), result.log.odometry.size());
  EXPECT_EQ(log.stats.laser_timestamps_backwards, 0);
  int valid = 0, total = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    ASSERT_NEAR(log.lasers[i].scan.stamp_seconds, truth[i].stamp_seconds, 1e-6);
    ASSERT_NEAR((truth[i].pose.translation() - result.truth[i].pose.translation()).norm(), 0.0,
                1e-8);
    valid += log.lasers[i].scan.NumValidBeams();
    total += static_cast<int>(log.lasers[i].scan.ranges_meters.size());
  }
  // Exactly the simulator's no-return beams are invalid after reading with default options.
  EXPECT_EQ(total - valid, result.num_no_return_beams);
  EXPECT_GT(std::filesystem::file_size(files.image_path), 1000u);
}

TEST(SimulateTest, DurationLimitStopsAnUnfinishedRoute) {
  Scenario scenario = OfficeLoop();
  scenario.duration_limit_seconds = 20.0;
  std::mt19937_64 rng(1);
  SimulationResult result;
  ASSERT_TRUE(Simulate(scenario, SimulatorOptions(), &rng, &result).ok());
  EXPECT_FALSE(result.completed);
  EXPECT_LT(result.waypoints_reached, static_cast<int>(scenario.waypoints.size()));
  EXPECT_NEAR(result.truth.back().stamp_seconds, 20.0, 1e-9);
  EXPECT_EQ(result.num_scans, 201);
}

TEST(SimulateTest, InvalidInputsAreErrorsNotCrashes) {
  std::mt19937_64 rng(1);
  SimulationResult result;
  Scenario empty;
  Status status = Simulate(empty, SimulatorOptions(), &rng, &result);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("waypoint"));
  SimulatorOptions options;
  options.control_rate_hz = 0.0;
  status = Simulate(OfficeLoop(), options, &rng, &result);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("control rate"));
  options = SimulatorOptions();
  options.goal_reached_radius_meters = 2.0 * options.waypoint_reached_radius_meters;
  EXPECT_FALSE(Simulate(OfficeLoop(), options, &rng, &result).ok());
  // Writing into a folder that does not exist names the file.
  SimulationFiles files;
  std::mt19937_64 rng2(1);
  Scenario short_run = OfficeLoop();
  short_run.duration_limit_seconds = 1.0;
  ASSERT_TRUE(Simulate(short_run, SimulatorOptions(), &rng2, &result).ok());
  status = WriteSimulationOutputs("/nonexistent/folder", short_run, result, {}, &files);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("/nonexistent/folder/log.clf"));
}

}  // namespace
}  // namespace sim
}  // namespace hetslam
