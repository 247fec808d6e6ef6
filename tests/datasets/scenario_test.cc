// The scenario parser: world, single-robot and team statements, errors naming file and line.
#include "datasets/sim/scenario.h"

#include <cmath>
#include <fstream>
#include <set>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

using ::testing::HasSubstr;

constexpr double kDeg = M_PI / 180.0;

TEST(ScenarioTest, ParsesEveryStatement) {
  const std::string text =
      "# a comment\n"
      "\n"
      "wall 0 0 10 0   # trailing comment\n"
      "box 5 5 2 1 90\n"
      "box 1 1 0.5 0.5\n"
      "waypoint 1 2\n"
      "waypoint 3 4\n"
      "start 0.5 0.5 90\n"
      "laser 270 541 25 0.02 0.01 20\n"
      "robot 0.8 60\n"
      "odometry 50 0.03 1.0 0.5\n"
      "duration_limit_s 99\n";
  Scenario scenario;
  const Status status = ParseScenario(text, "mini.scenario", &scenario);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(scenario.source_name, "mini.scenario");
  ASSERT_EQ(scenario.world.walls().size(), 9u);
  EXPECT_EQ(scenario.world.walls()[0].source_line, 3);
  EXPECT_EQ(scenario.world.walls()[1].source_line, 4);
  ASSERT_EQ(scenario.waypoints.size(), 2u);
  EXPECT_EQ(scenario.waypoints[1], Eigen::Vector2d(3.0, 4.0));
  ASSERT_TRUE(scenario.has_start_pose);
  EXPECT_NEAR(scenario.start_pose.theta(), M_PI / 2, 1e-12);
  EXPECT_EQ(scenario.FirstWaypointToReach(), 0);
  EXPECT_NEAR(scenario.laser.field_of_view_radians, 270.0 * kDeg, 1e-12);
  EXPECT_EQ(scenario.laser.num_beams, 541);
  EXPECT_EQ(scenario.laser.max_range_meters, 25.0);
  EXPECT_EQ(scenario.laser.range_noise_std_meters, 0.02);
  EXPECT_EQ(scenario.laser.dropout_probability, 0.01);
  EXPECT_EQ(scenario.laser.rate_hz, 20.0);
  EXPECT_EQ(scenario.robot.max_speed_mps, 0.8);
  EXPECT_NEAR(scenario.robot.max_turn_rate_radps, 60.0 * kDeg, 1e-12);
  EXPECT_EQ(scenario.odometry.rate_hz, 50.0);
  EXPECT_EQ(scenario.odometry.trans_noise_meters_per_sqrt_meter, 0.03);
  EXPECT_NEAR(scenario.odometry.rot_noise_radians_per_sqrt_meter, 1.0 * kDeg, 1e-12);
  // 0.5 deg/sqrt(deg): a 100° turn gets 5° of standard deviation.
  EXPECT_NEAR(scenario.odometry.rot_noise_radians_per_sqrt_radian * std::sqrt(100.0 * kDeg),
              5.0 * kDeg, 1e-12);
  EXPECT_EQ(scenario.duration_limit_seconds, 99.0);
}

TEST(ScenarioTest, DefaultStartIsFirstWaypointFacingTheSecond) {
  Scenario scenario;
  ASSERT_TRUE(ParseScenario("wall 0 0 1 0\nwaypoint 1 1\nwaypoint 1 3\n", "s", &scenario).ok());
  EXPECT_FALSE(scenario.has_start_pose);
  const Pose2 start = scenario.InitialPose();
  EXPECT_EQ(start.translation(), Eigen::Vector2d(1.0, 1.0));
  EXPECT_NEAR(start.theta(), M_PI / 2, 1e-12);
  EXPECT_EQ(scenario.FirstWaypointToReach(), 1);
  // Defaults for everything not given.
  EXPECT_EQ(scenario.laser.num_beams, LaserOptions().num_beams);
  EXPECT_EQ(scenario.robot.max_speed_mps, RobotOptions().max_speed_mps);
}

struct BadScenario {
  const char* text;
  const char* location;  // "file:line" expected at the start of the message
  const char* fragment;  // expected somewhere in the message
};

