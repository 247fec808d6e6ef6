// The team simulator: 3D laser geometry through the full sensor path, motion models (UAV tilt,
// humanoid head), MARG at rest, the shipped scenarios, tag sharing, determinism.
#include "datasets/sim/team_simulator.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/robot_log.h"
#include "core/team_manifest.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::string ScenarioPath(const std::string& name) {
  return std::string(HETSLAM_SOURCE_DIR) + "/datasets/scenarios/" + name + ".scenario";
}

Scenario Parse(const std::string& text) {
  Scenario scenario;
  const Status status = ParseScenario(text, "test.scenario", &scenario);
  EXPECT_TRUE(status.ok()) << status.message();
  return scenario;
}

TeamSimulationResult RunTeam(const Scenario& scenario, uint64_t seed, double max_duration = 0.0) {
  TeamSimulatorOptions options;
  options.max_duration_seconds = max_duration;
  std::mt19937_64 rng(seed);
  TeamSimulationResult result;
  const Status status = SimulateTeam(scenario, options, &rng, &result);
  EXPECT_TRUE(status.ok()) << status.message();
  return result;
}

LaserOptions NoiseFreeLaser() {
  LaserOptions laser;
  laser.field_of_view_radians = 240.0 * kDeg;
  laser.num_beams = 667;
  laser.max_range_meters = 5.6;
  laser.range_noise_std_meters = 0.0;
  laser.dropout_probability = 0.0;
  return laser;
}

// A 6 m x 6 m room, laser at the centre.
World Room() {
  World world;
  world.AddBox(Eigen::Vector2d::Zero(), Eigen::Vector2d(6.0, 6.0), 0.0);
  world.SetHeights(2.6, 2.6);
  return world;
}

TEST(SimulateScan3DTest, CentreBeamHitsTheFloorWhereGeometrySays) {
  const World world = Room();
  const LaserOptions laser = NoiseFreeLaser();
  const int centre = laser.num_beams / 2;  // angle 0
  ASSERT_NEAR(laser.BeamAnglesRadians()[centre], 0.0, 1e-12);
  std::mt19937_64 rng(1);
  const double h = 0.5;
  for (double pitch_deg : {15.0, 25.0, 40.0}) {
    Eigen::Isometry3d world_T_laser = Eigen::Isometry3d::Identity();
    world_T_laser.translation() = Eigen::Vector3d(0.0, 0.0, h);
    world_T_laser.linear() = RotationFromRollPitchYaw(0.0, pitch_deg * kDeg, 0.0);
    std::vector<Surface> surfaces;
    const LaserScan scan = SimulateScan3D(world, laser, world_T_laser, 0.0, &rng, &surfaces);
    EXPECT_EQ(surfaces[centre], Surface::kFloor) << pitch_deg;
    const double range = scan.ranges_meters[centre];
    // Horizontal distance of the hit: h / tan(p).
    EXPECT_NEAR(range * std::cos(pitch_deg * kDeg), h / std::tan(pitch_deg * kDeg), 1e-9);
    // Side beams reach the floor farther away, or the wall: never closer than the centre.
    EXPECT_GE(scan.ranges_meters[centre / 2], range - 1e-9);
  }
  // 3° down: the floor would be 9.5 m ahead, the wall (3 m) comes first.
  Eigen::Isometry3d shallow = Eigen::Isometry3d::Identity();
  shallow.translation() = Eigen::Vector3d(0.0, 0.0, h);
  shallow.linear() = RotationFromRollPitchYaw(0.0, 3.0 * kDeg, 0.0);
  std::vector<Surface> surfaces;
  const LaserScan scan = SimulateScan3D(world, laser, shallow, 0.0, &rng, &surfaces);
  EXPECT_EQ(surfaces[centre], Surface::kWall);
  EXPECT_NEAR(scan.ranges_meters[centre], 3.0 / std::cos(3.0 * kDeg), 1e-9);
}

TEST(SimulateScan3DTest, NoReturnIsWrittenAsMaxRange) {
  World world;
  world.AddWall(Eigen::Vector2d(10.0, -1.0), Eigen::Vector2d(10.0, 1.0));
  LaserOptions laser = NoiseFreeLaser();
  std::mt19937_64 rng(2);
  Eigen::Isometry3d level = Eigen::Isometry3d::Identity();
  level.translation().z() = 0.3;
  std::vector<Surface> surfaces;
  int no_return = 0;
  const LaserScan scan = SimulateScan3D(world, laser, level, 0.0, &rng, &surfaces, &no_return);
  EXPECT_EQ(no_return, laser.num_beams);
  for (size_t i = 0; i < scan.ranges_meters.size(); ++i) {
    EXPECT_EQ(scan.ranges_meters[i], laser.max_range_meters);
    EXPECT_EQ(surfaces[i], Surface::kNone);
  }
}

