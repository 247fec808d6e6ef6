#include "merger/map_merge.h"

#include <cmath>
#include <optional>
#include <vector>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

// A wall along x = 2 (y in [-1, 1]) seen from the origin `scans` times: rays over free space,
// end points on the wall.
void ObserveWall(int scans, OccupancyGrid* grid) {
  std::vector<Eigen::Vector2d> points;
  for (double y = -1.0; y <= 1.0; y += 0.025) points.emplace_back(2.01, y);
  for (int i = 0; i < scans; ++i) grid->InsertScan(Eigen::Vector2d::Zero(), points, nullptr);
}

float Probability(const OccupancyGrid& grid, const Eigen::Vector2d& p) {
  return grid.Probability(grid.geometry().LinearIndex(grid.geometry().WorldToCell(p)));
}

CellState StateAt(const OccupancyGrid& grid, const Eigen::Vector2d& p) {
  const CellIndex c = grid.geometry().WorldToCell(p);
  return grid.geometry().Contains(c) ? grid.State(c) : CellState::kUnknown;
}

// The paper's merge rule (§V-B): a teammate's map is one observation. Our robot mapped a wall at
// x = 2 with 20 scans; the teammate's map (slightly off, as a noisy merge would be) says the wall
// is at x = 2.3 and the cells at x = 2 are free, and it also saw a wall at x = -3 that we never
// saw. After the merge: the unknown wall appears, our wall stays occupied within a small bound,
// and the teammate's free cells behind our wall fill our unknown space.
TEST(MapMergeTest, TeammateFillsUnknownCellsAndBarelyMovesWellObservedWalls) {
  OccupancyGrid own{OccupancyGridOptions()};
  ObserveWall(20, &own);
  const Eigen::Vector2d wall(2.01, 0.0), free_space(1.0, 0.0);
  ASSERT_EQ(CellState::kOccupied, StateAt(own, wall));
  ASSERT_EQ(CellState::kUnknown, StateAt(own, {-2.99, 0.0}));
  const float wall_before = Probability(own, wall);
  const float free_before = Probability(own, free_space);

  // The teammate's map in its own frame, which sits at (0.3, 0) in ours: its wall at x = 2 is our
  // x = 2.3, and its rays cross our x = 2; it also sees a wall at its x = -3.3 (our -3.0).
  OccupancyGrid teammate{OccupancyGridOptions()};
  std::vector<Eigen::Vector2d> points;
  for (double y = -1.0; y <= 1.0; y += 0.025) points.emplace_back(2.01, y);
  teammate.InsertScan(Eigen::Vector2d::Zero(), points, nullptr);
  points.clear();
  for (double y = -1.0; y <= 1.0; y += 0.025) points.emplace_back(-3.29, y);
  teammate.InsertScan(Eigen::Vector2d::Zero(), points, nullptr);

  const int merged = MergeMapAsOneObservation(teammate, Pose2(0.3, 0.0, 0.0), MapMergeOptions(), &own);
  EXPECT_GT(merged, 100);
  // Our well-observed wall: still occupied, its probability within 0.03 of before.
  EXPECT_EQ(CellState::kOccupied, StateAt(own, wall));
  EXPECT_LT(std::abs(Probability(own, wall) - wall_before), 0.03);
  // Our free space stays free (the teammate agrees there).
  EXPECT_EQ(CellState::kFree, StateAt(own, free_space));
  EXPECT_LE(Probability(own, free_space), free_before + 1e-6);
  // Unknown to us, known to the teammate: now its state.
  EXPECT_EQ(CellState::kOccupied, StateAt(own, {-2.99, 0.0}));
  EXPECT_EQ(CellState::kFree, StateAt(own, {-1.5, 0.0}));
  EXPECT_EQ(CellState::kOccupied, StateAt(own, {2.31, 0.0}));  // behind our wall: we never saw there
  // Cells neither saw stay unknown.
  EXPECT_EQ(CellState::kUnknown, StateAt(own, {0.0, 3.0}));
}