TEST(ScenarioTest, MalformedScenariosNameFileAndLine) {
  const BadScenario cases[] = {
      {"wall 0 0 1 0\nwaypoint 1 1\nteleport 3 4\n", "bad.scenario:3:", "unknown keyword 'teleport'"},
      {"wall 0 0 1\n", "bad.scenario:1:", "takes 4 numbers"},
      {"wall 0 0 1 0 5\n", "bad.scenario:1:", "takes 4 numbers"},
      {"# x\nwall 0 0 one 0\n", "bad.scenario:2:", "'one' is not a number"},
      {"wall 0 0 1e 0\n", "bad.scenario:1:", "is not a number"},
      {"wall 0 0 nan 0\n", "bad.scenario:1:", "not a finite number"},
      {"wall 0 0 inf 0\n", "bad.scenario:1:", "not a finite number"},
      {"wall 0 0 1e999 0\n", "bad.scenario:1:", "not a finite number"},
      {"wall 1 1 1 1\n", "bad.scenario:1:", "zero length"},
      {"box 0 0 -1 2\n", "bad.scenario:1:", "positive"},
      {"box 0 0 1 2 3 4\n", "bad.scenario:1:", "takes 4 or 5 numbers"},
      {"waypoint 1\n", "bad.scenario:1:", "takes 2 numbers"},
      {"\n\nlaser 180 360.5 30 0.01 0 10\n", "bad.scenario:3:", "integer"},
      {"laser 400 360 30 0.01 0 10\n", "bad.scenario:1:", "field of view"},
      {"laser 180 1 30 0.01 0 10\n", "bad.scenario:1:", "num_beams"},
      {"laser 180 360 30 0.01 1.0 10\n", "bad.scenario:1:", "dropout"},
      {"laser 180 360 30 0.01 0 0\n", "bad.scenario:1:", "rate"},
      {"laser 180 360 -3 0.01 0 10\n", "bad.scenario:1:", "max range"},
      {"laser 180 360 30 0.01 0 10\nlaser 180 360 30 0.01 0 10\n", "bad.scenario:2:",
       "given twice (first on line 1)"},
      {"robot 0 45\n", "bad.scenario:1:", "speed"},
      {"robot 0.5 -45\n", "bad.scenario:1:", "turn rate"},
      {"odometry 20 -0.1 0 0\n", "bad.scenario:1:", "translation noise"},
      {"odometry 20 0.1 0\n", "bad.scenario:1:", "takes 4 numbers"},
      {"duration_limit_s 0\n", "bad.scenario:1:", "positive"},
      {"start 0 0\n", "bad.scenario:1:", "takes 3 numbers"},
      // Issue #16: ranges that keep the world buildable and the run bounded.
      {"box 1e5 1e5 1e-9 1e-9\n", "bad.scenario:1:", "at least 1 mm"},
      {"obstacle 0 0 1e-9 1 1\n", "bad.scenario:1:", "at least 1 mm"},
      {"shelf 0 0 1 0 1e-9 0.5 0.3 1\n", "bad.scenario:1:", "shelf depths"},
      {"wall 0 0 2e6 0\n", "bad.scenario:1:", "beyond +-1e6"},
      {"duration_limit_s 1e300\n", "bad.scenario:1:", "beyond +-1e6"},
      {"duration_limit_s 100000\n", "bad.scenario:1:", "at most 86400 s"},
  };
  for (const BadScenario& c : cases) {
    Scenario scenario;
    const Status status = ParseScenario(c.text, "bad.scenario", &scenario);
    ASSERT_FALSE(status.ok()) << "accepted: " << c.text;
    EXPECT_EQ(status.message().rfind(c.location, 0), 0u)
        << "message '" << status.message() << "' should start with " << c.location;
    EXPECT_THAT(status.message(), HasSubstr(c.fragment)) << "for input: " << c.text;
  }
}

