// 3D ray casting (floor, ceiling, wall heights, tables, shelves, obstacles) and the team
// scenario statements of the parser.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "datasets/sim/world.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

using ::testing::HasSubstr;

constexpr double kDeg = M_PI / 180.0;

// A beam of a laser at height h, pitched down by `pitch` (positive = down), heading along +x.
Eigen::Vector3d PitchedDown(double pitch_radians) {
  return Eigen::Vector3d(std::cos(pitch_radians), 0.0, -std::sin(pitch_radians));
}

// A 6 m x 6 m room centred at the origin, 2.5 m walls, ceiling at 2.5 m.
World Room() {
  World world;
  world.AddBox(Eigen::Vector2d::Zero(), Eigen::Vector2d(6.0, 6.0), 0.0);
  world.SetHeights(2.5, 2.5);
  return world;
}

TEST(World3DTest, PitchedBeamHitsTheFloorExactlyWhereGeometrySays) {
  const World world = Room();
  const double h = 0.5;
  const Eigen::Vector3d origin(0.0, 0.0, h);
  for (double pitch_deg : {10.0, 20.0, 30.0, 40.0}) {
    const double p = pitch_deg * kDeg;
    const RayHit hit = world.CastRay3D(origin, PitchedDown(p), 5.6);
    ASSERT_TRUE(hit.hit) << pitch_deg;
    EXPECT_EQ(hit.surface, Surface::kFloor) << pitch_deg;
    EXPECT_NEAR(hit.range_meters, h / std::sin(p), 1e-12) << pitch_deg;
    // The hit point lies on the floor, h / tan(p) ahead.
    const Eigen::Vector3d point = origin + hit.range_meters * PitchedDown(p);
    EXPECT_NEAR(point.z(), 0.0, 1e-12);
    EXPECT_NEAR(point.x(), h / std::tan(p), 1e-12) << pitch_deg;
  }
}

TEST(World3DTest, TooSmallPitchHitsTheWallInstead) {
  const World world = Room();  // wall 3 m ahead
  const double h = 0.5, p = 5.0 * kDeg;  // the floor would be 5.71 m ahead
  ASSERT_GT(h / std::tan(p), 3.0);
  const RayHit hit = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, h), PitchedDown(p), 5.6);
  ASSERT_TRUE(hit.hit);
  EXPECT_EQ(hit.surface, Surface::kWall);
  EXPECT_NEAR(hit.range_meters, 3.0 / std::cos(p), 1e-12);
  // Without the wall in range the beam has no return (the floor is beyond 5.6 m).
  World open_floor;
  open_floor.AddWall(Eigen::Vector2d(-10.0, -10.0), Eigen::Vector2d(-10.0, 10.0));
  EXPECT_FALSE(open_floor.CastRay3D(Eigen::Vector3d(0.0, 0.0, h), PitchedDown(p), 5.6).hit);
}

TEST(World3DTest, FloorOrWallDecidedBySweepOverPitch) {
  const World world = Room();
  const double h = 0.47, wall = 3.0;
  for (double pitch_deg = 0.5; pitch_deg < 80.0; pitch_deg += 0.25) {
    const double p = pitch_deg * kDeg;
    const double floor_x = h / std::tan(p);
    if (std::abs(floor_x - wall) < 1e-6) continue;  // the corner itself
    const RayHit hit = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, h), PitchedDown(p), 30.0);
    ASSERT_TRUE(hit.hit);
    if (floor_x < wall) {
      EXPECT_EQ(hit.surface, Surface::kFloor) << pitch_deg;
      EXPECT_NEAR(hit.range_meters, h / std::sin(p), 1e-9);
    } else {
      EXPECT_EQ(hit.surface, Surface::kWall) << pitch_deg;
      EXPECT_NEAR(hit.range_meters, wall / std::cos(p), 1e-9);
    }
  }
}