TEST(MapMergeTest, RotatedTeammateLandsWhereItsFrameSays) {
  OccupancyGrid teammate{OccupancyGridOptions()};
  std::vector<Eigen::Vector2d> points;
  for (double y = -1.0; y <= 1.0; y += 0.025) points.emplace_back(2.01, y);
  teammate.InsertScan(Eigen::Vector2d::Zero(), points, nullptr);
  OccupancyGrid merged{OccupancyGridOptions()};
  // The teammate's frame at (5, 5), turned by 90°: its wall x = 2 is our y = 7, x in [4, 6].
  MergeMapAsOneObservation(teammate, Pose2(5.0, 5.0, M_PI / 2), MapMergeOptions(), &merged);
  EXPECT_EQ(CellState::kOccupied, StateAt(merged, {5.0, 7.01}));
  EXPECT_EQ(CellState::kOccupied, StateAt(merged, {4.2, 7.01}));
  EXPECT_EQ(CellState::kFree, StateAt(merged, {5.0, 6.0}));
  EXPECT_EQ(CellState::kUnknown, StateAt(merged, {7.0, 5.0}));
}

TEST(MapMergeTest, EmptyTeammateChangesNothing) {
  OccupancyGrid own{OccupancyGridOptions()};
  ObserveWall(3, &own);
  const std::vector<float> before = own.log_odds().Dense();
  OccupancyGrid empty{OccupancyGridOptions()};
  EXPECT_EQ(0, MergeMapAsOneObservation(empty, Pose2::Identity(), MapMergeOptions(), &own));
  EXPECT_EQ(before, own.log_odds().Dense());
}

// Walls around a 4 m x 3 m room seen from its centre (five scans), plus `extra` points; hit at
// `laser_height` metres above the floor when given (a 2.5D projection's heights).
OccupancyGrid RoomWith(const std::vector<Eigen::Vector2d>& extra, std::optional<float> laser_height = std::nullopt) {
  OccupancyGrid grid{OccupancyGridOptions()};
  std::vector<Eigen::Vector2d> points;
  for (double t = -2.0; t <= 2.0; t += 0.02) {
    points.emplace_back(t, -1.5);
    points.emplace_back(t, 1.5);
  }
  for (double t = -1.5; t <= 1.5; t += 0.02) {
    points.emplace_back(-2.0, t);
    points.emplace_back(2.0, t);
  }
  points.insert(points.end(), extra.begin(), extra.end());
  const std::vector<float> heights(points.size(), laser_height.value_or(0.f));
  for (int i = 0; i < 5; ++i) {
    grid.InsertScan(Eigen::Vector2d(0.0, 0.0), points, nullptr, nullptr, laser_height ? &heights : nullptr);
  }
  return grid;
}

// The room with a 0.4 m square box in one corner (its front face).
OccupancyGrid RoomMap() {
  std::vector<Eigen::Vector2d> box;
  for (double t = 0.8; t <= 1.2; t += 0.02) box.emplace_back(t, 0.6);
  return RoomWith(box);
}

int OccupiedCells(const OccupancyGrid& grid) {
  int n = 0;
  for (int i = 0; i < grid.geometry().num_cells(); ++i) n += grid.State(i) == CellState::kOccupied ? 1 : 0;
  return n;
}