TEST(ScenarioTest, ScenarioLevelErrorsNameTheFile) {
  Scenario scenario;
  Status status = ParseScenario("wall 0 0 1 0\n", "nowaypoints.scenario", &scenario);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("nowaypoints.scenario: "));
  EXPECT_THAT(status.message(), HasSubstr("waypoint"));
  status = ParseScenario("waypoint 0 0\n", "nowalls.scenario", &scenario);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("nowalls.scenario: "));
  EXPECT_THAT(status.message(), HasSubstr("no walls"));
  status = ParseScenario("", "empty.scenario", &scenario);
  EXPECT_FALSE(status.ok());
}

TEST(ScenarioTest, BoundsOfTheWholeScenarioAreChecked) {
  Scenario scenario;
  Status status = ParseScenario("wall 0 0 2000 0\nwaypoint 1 1\n", "wide.scenario", &scenario);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("wide.scenario: the world spans 2000 x 0 m"));
  status = ParseScenario("wall 0 0 10 0\nwaypoint 1 1\nlaser 180 100000 30 0.01 0 1000\nduration_limit_s 86400\n",
                         "beams.scenario", &scenario);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("beams.scenario: the lasers would cast"));
}

TEST(ScenarioTest, ADirectoryIsRefusedByName) {
  Scenario scenario;
  const Status status = ReadScenarioFile(testing::TempDir(), &scenario);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("Is a directory"));
}

TEST(ScenarioTest, MissingFileIsAnErrorNamingThePath) {
  Scenario scenario;
  const Status status = ReadScenarioFile("/nonexistent/dir/x.scenario", &scenario);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("/nonexistent/dir/x.scenario"));
}

TEST(ScenarioTest, FileErrorsNameThePathAndLine) {
  const std::string path = testing::TempDir() + "/scenario_test_bad.scenario";
  {
    std::ofstream file(path);
    file << "wall 0 0 10 0\n# comment\nwaypoint 1 2\nrobot 0.5 fast\n";
  }
  Scenario scenario;
  const Status status = ReadScenarioFile(path, &scenario);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.message().rfind(path + ":4: ", 0), 0u) << status.message();
  EXPECT_THAT(status.message(), HasSubstr("'fast' is not a number"));
}

TEST(ScenarioTest, ShippedOfficeLoopIsAConsistentFloorPlan) {
  Scenario scenario;
  const Status status = ReadScenarioFile(
      std::string(HETSLAM_SOURCE_DIR) + "/datasets/scenarios/office_loop.scenario", &scenario);
  ASSERT_TRUE(status.ok()) << status.message();
  const Eigen::AlignedBox2d bounds = scenario.world.Bounds();
  EXPECT_NEAR(bounds.sizes().x(), 30.0, 1e-9);
  EXPECT_NEAR(bounds.sizes().y(), 20.0, 1e-9);
  EXPECT_GE(scenario.world.walls().size(), 60u);  // rooms, doors and clutter
  ASSERT_GE(scenario.waypoints.size(), 4u);
  // Every leg of the route is free of walls, with room to spare, and inside the building.
  Eigen::Vector2d from = scenario.InitialPose().translation();
  for (size_t i = scenario.FirstWaypointToReach(); i < scenario.waypoints.size(); ++i) {
    const Eigen::Vector2d to = scenario.waypoints[i];
    EXPECT_FALSE(scenario.world.SegmentHitsWall(from, to)) << "leg to waypoint " << i;
    for (double s = 0.0; s <= 1.0; s += 0.01) {
      EXPECT_GT(scenario.world.DistanceToNearestWall(from + s * (to - from)), 0.5)
          << "leg to waypoint " << i << " at s = " << s;
    }
    EXPECT_TRUE(bounds.contains(to));
    from = to;
  }
  // A loop: the route ends close to where it starts.
  EXPECT_LT((scenario.waypoints.back() - scenario.InitialPose().translation()).norm(), 1.0);
  // A laser the default FLASER reader geometry understands.
  EXPECT_NEAR(scenario.laser.field_of_view_radians, M_PI, 1e-12);
}