TEST(TeamSimulatorTest, HumanoidHeadProfileReachesFortyDegreesAndSeesTheFloor) {
  Scenario scenario;
  ASSERT_TRUE(ReadScenarioFile(ScenarioPath("humanoid_static_tilt"), &scenario).ok());
  const TeamSimulationResult result = RunTeam(scenario, 3);
  ASSERT_EQ(result.robots.size(), 1u);
  const RobotSimulation& nao = result.robots[0];
  EXPECT_TRUE(nao.completed);
  EXPECT_NEAR(nao.path_length_meters, 0.0, 1e-12);  // stands still
  // A MOUNT at every scan; its pitch goes 0 -> 40° -> 0.
  ASSERT_EQ(nao.log.mounts.size(), nao.log.lasers.size());
  double max_pitch = 0.0;
  for (const StampedPose3& mount : nao.log.mounts) {
    const double pitch = RollPitchYawFromRotation(mount.pose.linear()).y();
    max_pitch = std::max(max_pitch, pitch);
  }
  EXPECT_NEAR(max_pitch, 40.0 * kDeg, 1e-9);
  EXPECT_NEAR(RollPitchYawFromRotation(nao.log.mounts.front().pose.linear()).y(), 0.0, 1e-12);
  EXPECT_NEAR(RollPitchYawFromRotation(nao.log.mounts.back().pose.linear()).y(), 0.0, 1e-12);
  // Level scans (laser 0.5 m up, 5.6 m range in a room whose walls are closer) never see the
  // floor: only tilted ones do. Recompute each scan's labels noise-free from its truth.
  const Eigen::Isometry3d world_T_body = nao.log.truth.front().pose;
  std::mt19937_64 rng(4);
  int tilted_with_floor = 0;
  for (size_t k = 0; k < nao.log.lasers.size(); ++k) {
    const Eigen::Isometry3d& body_T_laser = nao.log.mounts[k].pose;
    std::vector<Surface> surfaces;
    SimulateScan3D(result.world, NoiseFreeLaser(), world_T_body * body_T_laser, 0.0, &rng,
                   &surfaces);
    const int centre = static_cast<int>(surfaces.size()) / 2;
    const double pitch = RollPitchYawFromRotation(body_T_laser.linear()).y();
    const double height = (world_T_body * body_T_laser).translation().z();
    // Where the centre beam meets the floor, horizontally; the low box's face is 0.62 m ahead
    // of the laser (0.65 m ahead of the body).
    const double floor_ahead = pitch > 1e-9 ? height / std::tan(pitch) : 1e9;
    if (pitch < 1e-9) {
      for (Surface s : surfaces) EXPECT_NE(s, Surface::kFloor) << "level scan " << k;
    } else if (floor_ahead < 0.6) {
      EXPECT_EQ(surfaces[centre], Surface::kFloor) << "scan " << k << " pitch " << pitch;
      ++tilted_with_floor;
    }
  }
  EXPECT_GT(tilted_with_floor, 10);
  EXPECT_GT(nao.beams_by_surface.at(Surface::kFloor), 0);
  EXPECT_GT(nao.beams_by_surface.at(Surface::kObstacle), 0);
}