// The same map at its own pose agrees everywhere; shifted by 0.5 m its walls land in the other's
// free space; under a rotation that swaps the room's ends the box is the only conflict.
TEST(CompareMapsTest, CountsAgreeingAndConflictingWallCells) {
  const OccupancyGrid a = RoomMap(), b = RoomMap();
  const int occupied = OccupiedCells(a);
  ASSERT_GT(occupied, 250);  // 14 m of wall at 5 cm, and the box
  const MapAgreement same = CompareMaps(a, b, Pose2(0.0, 0.0, 0.0));
  EXPECT_EQ(2 * occupied, same.agreeing);
  EXPECT_EQ(0, same.conflicting);
  EXPECT_EQ(0.0, same.ConflictFraction());

  const MapAgreement shifted = CompareMaps(a, b, Pose2(0.5, 0.0, 0.0));
  EXPECT_GT(shifted.ConflictFraction(), 0.2) << shifted.agreeing << " agree, " << shifted.conflicting << " conflict";

  // The room is symmetric under a half turn, the box is not: only the box's cells (and the
  // free cells in front of the other's box) conflict.
  const MapAgreement half_turn = CompareMaps(a, b, Pose2(0.0, 0.0, M_PI));
  EXPECT_GT(half_turn.conflicting, 10);
  EXPECT_LT(half_turn.ConflictFraction(), 0.1);

  // Far apart: nothing compared.
  const MapAgreement apart = CompareMaps(a, b, Pose2(100.0, 0.0, 0.0));
  EXPECT_EQ(0, apart.agreeing + apart.conflicting);
  EXPECT_EQ(1.0, apart.ConflictFraction());
}

// Lasers at different heights (MapHeights). A wheeled robot's laser at 0.3 m and a UAV's at
// 1.4 m map the same room (`RoomWith`: walls, hits at the laser's height); the wheeled robot also
// meets a 0.4 m box the UAV flies over (the UAV's rays make its cells free), and the UAV meets a
// surface at 1.4 m (a shelf) where the wheeled robot's rays found free space. With the lasers'
// heights the box lies under the UAV's lowest ray: passed over, no conflict; the shelf, standing
// on the floor as the 2.5D assumption has it, reaches down through the wheeled robot's rays, so
// it conflicts as before. Without heights (or for a 2D laser) both conflict.
TEST(CompareMapsTest, ASurfaceUnderTheOtherRobotsLasersIsPassedOverNotAConflict) {
  std::vector<Eigen::Vector2d> box, shelf;
  for (double t = 0.8; t <= 1.2; t += 0.02) box.emplace_back(t, 0.6);      // its front face
  for (double t = -1.2; t <= -0.8; t += 0.02) shelf.emplace_back(t, -0.6);  // its front face
  const OccupancyGrid wheeled = RoomWith(box, 0.3f), uav = RoomWith(shelf, 1.4f);
  const Pose2 same(0.0, 0.0, 0.0);

  const MapAgreement without = CompareMaps(wheeled, uav, same);
  EXPECT_EQ(0, without.passed_over);
  EXPECT_GE(without.conflicting, 2 * 8);  // the box's and the shelf's faces, 0.4 m each

  MapHeights heights;
  heights.a_lowest_ray_meters = 0.3;
  heights.b_lowest_ray_meters = 1.4;
  const MapAgreement with = CompareMaps(wheeled, uav, same, 1, heights);
  EXPECT_EQ(without.agreeing, with.agreeing);
  EXPECT_GE(with.passed_over, 8);  // the box, under the UAV's rays
  EXPECT_EQ(without.conflicting, with.conflicting + with.passed_over);
  EXPECT_GE(with.conflicting, 8);  // the shelf, above the wheeled robot's rays
  EXPECT_LT(with.ConflictFraction(), without.ConflictFraction());

  // A margin wider than the lasers' gap: the box counts as above the UAV's rays again.
  heights.margin_meters = 1.2;
  EXPECT_EQ(without.conflicting, CompareMaps(wheeled, uav, same, 1, heights).conflicting);
  // The UAV without a lowest ray (a 2D laser, no heights): the box conflicts as before.
  heights.margin_meters = 0.1;
  heights.b_lowest_ray_meters.reset();
  EXPECT_EQ(without.conflicting, CompareMaps(wheeled, uav, same, 1, heights).conflicting);
}