constexpr char kTeamScenario[] =
    "ceiling 2.4\n"
    "wall_height 2.2\n"
    "box 0 0 10 8\n"
    "table 2 2 1.2 0.8 0.75 90\n"
    "shelf -5 -2 -5 2 0.4 0.9 0.25 1.8\n"
    "obstacle 1 -1 0.3 0.3 0.2\n"
    "random_obstacles 5 -3 -3 3 3 0.3\n"
    "tag 7 0.16 5 0 1.2 180   # on the east wall, facing west\n"
    "robot_begin nao humanoid\n"
    "  start 0 0 90\n"
    "  head_level 2\n"
    "  head_move 3 40\n"
    "  head_sweep 10 0 40 4\n"
    "  stand 2\n"
    "  waypoint 0 2\n"
    "  command 3 0.1 0.05 10\n"
    "  camera 10 320 240 260 260 159.5 119.5\n"
    "robot_end\n"
    "robot_begin drone uav\n"
    "  altitude 1.5\n"
    "  waypoint -1 -1\n"
    "  waypoint 1 -1 1.8\n"
    "  marg 200 0.1 0.5 0.01 0.05 0.05 0.5 0.2 0.5\n"
    "  altimeter 50 0.02\n"
    "  laser 240 667 5.6 0.01 0.005 10\n"
    "  camera none\n"
    "robot_end\n"
    "robot_begin rover wheeled\n"
    "  waypoint 0 -3\n"
    "  waypoint 2 -3\n"
    "  odometry 20 0.02 0.5 0.2\n"
    "  laser_mount 0.1 0 0.3 0 0 0\n"
    "robot_end\n";