TEST(TeamSimulatorTest, UavTiltIsBoundedAndFollowsTheAcceleration) {
  Scenario scenario;
  ASSERT_TRUE(ReadScenarioFile(ScenarioPath("uav_flight"), &scenario).ok());
  const TeamSimulationResult result = RunTeam(scenario, 5, 40.0);
  const RobotSimulation& drone = result.robots[0];
  // Heading-frame acceleration vs pitch (forward) and roll (left) at the control rate.
  std::vector<double> pitch, a_forward, roll, a_left;
  double max_tilt = 0.0;
  for (const TruthSample& s : drone.truth) {
    const Eigen::Vector3d rpy = RollPitchYawFromRotation(s.rotation.toRotationMatrix());
    max_tilt = std::max({max_tilt, std::abs(rpy.x()), std::abs(rpy.y())});
    const double c = std::cos(rpy.z()), sn = std::sin(rpy.z());
    pitch.push_back(rpy.y());
    roll.push_back(rpy.x());
    a_forward.push_back(c * s.acceleration_world.x() + sn * s.acceleration_world.y());
    a_left.push_back(-sn * s.acceleration_world.x() + c * s.acceleration_world.y());
  }
  EXPECT_LE(max_tilt, 15.0 * kDeg + 1e-12);
  EXPECT_GT(max_tilt, 2.0 * kDeg);  // it does tilt
  auto correlation = [](const std::vector<double>& x, const std::vector<double>& y) {
    double mx = 0, my = 0;
    for (size_t i = 0; i < x.size(); ++i) mx += x[i], my += y[i];
    mx /= x.size();
    my /= y.size();
    double sxy = 0, sxx = 0, syy = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      sxy += (x[i] - mx) * (y[i] - my);
      sxx += (x[i] - mx) * (x[i] - mx);
      syy += (y[i] - my) * (y[i] - my);
    }
    return sxy / std::sqrt(sxx * syy);
  };
  // Nose down (positive pitch) to accelerate forward; right roll (negative) to go left.
  EXPECT_GT(correlation(pitch, a_forward), 0.8);
  EXPECT_LT(correlation(roll, a_left), -0.8);
  // Altitude held in [1, 2] m once cruising, and the altimeter agrees with the truth.
  for (const TruthSample& s : drone.truth) {
    EXPECT_GE(s.position.z(), 1.0);
    EXPECT_LE(s.position.z(), 2.0);
  }
  ASSERT_FALSE(drone.log.altitudes.empty());
  EXPECT_FALSE(drone.log.odometry.size() > 0);  // no wheels
}

constexpr char kStandingRobot[] =
    "box 0 0 8 8\n"
    "robot_begin r wheeled\n"
    "  start 0 0 30\n"
    "  stand 5\n"
    "robot_end\n";

TEST(TeamSimulatorTest, MargAtRestReadsGravityUpAndZeroRate) {
  const Scenario scenario = Parse(kStandingRobot);
  const MargOptions& marg = scenario.robots[0].marg;
  const TeamSimulationResult result = RunTeam(scenario, 6);
  const RobotLog& log = result.robots[0].log;
  ASSERT_EQ(log.marg.size(), 501u);  // 5 s at 100 Hz, both ends
  Eigen::Vector3d gyro_mean = Eigen::Vector3d::Zero(), accel_mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d mag_mean = Eigen::Vector3d::Zero();
  for (const MargSample& m : log.marg) {
    gyro_mean += m.gyro_radps / log.marg.size();
    accel_mean += m.accel_mps2 / log.marg.size();
    mag_mean += m.magnetometer / log.marg.size();
  }
  // Within noise: the mean of 501 samples is off by the bias (drawn once) and noise / sqrt(n).
  const double gyro_tolerance = 4.0 * marg.gyro_bias_radps + 4.0 * marg.gyro_noise_radps;
  EXPECT_LT(gyro_mean.norm(), gyro_tolerance);
  EXPECT_NEAR(accel_mean.z(), marg.gravity_mps2, 4.0 * marg.accel_bias_mps2 + 0.02);
  EXPECT_NEAR(accel_mean.head<2>().norm(), 0.0, 6.0 * marg.accel_bias_mps2 + 0.02);
  // The field seen from a body yawed by 30°: north (world x) lies at -30° in the body.
  EXPECT_NEAR(std::atan2(mag_mean.y(), mag_mean.x()), -30.0 * kDeg, 3.0 * kDeg);
  EXPECT_LT(mag_mean.z(), 0.0);  // pointing down
  // The attitude report: level, yaw 30°, within its offset and noise.
  for (const AttitudeReading& a : log.attitudes) {
    EXPECT_NEAR(a.roll_radians, 0.0, 5.0 * (marg.attitude_offset_radians + marg.attitude_noise_radians));
    EXPECT_NEAR(a.yaw_radians, 30.0 * kDeg, 5.0 * (marg.attitude_offset_radians + marg.attitude_noise_radians));
  }
}

