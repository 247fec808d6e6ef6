#include "datasets/sim/world.h"

#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

using ::testing::HasSubstr;

constexpr double kDeg = M_PI / 180.0;

// A 4 m x 4 m square room centred at the origin.
World SquareRoom() {
  World world;
  world.AddBox(Eigen::Vector2d::Zero(), Eigen::Vector2d(4.0, 4.0), 0.0);
  return world;
}

TEST(WorldTest, BoxHasFourWallsAroundItsCentre) {
  const World world = SquareRoom();
  ASSERT_EQ(world.walls().size(), 4u);
  const Eigen::AlignedBox2d bounds = world.Bounds();
  EXPECT_NEAR(bounds.min().x(), -2.0, 1e-12);
  EXPECT_NEAR(bounds.min().y(), -2.0, 1e-12);
  EXPECT_NEAR(bounds.max().x(), 2.0, 1e-12);
  EXPECT_NEAR(bounds.max().y(), 2.0, 1e-12);
}

TEST(WorldTest, RotatedBoxSwapsItsExtent) {
  World world;
  world.AddBox(Eigen::Vector2d(1.0, 2.0), Eigen::Vector2d(4.0, 1.0), 90.0 * kDeg);
  const Eigen::AlignedBox2d bounds = world.Bounds();
  EXPECT_NEAR(bounds.sizes().x(), 1.0, 1e-9);
  EXPECT_NEAR(bounds.sizes().y(), 4.0, 1e-9);
  EXPECT_NEAR(bounds.center().x(), 1.0, 1e-9);
  EXPECT_NEAR(bounds.center().y(), 2.0, 1e-9);
}

TEST(WorldTest, RayFromCentreOfSquareRoomMatchesHandComputedRanges) {
  const World world = SquareRoom();
  double range = 0.0;
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d::Zero(), 0.0, 30.0, &range));
  EXPECT_NEAR(range, 2.0, 1e-12);
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d::Zero(), 45.0 * kDeg, 30.0, &range));
  EXPECT_NEAR(range, 2.0 * std::sqrt(2.0), 1e-12);  // into the corner
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d::Zero(), M_PI / 2, 30.0, &range));
  EXPECT_NEAR(range, 2.0, 1e-12);
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d::Zero(), -135.0 * kDeg, 30.0, &range));
  EXPECT_NEAR(range, 2.0 * std::sqrt(2.0), 1e-12);
  // 30°: the wall x = 2 at distance 2 / cos(30°).
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d::Zero(), 30.0 * kDeg, 30.0, &range));
  EXPECT_NEAR(range, 2.0 / std::cos(30.0 * kDeg), 1e-12);
  // Off-centre origin: 0.5 m from the east wall.
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d(1.5, 0.3), 0.0, 30.0, &range));
  EXPECT_NEAR(range, 0.5, 1e-12);
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d(1.5, 0.3), M_PI, 30.0, &range));
  EXPECT_NEAR(range, 3.5, 1e-12);
}

TEST(WorldTest, RayBeyondMaxRangeOrAwayFromWallsMisses) {
  const World world = SquareRoom();
  double range = -1.0;
  EXPECT_FALSE(world.CastRay(Eigen::Vector2d::Zero(), 0.0, 1.9, &range));
  EXPECT_EQ(range, -1.0);  // untouched on a miss
  EXPECT_TRUE(world.CastRay(Eigen::Vector2d::Zero(), 0.0, 2.0, &range));  // inclusive
  // From outside the room, looking away from it.
  EXPECT_FALSE(world.CastRay(Eigen::Vector2d(5.0, 0.0), 0.0, 100.0, &range));
  // An empty world never returns.
  EXPECT_FALSE(World().CastRay(Eigen::Vector2d::Zero(), 0.3, 100.0, &range));
}

TEST(WorldTest, RayReturnsNearestOfSeveralWallsAndIgnoresParallelOnes) {
  World world;
  world.AddWall(Eigen::Vector2d(5.0, -1.0), Eigen::Vector2d(5.0, 1.0));
  world.AddWall(Eigen::Vector2d(3.0, -1.0), Eigen::Vector2d(3.0, 1.0));
  world.AddWall(Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(2.0, 0.0));  // along the ray
  double range = 0.0;
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d::Zero(), 0.0, 30.0, &range));
  EXPECT_NEAR(range, 3.0, 1e-12);
  // Through the end point of the wall x = 3 (y = 1): still a hit.
  ASSERT_TRUE(world.CastRay(Eigen::Vector2d::Zero(), std::atan2(1.0, 3.0), 30.0, &range));
  EXPECT_NEAR(range, std::sqrt(10.0), 1e-9);
}