TEST(World3DTest, CeilingAndWallTops) {
  World world = Room();
  const RayHit up = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, 1.0),
                                    Eigen::Vector3d(std::cos(60 * kDeg), 0.0, std::sin(60 * kDeg)),
                                    10.0);
  ASSERT_TRUE(up.hit);
  EXPECT_EQ(up.surface, Surface::kCeiling);
  EXPECT_NEAR(up.range_meters, 1.5 / std::sin(60 * kDeg), 1e-12);
  // Low walls and no ceiling: a level beam above the wall top sees nothing, one below hits.
  world.SetHeights(1.0, std::numeric_limits<double>::infinity());
  EXPECT_FALSE(world.CastRay3D(Eigen::Vector3d(0.0, 0.0, 1.2), Eigen::Vector3d::UnitX(), 10.0).hit);
  const RayHit low = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, 0.8), Eigen::Vector3d::UnitX(), 10.0);
  ASSERT_TRUE(low.hit);
  EXPECT_EQ(low.surface, Surface::kWall);
  EXPECT_NEAR(low.range_meters, 3.0, 1e-12);
}

TEST(World3DTest, TableTopIsHitAboveAndPassedUnderBetweenTheLegs) {
  World world = Room();
  // 1.2 m x 0.8 m table, 0.75 m high, centred 1.5 m ahead: the top spans x in [0.9, 2.1] and
  // z in [0.71, 0.75]; the legs stand at the corners, y = +-0.3, so y = 0 is between them.
  world.AddTable(Eigen::Vector2d(1.5, 0.0), Eigen::Vector2d(1.2, 0.8), 0.0, 0.75);
  ASSERT_EQ(world.prisms().size(), 5u);  // top and four legs
  const RayHit under = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, 0.3), Eigen::Vector3d::UnitX(), 5.6);
  ASSERT_TRUE(under.hit);
  EXPECT_EQ(under.surface, Surface::kWall);  // passes under the top, between the legs
  EXPECT_NEAR(under.range_meters, 3.0, 1e-12);
  const RayHit top = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, 0.72), Eigen::Vector3d::UnitX(), 5.6);
  ASSERT_TRUE(top.hit);
  EXPECT_EQ(top.surface, Surface::kFurniture);
  EXPECT_NEAR(top.range_meters, 0.9, 1e-12);  // the top's near edge
  // A beam at 0.3 m along a leg row (y = 0.3) hits the near leg (x from 0.95 to 1.0).
  const RayHit leg = world.CastRay3D(Eigen::Vector3d(0.0, 0.3, 0.3), Eigen::Vector3d::UnitX(), 5.6);
  ASSERT_TRUE(leg.hit);
  EXPECT_EQ(leg.surface, Surface::kFurniture);
  EXPECT_NEAR(leg.range_meters, 0.95, 1e-12);
  // Looking down onto the top from above: hits its upper face.
  const RayHit down = world.CastRay3D(Eigen::Vector3d(1.5, 0.1, 1.5), -Eigen::Vector3d::UnitZ(), 5.0);
  ASSERT_TRUE(down.hit);
  EXPECT_EQ(down.surface, Surface::kFurniture);
  EXPECT_NEAR(down.range_meters, 0.75, 1e-12);
}

TEST(World3DTest, ShelfHasADeepLowerAndAShallowUpperPart) {
  World world = Room();
  // Back against the east wall x = 3, from (3, -1) to (3, 1): the shelf stands on the left of
  // that segment, i.e. towards -x. Lower part 0.5 m deep up to 0.8 m, upper 0.3 m deep to 2 m.
  world.AddShelf(Eigen::Vector2d(3.0, -1.0), Eigen::Vector2d(3.0, 1.0), 0.5, 0.8, 0.3, 2.0);
  const Eigen::Vector3d ahead = Eigen::Vector3d::UnitX();
  const RayHit low = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, 0.3), ahead, 5.6);
  ASSERT_TRUE(low.hit);
  EXPECT_EQ(low.surface, Surface::kFurniture);
  EXPECT_NEAR(low.range_meters, 2.5, 1e-12);
  const RayHit high = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, 1.5), ahead, 5.6);
  ASSERT_TRUE(high.hit);
  EXPECT_EQ(high.surface, Surface::kFurniture);
  EXPECT_NEAR(high.range_meters, 2.7, 1e-12);
  const RayHit above = world.CastRay3D(Eigen::Vector3d(0.0, 0.0, 2.2), ahead, 5.6);
  ASSERT_TRUE(above.hit);
  EXPECT_EQ(above.surface, Surface::kWall);
}