TEST(TeamSimulatorTest, NoiseFreeMargMatchesTheMotion) {
  // A wheeled robot turning on the spot at 20°/s, then driving straight: noise-free gyro z is
  // the yaw rate, the accelerometer reads g plus the centripetal and forward accelerations.
  const Scenario scenario = Parse(
      "box 0 0 20 20\n"
      "robot_begin r wheeled\n"
      "  start 0 0 0\n"
      "  marg 100 0 0 0 0 0 0 0 0\n"
      "  command 4 0 0 20\n"
      "  command 4 0.3 0 0\n"
      "robot_end\n");
  const TeamSimulationResult result = RunTeam(scenario, 7);
  const RobotLog& log = result.robots[0].log;
  int checked = 0;
  for (const MargSample& m : log.marg) {
    if (m.stamp_seconds > 2.0 && m.stamp_seconds < 3.5) {  // turning steadily
      EXPECT_NEAR(m.gyro_radps.z(), 20.0 * kDeg, 1e-6);
      EXPECT_NEAR(m.gyro_radps.head<2>().norm(), 0.0, 1e-9);
      EXPECT_NEAR(m.accel_mps2.z(), 9.81, 1e-9);
      ++checked;
    }
    if (m.stamp_seconds > 6.0 && m.stamp_seconds < 7.5) {  // straight at 0.3 m/s
      EXPECT_NEAR(m.gyro_radps.norm(), 0.0, 1e-6);
      EXPECT_NEAR(m.accel_mps2.x(), 0.0, 1e-6);
      ++checked;
    }
  }
  EXPECT_GT(checked, 200);
  // Commands are logged at the control rate, body frame.
  ASSERT_FALSE(log.commands.empty());
  EXPECT_NEAR(log.commands[300].yaw_rate_radps, 20.0 * kDeg, 1e-9);
  // Odometry starts at the robot's own origin, not the world's.
  ASSERT_FALSE(log.odometry.empty());
  EXPECT_EQ(log.odometry.front().pose.translation(), Eigen::Vector2d::Zero());
}

TEST(TeamSimulatorTest, TeamThreeSharesTagsOnlyBetweenNeighbours) {
  Scenario scenario;
  ASSERT_TRUE(ReadScenarioFile(ScenarioPath("team_three"), &scenario).ok());
  const TeamSimulationResult result = RunTeam(scenario, 1);
  std::map<std::string, std::set<int>> seen;
  for (const RobotSimulation& robot : result.robots) {
    EXPECT_TRUE(robot.completed) << robot.name;
    for (const CameraFrame& frame : robot.frames) {
      for (int index : frame.visible_tags) seen[robot.name].insert(scenario.tags[index].id);
    }
  }
  EXPECT_EQ(seen["rover"], std::set<int>({1}));
  EXPECT_EQ(seen["nao"], std::set<int>({2}));
  EXPECT_TRUE(seen["drone"].count(1) && seen["drone"].count(2)) << "drone links both";
}

TEST(TeamSimulatorTest, TeamTwoSharesTagOne) {
  Scenario scenario;
  ASSERT_TRUE(ReadScenarioFile(ScenarioPath("team_two"), &scenario).ok());
  const TeamSimulationResult result = RunTeam(scenario, 1);
  std::map<std::string, std::set<int>> seen;
  for (const RobotSimulation& robot : result.robots) {
    EXPECT_TRUE(robot.completed) << robot.name;
    for (const CameraFrame& frame : robot.frames) {
      for (int index : frame.visible_tags) seen[robot.name].insert(scenario.tags[index].id);
    }
  }
  EXPECT_EQ(seen["nao"].count(1), 1u);
  EXPECT_EQ(seen["drone"].count(1), 1u);
  EXPECT_EQ(seen["drone"].count(2), 1u);
}

TEST(TeamSimulatorTest, RandomObstaclesKeepClearOfTheRouteAndFollowTheSeed) {
  Scenario scenario;
  ASSERT_TRUE(ReadScenarioFile(ScenarioPath("humanoid_explore"), &scenario).ok());
  const size_t fixed_prisms = scenario.world.prisms().size();
  std::mt19937_64 rng_a(11), rng_b(11), rng_c(12);
  World a = scenario.world, b = scenario.world, c = scenario.world;
  ASSERT_TRUE(PlaceRandomObstacles(scenario, &rng_a, &a).ok());
  ASSERT_TRUE(PlaceRandomObstacles(scenario, &rng_b, &b).ok());
  ASSERT_TRUE(PlaceRandomObstacles(scenario, &rng_c, &c).ok());
  ASSERT_EQ(a.prisms().size(), fixed_prisms + 8);
  EXPECT_EQ(a.prisms().back().footprint, b.prisms().back().footprint);
  EXPECT_NE(a.prisms().back().footprint, c.prisms().back().footprint);
  for (size_t i = fixed_prisms; i < a.prisms().size(); ++i) {
    EXPECT_EQ(a.prisms()[i].surface, Surface::kObstacle);
    EXPECT_LE(a.prisms()[i].z_max_meters, 0.25);
  }
  // Too many to fit: an error naming the line.
  Scenario crowded = Parse(
      "box 0 0 2 2\n"
      "random_obstacles 50 -1 -1 1 1 0.2\n"
      "robot_begin r wheeled\n  start 0 0 0\n  stand 1\nrobot_end\n");
  World world = crowded.world;
  std::mt19937_64 rng(1);
  const Status status = PlaceRandomObstacles(crowded, &rng, &world);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), ::testing::HasSubstr("test.scenario:2:"));
}