// CastRays (angular culling) against CastRay (brute force), ray by ray.
void ExpectCastRaysMatchesCastRay(const World& world, const Eigen::Vector2d& origin,
                                  const std::vector<double>& angles, double max_range) {
  std::vector<double> ranges;
  world.CastRays(origin, angles, max_range, &ranges);
  ASSERT_EQ(ranges.size(), angles.size());
  for (size_t i = 0; i < angles.size(); ++i) {
    double expected = 0.0;
    if (world.CastRay(origin, angles[i], max_range, &expected)) {
      ASSERT_EQ(ranges[i], expected) << "origin " << origin.transpose() << " angle " << angles[i];
    } else {
      ASSERT_TRUE(std::isinf(ranges[i])) << "origin " << origin.transpose() << " angle "
                                         << angles[i] << " range " << ranges[i];
    }
  }
}

TEST(WorldTest, CastRaysMatchesCastRayInSquareRoomIncludingCornersAndWrap) {
  const World world = SquareRoom();
  std::vector<double> angles;
  for (int k = -720; k <= 720; ++k) angles.push_back(k * 0.5 * kDeg);  // ±360°, hits ±180°
  ExpectCastRaysMatchesCastRay(world, Eigen::Vector2d::Zero(), angles, 30.0);
  ExpectCastRaysMatchesCastRay(world, Eigen::Vector2d(1.0, -0.5), angles, 30.0);
  ExpectCastRaysMatchesCastRay(world, Eigen::Vector2d(1.0, -0.5), angles, 1.5);
  // Origin on a wall and at a corner.
  ExpectCastRaysMatchesCastRay(world, Eigen::Vector2d(2.0, 0.5), angles, 30.0);
  ExpectCastRaysMatchesCastRay(world, Eigen::Vector2d(2.0, 2.0), angles, 30.0);
  std::vector<double> ranges;
  world.CastRays(Eigen::Vector2d::Zero(), {0.0, 45.0 * kDeg, M_PI}, 30.0, &ranges);
  EXPECT_NEAR(ranges[0], 2.0, 1e-12);
  EXPECT_NEAR(ranges[1], 2.0 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(ranges[2], 2.0, 1e-12);
}

TEST(WorldTest, CastRaysMatchesCastRayAtSeededRandomPosesInTheOfficeLoop) {
  Scenario scenario;
  ASSERT_TRUE(ReadScenarioFile(
                  std::string(HETSLAM_SOURCE_DIR) + "/datasets/scenarios/office_loop.scenario",
                  &scenario)
                  .ok());
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> x(-1.0, 31.0), y(-1.0, 21.0), heading(-M_PI, M_PI),
      range(1.0, 40.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector2d origin(x(rng), y(rng));
    const double h = heading(rng);
    std::vector<double> angles;
    for (int k = 0; k < 361; ++k) angles.push_back(h - M_PI / 2 + k * 0.5 * kDeg);
    ExpectCastRaysMatchesCastRay(scenario.world, origin, angles, range(rng));
  }
}

TEST(WorldTest, SegmentAndDistanceQueries) {
  const World world = SquareRoom();
  EXPECT_FALSE(world.SegmentHitsWall(Eigen::Vector2d(-1.0, -1.0), Eigen::Vector2d(1.0, 1.0)));
  EXPECT_TRUE(world.SegmentHitsWall(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(3.0, 0.5)));
  EXPECT_TRUE(world.SegmentHitsWall(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(2.0, 0.0)));
  EXPECT_NEAR(world.DistanceToNearestWall(Eigen::Vector2d(0.0, 0.0)), 2.0, 1e-12);
  EXPECT_NEAR(world.DistanceToNearestWall(Eigen::Vector2d(1.5, -0.25)), 0.5, 1e-12);
  EXPECT_NEAR(world.DistanceToNearestWall(Eigen::Vector2d(3.0, 3.0)), std::sqrt(2.0), 1e-12);
}

TEST(LaserOptionsTest, BeamAnglesFollowTheFlaserConvention) {
  LaserOptions laser;
  laser.field_of_view_radians = M_PI;
  laser.num_beams = 361;  // odd: both ends included
  std::vector<double> angles = laser.BeamAnglesRadians();
  ASSERT_EQ(angles.size(), 361u);
  EXPECT_NEAR(angles.front(), -M_PI / 2, 1e-12);
  EXPECT_NEAR(angles.back(), M_PI / 2, 1e-12);
  EXPECT_NEAR(angles[180], 0.0, 1e-12);
  laser.num_beams = 360;  // even: fov / n steps, last beam at +89.5°
  angles = laser.BeamAnglesRadians();
  EXPECT_NEAR(angles.front(), -M_PI / 2, 1e-12);
  EXPECT_NEAR(angles.back(), 89.5 * kDeg, 1e-12);
  EXPECT_NEAR(laser.AngleIncrementRadians(), 0.5 * kDeg, 1e-12);
}

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

TEST(ScenarioTest, MissingFileIsAnErrorNamingThePath) {
  Scenario scenario;
  const Status status = ReadScenarioFile("/nonexistent/dir/x.scenario", &scenario);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("/nonexistent/dir/x.scenario"));
}

TEST(ScenarioTest, FileErrorsNameThePathAndLine) {
  const std::string path = testing::TempDir() + "/world_test_bad.scenario";
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

}  // namespace
}  // namespace sim
}  // namespace hetslam