TEST(TeamScenarioTest, ParsesEveryTeamStatement) {
  Scenario scenario;
  const Status status = ParseScenario(kTeamScenario, "team.scenario", &scenario);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_TRUE(scenario.IsTeam());
  EXPECT_EQ(scenario.world.ceiling_height_meters(), 2.4);
  EXPECT_EQ(scenario.world.wall_height_meters(), 2.2);
  EXPECT_EQ(scenario.world.prisms().size(), 5u + 2u + 1u);  // table, shelf, obstacle
  ASSERT_EQ(scenario.random_obstacles.size(), 1u);
  EXPECT_EQ(scenario.random_obstacles[0].count, 5);
  ASSERT_EQ(scenario.tags.size(), 1u);
  EXPECT_EQ(scenario.tags[0].id, 7);
  // Tag 7 faces west: its z axis is -x, its y axis up.
  const Eigen::Isometry3d world_T_tag = scenario.tags[0].WorldTTag();
  EXPECT_TRUE(world_T_tag.linear().col(2).isApprox(-Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_TRUE(world_T_tag.linear().col(1).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  EXPECT_NEAR(world_T_tag.linear().determinant(), 1.0, 1e-12);

  ASSERT_EQ(scenario.robots.size(), 3u);
  const RobotSpec& nao = scenario.robots[0];
  EXPECT_EQ(nao.kind, RobotKind::kHumanoid);
  ASSERT_EQ(nao.head_profile.size(), 3u);
  ASSERT_EQ(nao.route.size(), 3u);
  EXPECT_EQ(nao.route[0].type, RouteStep::Type::kStand);
  EXPECT_EQ(nao.route[2].type, RouteStep::Type::kCommand);
  EXPECT_NEAR(nao.route[2].yaw_rate_radps, 10.0 * kDeg, 1e-12);
  EXPECT_EQ(nao.camera.width, 320);
  EXPECT_NEAR(nao.InitialPose().theta(), M_PI / 2, 1e-12);
  // Head profile: level, then moving to 40° over 3 s, then a 0..40° sweep with a 4 s period.
  EXPECT_NEAR(nao.HeadPitchRadians(1.0), 0.0, 1e-12);
  EXPECT_NEAR(nao.HeadPitchRadians(3.5), 20.0 * kDeg, 1e-12);
  EXPECT_NEAR(nao.HeadPitchRadians(5.0), 0.0, 1e-12);  // the sweep starts at its minimum
  EXPECT_NEAR(nao.HeadPitchRadians(7.0), 40.0 * kDeg, 1e-12);
  EXPECT_NEAR(nao.HeadPitchRadians(15.0 + 1.0), 0.0, 1e-12);  // repeats after 15 s
  // The head laser sits 0.5 m above the floor and pitches about the joint at 0.45 m.
  const Eigen::Isometry3d level = nao.BodyTLaser(0.0);
  EXPECT_NEAR(level.translation().z(), 0.5, 1e-12);
  const Eigen::Isometry3d down = nao.BodyTLaser(40.0 * kDeg);
  const Eigen::Vector3d beam = down.linear() * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(std::asin(-beam.z()), 40.0 * kDeg, 1e-12);
  EXPECT_LT(down.translation().z(), 0.5);

  const RobotSpec& drone = scenario.robots[1];
  EXPECT_EQ(drone.kind, RobotKind::kUav);
  EXPECT_FALSE(drone.camera.enabled);
  EXPECT_EQ(drone.marg.rate_hz, 200.0);
  EXPECT_EQ(drone.altimeter.rate_hz, 50.0);
  EXPECT_TRUE(std::isnan(drone.route[0].altitude_meters));
  EXPECT_EQ(drone.route[1].altitude_meters, 1.8);
  const RobotSpec& rover = scenario.robots[2];
  EXPECT_NEAR(rover.body_T_laser.translation().z(), 0.3, 1e-12);
  EXPECT_EQ(std::string(RobotKindName(rover.kind)), "wheeled");
}

TEST(TeamScenarioTest, TheMirroredScenarioIsTheWorldAndTheRoutesSeenInAMirror) {
  Scenario scenario;
  ASSERT_TRUE(ParseScenario(kTeamScenario, "team.scenario", &scenario).ok());
  const Scenario mirrored = MirroredScenario(scenario);
  EXPECT_EQ(mirrored.source_name, "team.scenario (mirrored)");
  // The walls span x in [-5, 5]: the mirror is x -> -x.
  const auto mirror = [](const Eigen::Vector3d& v) { return Eigen::Vector3d(-v.x(), v.y(), v.z()); };
  ASSERT_EQ(mirrored.world.walls().size(), scenario.world.walls().size());
  ASSERT_EQ(mirrored.world.prisms().size(), scenario.world.prisms().size());
  EXPECT_EQ(mirrored.world.ceiling_height_meters(), 2.4);
  EXPECT_EQ(mirrored.world.wall_height_meters(), 2.2);
  // Every ray sees in the mirrored world what its mirror image sees in the scenario's: walls,
  // the table (its legs and top), the shelf's two parts, the obstacle, floor and ceiling.
  int rays = 0;
  std::set<Surface> surfaces;
  for (double x = -4.0; x <= 4.0; x += 1.3) {
    for (double y = -3.5; y <= 3.5; y += 1.1) {
      for (double z : {0.1, 0.5, 0.8, 1.5}) {
        for (double yaw = 0.0; yaw < 2 * M_PI; yaw += 0.37) {
          for (double pitch : {-0.3, 0.0, 0.2}) {
            const Eigen::Vector3d origin(x, y, z);
            const Eigen::Vector3d direction(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                                            std::sin(pitch));
            const RayHit hit = scenario.world.CastRay3D(origin, direction, 20.0);
            const RayHit seen = mirrored.world.CastRay3D(mirror(origin), mirror(direction), 20.0);
            ASSERT_EQ(hit.hit, seen.hit) << origin.transpose() << " yaw " << yaw << " pitch " << pitch;
            if (!hit.hit) continue;
            EXPECT_NEAR(hit.range_meters, seen.range_meters, 1e-9) << origin.transpose() << " yaw " << yaw;
            EXPECT_EQ(hit.surface, seen.surface);
            EXPECT_EQ(hit.source_line, seen.source_line);
            surfaces.insert(hit.surface);
            ++rays;
          }
        }
      }
    }
  }
  EXPECT_GT(rays, 5000);
  EXPECT_EQ(surfaces, (std::set<Surface>{Surface::kFloor, Surface::kCeiling, Surface::kWall, Surface::kFurniture,
                                         Surface::kObstacle}));
  // Tag 7 moves to the west wall and faces east; it stays a right-handed (readable) tag.
  ASSERT_EQ(mirrored.tags.size(), 1u);
  EXPECT_TRUE(mirrored.tags[0].center.isApprox(Eigen::Vector3d(-5.0, 0.0, 1.2), 1e-12));
  const Eigen::Isometry3d world_T_tag = mirrored.tags[0].WorldTTag();
  EXPECT_TRUE(world_T_tag.linear().col(2).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_NEAR(world_T_tag.linear().determinant(), 1.0, 1e-12);
  // Routes: starts and waypoints mirrored, headings theta -> pi - theta, body-frame commands
  // turning and sliding the other way; altitudes, stands, sensors and head profiles as they were.
  const RobotSpec& nao = mirrored.robots[0];
  EXPECT_NEAR(nao.InitialPose().theta(), M_PI / 2, 1e-12);
  EXPECT_EQ(nao.route[1].target, Eigen::Vector2d(0.0, 2.0));
  EXPECT_EQ(nao.route[2].vx_mps, 0.1);
  EXPECT_EQ(nao.route[2].vy_mps, -0.05);
  EXPECT_NEAR(nao.route[2].yaw_rate_radps, -10.0 * kDeg, 1e-12);
  EXPECT_NEAR(nao.HeadPitchRadians(7.0), 40.0 * kDeg, 1e-12);
  const RobotSpec& drone = mirrored.robots[1];
  EXPECT_EQ(drone.route[0].target, Eigen::Vector2d(1.0, -1.0));
  EXPECT_EQ(drone.route[1].target, Eigen::Vector2d(-1.0, -1.0));
  EXPECT_EQ(drone.route[1].altitude_meters, 1.8);
  // Without a start the robot faces its second waypoint: west instead of east.
  EXPECT_NEAR(std::abs(drone.InitialPose().theta()), M_PI, 1e-12);
  EXPECT_NEAR(std::abs(mirrored.robots[2].InitialPose().theta()), M_PI, 1e-12);
  EXPECT_TRUE(mirrored.robots[2].body_T_laser.isApprox(scenario.robots[2].body_T_laser));
  ASSERT_EQ(mirrored.random_obstacles.size(), 1u);
  EXPECT_TRUE(mirrored.random_obstacles[0].region.isApprox(scenario.random_obstacles[0].region));
  // Twice mirrored is the scenario again.
  const Scenario twice = MirroredScenario(mirrored);
  for (size_t i = 0; i < scenario.world.walls().size(); ++i) {
    EXPECT_TRUE(twice.world.walls()[i].a.isApprox(scenario.world.walls()[i].a, 1e-12));
    EXPECT_TRUE(twice.world.walls()[i].b.isApprox(scenario.world.walls()[i].b, 1e-12));
  }
  EXPECT_TRUE(twice.tags[0].WorldTTag().isApprox(scenario.tags[0].WorldTTag(), 1e-12));
  EXPECT_NEAR(std::cos(twice.robots[2].InitialPose().theta()), std::cos(scenario.robots[2].InitialPose().theta()), 1e-12);
}

TEST(ScenarioTest, TheMirroredSingleRobotPathTurnsTheOtherWay) {
  Scenario scenario;
  ASSERT_TRUE(ParseScenario("wall 2 0 12 0\nwall 12 0 12 6\nwaypoint 3 1\nwaypoint 5 1\nstart 3 1 30\n",
                            "path.scenario", &scenario)
                  .ok());
  const Scenario mirrored = MirroredScenario(scenario);  // about x = 7
  EXPECT_EQ(mirrored.world.walls()[0].a, Eigen::Vector2d(12.0, 0.0));
  EXPECT_EQ(mirrored.world.walls()[1].b, Eigen::Vector2d(2.0, 6.0));
  EXPECT_EQ(mirrored.waypoints[1], Eigen::Vector2d(9.0, 1.0));
  EXPECT_EQ(mirrored.start_pose.translation(), Eigen::Vector2d(11.0, 1.0));
  EXPECT_NEAR(mirrored.start_pose.theta(), 150.0 * kDeg, 1e-12);
  std::string error;
  EXPECT_TRUE(mirrored.IsValid(&error)) << error;
}

struct BadCase {
  const char* text;
  const char* location;  // ":line:" expected right after the file name
  const char* fragment;  // expected somewhere in the message
};

TEST(TeamScenarioTest, ErrorsNameFileAndLine) {
  const std::string base = "box 0 0 10 8\n";  // line 1
  const BadCase cases[] = {
      {"table 0 0 0.1 0.5 0.7\n", ":2:", "table sides"},
      {"table 0 0 1 0.5\n", ":2:", "takes 5 or 6 numbers"},
      {"obstacle 0 0 1 1 -0.2\n", ":2:", "positive"},
      {"shelf 0 0 0 0 0.4 0.9 0.2 1.8\n", ":2:", "zero length"},
      {"shelf 0 0 1 0 0.4 0.9 0.2 0.5\n", ":2:", "height > lower_height"},
      {"random_obstacles 2.5 0 0 1 1 0.3\n", ":2:", "integer"},
      {"random_obstacles 2 1 0 0 1 0.3\n", ":2:", "x0 < x1"},
      {"tag 600 0.16 5 0 1 180\n", ":2:", "tag36h11"},
      {"tag 1 0.16 4 0 1 180\n", ":2:", "not on a wall"},
      {"tag 1 0.16 5 0 1 180\ntag 1 0.16 5 1 1 180\n", ":3:", "used twice (first on line 2)"},
      {"ceiling -1\n", ":2:", "ceiling"},
      {"ceiling 2\nceiling 3\n", ":3:", "given twice"},
      {"robot_begin a flyer\n", ":2:", "unknown robot kind 'flyer'"},
      {"robot_begin a/b uav\n", ":2:", "may only hold"},
      {"robot_begin a uav\nwaypoint 0 0\n", ":2:", "not closed"},
      {"robot_begin a uav\nwall 0 0 1 1\nrobot_end\n", ":3:", "inside robot block 'a'"},
      {"robot_end\n", ":2:", "without robot_begin"},
      {"robot_begin a wheeled\nwaypoint 0 0\nrobot_end\nrobot_begin a uav\n", ":5:",
       "used twice"},
      {"robot_begin a wheeled\nstand 1\nrobot_end\n", ":2:", "needs a 'start' line"},
      {"robot_begin a wheeled\nrobot_end\n", ":2:", "no waypoint"},
      {"robot_begin a wheeled\nstart 0 0 0\ncommand 1 0.1 0.1 0\nrobot_end\n", ":4:",
       "cannot move sideways"},
      {"robot_begin a humanoid\nspeed 0.3 30\n", ":3:", "at most 0.15"},
      {"robot_begin a humanoid\nhead_sweep 5 0 90 2\n", ":3:", "[-30, 60]"},
      {"robot_begin a uav\naltitude 1\naltitude 2\n", ":4:", "given twice (first on line 3)"},
      {"robot_begin a wheeled\naltitude 1\n", ":3:", "for uav robots"},
      {"robot_begin a uav\nhead_level 2\n", ":3:", "for humanoid robots"},
      {"robot_begin a uav\nwaypoint 0 0 20\n", ":3:", "altitude"},
      {"robot_begin a wheeled\nwaypoint 0 0 1\n", ":3:", "takes 2 numbers"},
      {"robot_begin a uav\nmarg 100 0.1\n", ":3:", "takes 9 numbers"},
      {"robot_begin a uav\ncamera 5 640 480 500 500 900 240\n", ":3:", "principal point"},
      {"robot_begin a uav\ncamera 5 640.5 480 500 500 300 240\n", ":3:", "integers"},
      {"robot_begin a uav\nteleport 1\n", ":3:", "unknown keyword 'teleport' inside robot block"},
      {"waypoint 1 1\nrobot_begin a uav\nwaypoint 0 0\nrobot_end\n", ":2:",
       "'waypoint' outside a robot block"},
  };
  for (const BadCase& c : cases) {
    Scenario scenario;
    const Status status = ParseScenario(base + c.text, "bad.scenario", &scenario);
    ASSERT_FALSE(status.ok()) << "accepted: " << c.text;
    EXPECT_EQ(status.message().rfind(std::string("bad.scenario") + c.location, 0), 0u)
        << "message '" << status.message() << "' should start with bad.scenario" << c.location;
    EXPECT_THAT(status.message(), HasSubstr(c.fragment)) << "for input: " << c.text;
  }
}

}  // namespace
}  // namespace sim
}  // namespace hetslam