// Walls seen through by a teammate (DropWallsSeenThrough). Our robot's wall layer holds a
// surface along x = 2 (y in [-1, 1]) and one along x = -2 (a wall, seen by the teammate too).
// The teammate, at another height, sees the surface at x = 2 as free and meets its own surface
// `behind` metres further (a shelf's lower face 0.1 m in front of its upper part), and sees the
// wall at x = -2 where we do, 2 cm off (a merge is a few cm off).
void SurfaceAt(double x, const Eigen::Vector2d& sensor, OccupancyGrid* grid, double y_min = -1.0,
               double y_max = 1.0) {
  std::vector<Eigen::Vector2d> points;
  for (double y = y_min; y <= y_max + 1e-9; y += 0.025) points.emplace_back(x, y);
  grid->InsertScan(sensor, points, nullptr);
}

TEST(DropWallsSeenThroughTest, ASurfaceATeammateSawThroughIsNoWall) {
  OccupancyGrid walls{OccupancyGridOptions()};
  SurfaceAt(2.01, Eigen::Vector2d::Zero(), &walls);
  SurfaceAt(-2.01, Eigen::Vector2d::Zero(), &walls);
  const Eigen::Vector2d shelf_face(2.01, 0.0), wall(-2.01, 0.0);
  ASSERT_EQ(CellState::kOccupied, StateAt(walls, shelf_face));
  ASSERT_EQ(CellState::kOccupied, StateAt(walls, wall));

  // The teammate's map, in a frame 0.3 m along x from ours: its surfaces at its x = 1.81 (our
  // 2.11: 0.1 m behind our x = 2.01) and -2.29 (our -1.99).
  OccupancyGrid teammate{OccupancyGridOptions()};
  for (int i = 0; i < 3; ++i) {
    SurfaceAt(1.81, {-0.3, 0.0}, &teammate);
    SurfaceAt(-2.29, {-0.3, 0.0}, &teammate);
  }
  const Pose2 walls_T_teammate(0.3, 0.0, 0.0);
  ASSERT_EQ(CellState::kFree, StateAt(teammate, walls_T_teammate.inverse() * shelf_face));

  const int dropped = DropWallsSeenThrough(teammate, walls_T_teammate, 0.075, &walls);
  // Every cell of the surface at x = 2 (its hit points on free cells of the teammate, its
  // surface 0.1 m away), none of the wall (the teammate's surface 2 cm from it).
  EXPECT_GE(dropped, 40);
  EXPECT_EQ(CellState::kUnknown, StateAt(walls, shelf_face));
  EXPECT_EQ(CellState::kUnknown, StateAt(walls, {2.01, 0.9}));
  EXPECT_EQ(CellState::kOccupied, StateAt(walls, wall));
  EXPECT_EQ(CellState::kOccupied, StateAt(walls, {-2.01, 0.9}));
  EXPECT_EQ(CellState::kOccupied, StateAt(walls, {-2.01, -0.9}));
}

TEST(DropWallsSeenThroughTest, ASurfaceATeammateMetNearbyOrNeverSawStays) {
  OccupancyGrid walls{OccupancyGridOptions()};
  SurfaceAt(2.01, Eigen::Vector2d::Zero(), &walls);
  // The teammate saw only the part y < 0, 6 cm behind ours (within 0.075 m: the same wall,
  // merged a little off); the part y > 0 is unknown to it.
  OccupancyGrid teammate{OccupancyGridOptions()};
  SurfaceAt(2.07, Eigen::Vector2d::Zero(), &teammate, -1.0, -0.1);
  ASSERT_EQ(CellState::kFree, StateAt(teammate, {2.01, -0.5}));
  ASSERT_EQ(CellState::kUnknown, StateAt(teammate, {2.01, 0.5}));
  EXPECT_EQ(0, DropWallsSeenThrough(teammate, Pose2::Identity(), 0.075, &walls));
  // With a smaller distance than the 6 cm the part it saw goes, the unknown part stays.
  EXPECT_GE(DropWallsSeenThrough(teammate, Pose2::Identity(), 0.04, &walls), 15);  // y in [-1, -0.1]: 18 cells
  EXPECT_EQ(CellState::kUnknown, StateAt(walls, {2.01, -0.5}));
  EXPECT_EQ(CellState::kOccupied, StateAt(walls, {2.01, 0.5}));
}

}  // namespace
}  // namespace hetslam
