// 3D ray casting (floor, ceiling, wall heights, tables, shelves, obstacles).
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "datasets/sim/world.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

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

}  // namespace
}  // namespace sim
}  // namespace hetslam