TEST(World3DTest, LowObstacleIsSeenOnlyByABeamThatReachesIt) {
  World world = Room();
  world.AddBoxPrism(Eigen::Vector2d(1.5, 0.0), Eigen::Vector2d(0.4, 0.4), 30.0 * kDeg, 0.0, 0.2,
                    Surface::kObstacle);
  const Eigen::Vector3d origin(0.0, 0.0, 0.5);
  const RayHit level = world.CastRay3D(origin, Eigen::Vector3d::UnitX(), 5.6);
  EXPECT_EQ(level.surface, Surface::kWall);  // passes over it
  // Pitched so that it reaches height 0.1 at x = 1.5: inside the obstacle.
  const double p = std::atan2(0.4, 1.5);
  const RayHit tilted = world.CastRay3D(origin, PitchedDown(p), 5.6);
  ASSERT_TRUE(tilted.hit);
  EXPECT_EQ(tilted.surface, Surface::kObstacle);
  EXPECT_LT(tilted.range_meters, 1.5 / std::cos(p));
  EXPECT_EQ(std::string(SurfaceName(tilted.surface)), "obstacle");
}

TEST(World3DTest, LevelBeamsAgreeWithThe2DCastRaysWithoutPrisms) {
  World world;
  world.AddBox(Eigen::Vector2d::Zero(), Eigen::Vector2d(8.0, 5.0), 0.0);
  world.AddBox(Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(0.5, 0.7), 0.4);
  world.AddWall(Eigen::Vector2d(-3.0, -2.0), Eigen::Vector2d(2.0, 1.5));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(-3.5, 3.5), y(-2.0, 2.0), angle(-M_PI, M_PI),
      z(0.1, 3.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector2d origin(x(rng), y(rng));
    std::vector<double> angles;
    std::vector<Eigen::Vector3d> directions;
    for (int i = 0; i < 90; ++i) {
      angles.push_back(angle(rng));
      directions.emplace_back(std::cos(angles.back()), std::sin(angles.back()), 0.0);
    }
    std::vector<double> ranges;
    world.CastRays(origin, angles, 30.0, &ranges);
    std::vector<RayHit> hits;
    world.CastRays3D(Eigen::Vector3d(origin.x(), origin.y(), z(rng)), directions, 30.0, &hits);
    for (size_t i = 0; i < angles.size(); ++i) {
      ASSERT_EQ(hits[i].hit, std::isfinite(ranges[i]));
      if (hits[i].hit) {
        EXPECT_NEAR(hits[i].range_meters, ranges[i], 1e-9);
        EXPECT_EQ(hits[i].surface, Surface::kWall);
      }
    }
  }
}

TEST(World3DTest, LineOfSightIsBlockedByWallsAndFurniture) {
  World world = Room();
  world.AddBoxPrism(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.5, 0.5), 0.0, 0.0, 1.0,
                    Surface::kFurniture);
  EXPECT_FALSE(world.LineOfSight(Eigen::Vector3d(-1.0, 0.0, 0.5), Eigen::Vector3d(1.0, 0.0, 0.5)));
  EXPECT_TRUE(world.LineOfSight(Eigen::Vector3d(-1.0, 0.0, 1.5), Eigen::Vector3d(1.0, 0.0, 1.5)));
  // A point on a wall is visible from inside the room (the wall itself does not block it).
  EXPECT_TRUE(world.LineOfSight(Eigen::Vector3d(-1.0, 1.0, 1.5), Eigen::Vector3d(3.0, 1.0, 1.2)));
  EXPECT_NEAR(world.DistanceToNearestStructure(Eigen::Vector2d(0.0, 0.0)), 0.0, 1e-12);
  EXPECT_NEAR(world.DistanceToNearestStructure(Eigen::Vector2d(1.0, 0.0)), 0.75, 1e-12);
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

TEST(TeamScenarioTest, DefaultCameraLooksAlongTheLaser) {
  const CameraOptions camera;
  // The optical z axis is the laser's x axis, optical x is the laser's -y (right).
  EXPECT_TRUE(camera.laser_T_camera.linear().col(2).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_TRUE(camera.laser_T_camera.linear().col(0).isApprox(-Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_NEAR(camera.laser_T_camera.linear().determinant(), 1.0, 1e-12);
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