std::map<std::string, std::string> ReadTree(const std::string& root) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    files[std::filesystem::relative(entry.path(), root).string()] = bytes.str();
  }
  return files;
}

std::map<std::string, std::string> Generate(const Scenario& scenario, uint64_t seed,
                                            const std::string& dir) {
  std::filesystem::remove_all(dir);
  TeamSimulatorOptions options;
  options.max_duration_seconds = 2.0;
  std::mt19937_64 rng(seed);
  TeamSimulationResult result;
  Status status = SimulateTeam(scenario, options, &rng, &result);
  EXPECT_TRUE(status.ok()) << status.message();
  TeamDatasetFiles files;
  status = WriteTeamDataset(dir, scenario, result, options, {"seed " + std::to_string(seed)},
                            &files);
  EXPECT_TRUE(status.ok()) << status.message();
  EXPECT_GT(files.images_written, 0);
  return ReadTree(dir);
}

// The simulator has no collisions, so a route leg through a wall or furniture would make a log
// no robot could record: refused, naming the waypoint's line and what is in the way. A UAV
// flies over what is lower than it, a ground robot under a table's top (not through its legs).
TEST(TeamSimulatorTest, RoutesThroughWallsOrFurnitureAreRefused) {
  const std::string room =
      "box 5 5 10 10\n"                       // line 1: the room
      "wall 5 0 5 4\n"                        // line 2: a wall with a gap above y = 4
      "shelf 8 9.6 8 7.6 0.4 0.85 0.3 1.8\n"  // line 3
      "obstacle 2 7 0.4 0.4 0.3\n"            // line 4
      "table 2 2.5 1.2 0.8 0.74\n";           // line 5
  const auto check = [&](const std::string& robot) {
    const Scenario scenario = Parse(room + robot);
    return CheckRoutesClear(scenario, scenario.world);
  };
  // Through the wall below its gap (the waypoint is on line 8).
  Status status = check("robot_begin r wheeled\n  start 3 2 0\n  waypoint 7 2\nrobot_end\n");
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), ::testing::HasSubstr("test.scenario:8: robot 'r'"));
  EXPECT_THAT(status.message(), ::testing::HasSubstr("the wall of line 2"));
  // Around it, through the gap: clear.
  EXPECT_TRUE(check("robot_begin r wheeled\n  start 3 2 0\n  waypoint 4 5\n  waypoint 7 5\nrobot_end\n").ok());
  // The floor obstacle: in a ground robot's way, under a UAV at 1.4 m.
  status = check("robot_begin r humanoid\n  start 1 7 0\n  waypoint 3 7\nrobot_end\n");
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), ::testing::HasSubstr("furniture or obstacle of line 4"));
  EXPECT_TRUE(check("robot_begin d uav\n  start 1 7 0\n  altitude 1.4\n  waypoint 3 7\nrobot_end\n").ok());
  // The 1.8 m shelf: in a UAV's way at 1.4 m, not at 2.2 m (still under the 2.6 m walls).
  status = check("robot_begin d uav\n  start 6 8.6 0\n  altitude 1.4\n  waypoint 9 8.6\nrobot_end\n");
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), ::testing::HasSubstr("furniture or obstacle of line 3"));
  EXPECT_TRUE(check("robot_begin d uav\n  start 6 8.6 0\n  altitude 2.2\n  waypoint 7.5 8.6\nrobot_end\n").ok());
  // Under the table between its legs (its top is above a ground robot), but not through a leg.
  EXPECT_TRUE(check("robot_begin r wheeled\n  start 0.8 2.5 0\n  waypoint 3.2 2.5\nrobot_end\n").ok());
  status = check("robot_begin r wheeled\n  start 1.0 2.175 0\n  waypoint 3.0 2.175\nrobot_end\n");
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), ::testing::HasSubstr("furniture or obstacle of line 5"));
}

