#include "datasets/sim/world.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "datasets/sim/scenario.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

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

}  // namespace
}  // namespace sim
}  // namespace hetslam