TEST(TeamSimulatorTest, SameSeedSameBytesForAWholeTeamDataset) {
  Scenario scenario;
  ASSERT_TRUE(ReadScenarioFile(ScenarioPath("team_two"), &scenario).ok());
  const std::string base = testing::TempDir() + "/team_sim_bytes";
  const auto first = Generate(scenario, 9, base + "_a");
  const auto second = Generate(scenario, 9, base + "_b");
  const auto other = Generate(scenario, 10, base + "_c");
  ASSERT_GT(first.size(), 10u);  // manifest, two logs, images, world.png
  EXPECT_TRUE(first.count("team.txt") && first.count("nao/log.txt") &&
              first.count("drone/log.txt") && first.count("world.png") &&
              first.count("nao/images/000000.png"));
  ASSERT_EQ(first.size(), second.size());
  for (const auto& [path, bytes] : first) {
    ASSERT_TRUE(second.count(path)) << path;
    EXPECT_TRUE(bytes == second.at(path)) << path << " differs between two runs, same seed";
  }
  EXPECT_NE(first.at("nao/log.txt"), other.at("nao/log.txt"));
}

TEST(TeamSimulatorTest, EveryShippedScenarioParsesGeneratesAndReadsBack) {
  for (const char* name : {"humanoid_static_tilt", "humanoid_explore", "uav_flight",
                           "wheeled_corridor", "team_two", "team_three", "team_overlap"}) {
    SCOPED_TRACE(name);
    Scenario scenario;
    const Status status = ReadScenarioFile(ScenarioPath(name), &scenario);
    ASSERT_TRUE(status.ok()) << status.message();
    ASSERT_TRUE(scenario.IsTeam());
    TeamSimulatorOptions options;
    options.max_duration_seconds = 3.0;
    options.render_images = false;
    std::mt19937_64 rng(1);
    TeamSimulationResult result;
    ASSERT_TRUE(SimulateTeam(scenario, options, &rng, &result).ok());
    const std::string dir = testing::TempDir() + "/team_sim_" + name;
    std::filesystem::remove_all(dir);
    TeamDatasetFiles files;
    ASSERT_TRUE(WriteTeamDataset(dir, scenario, result, options, {}, &files).ok());
    TeamManifest manifest;
    const Status read = ReadTeamManifest(files.manifest_path, &manifest);
    ASSERT_TRUE(read.ok()) << read.message();
    ASSERT_EQ(manifest.robots.size(), scenario.robots.size());
    EXPECT_EQ(manifest.tags.size(), scenario.tags.size());
    for (size_t r = 0; r < manifest.robots.size(); ++r) {
      RobotLog log;
      const Status log_status = ReadRobotLog(manifest.RobotLogPath(manifest.robots[r]),
                                             RobotLogReadOptions(), &log);
      ASSERT_TRUE(log_status.ok()) << log_status.message();
      const RobotLog& written = result.robots[r].log;
      EXPECT_EQ(log.lasers.size(), written.lasers.size());
      EXPECT_EQ(log.marg.size(), written.marg.size());
      EXPECT_EQ(log.images.size(), written.images.size());
      EXPECT_EQ(log.commands.size(), written.commands.size());
      EXPECT_GE(log.truth.size(), log.lasers.size());
      EXPECT_EQ(log.params.at("robot_kind"), manifest.robots[r].kind);
      // The UAVs' velocity lag, for the EKF's command model; the others follow their commands.
      EXPECT_EQ(log.params.count("command_response_seconds"), manifest.robots[r].kind == "uav" ? 1u : 0u);
      ASSERT_FALSE(log.lasers.empty());
      EXPECT_EQ(log.lasers[0].scan.ranges_meters.size(), 667u);
      if (!log.images.empty()) {
        CameraIntrinsics intrinsics;
        Eigen::Isometry3d laser_T_camera;
        const Status camera = log.CameraModel(&intrinsics, &laser_T_camera);
        ASSERT_TRUE(camera.ok()) << camera.message();
        EXPECT_TRUE(laser_T_camera.isApprox(scenario.robots[r].camera.laser_T_camera, 1e-12));
      }
      // The mount read back is the one each scan was taken with.
      EXPECT_TRUE(log.lasers.back().scan.robot_T_sensor.isApprox(
          written.lasers.back().scan.robot_T_sensor, 1e-12));
    }
  }
}

}  // namespace
}  // namespace sim
}  // namespace hetslam
