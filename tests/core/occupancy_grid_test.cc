#include "core/occupancy_grid.h"

#include <cmath>
#include <string>
#include <vector>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

// The label layer: each end cell ORs in (1 << label) of the points that hit it, keeps its bits
// when the grid grows, and costs nothing until the first labelled insertion.
TEST(OccupancyGridTest, LabelLayerRecordsEveryLabelThatHitACellAndSurvivesGrowth) {
  OccupancyGrid grid{OccupancyGridOptions()};
  const Eigen::Vector2d sensor(0.0, 0.0);
  grid.InsertScan(sensor, {{1.0, 0.0}}, nullptr);
  EXPECT_FALSE(grid.has_labels());
  const int wall = grid.geometry().LinearIndex(grid.geometry().WorldToCell({1.0, 0.0}));
  EXPECT_EQ(0, grid.LabelMask(wall));

  const std::vector<uint8_t> labels = {0, 2};  // structure and floor obstacle in one cell
  grid.InsertScan(sensor, {{1.01, 0.01}, {1.02, 0.02}}, nullptr, &labels);
  ASSERT_TRUE(grid.has_labels());
  EXPECT_EQ((1 << 0) | (1 << 2), grid.LabelMask(grid.geometry().LinearIndex(grid.geometry().WorldToCell({1.0, 0.0}))));
  const int free_cell = grid.geometry().LinearIndex(grid.geometry().WorldToCell({0.5, 0.0}));
  EXPECT_EQ(0, grid.LabelMask(free_cell));  // rays do not label the cells they cross

  // A point 30 m away grows the grid (linear indices change); the labelled cell keeps its bits.
  const std::vector<uint8_t> far_label = {3};
  ASSERT_TRUE(grid.EnsureContains({-30.0, -30.0}, {30.0, 30.0}));
  grid.InsertScan(sensor, {{25.0, 0.0}}, nullptr, &far_label);
  EXPECT_EQ((1 << 0) | (1 << 2), grid.LabelMask(grid.geometry().LinearIndex(grid.geometry().WorldToCell({1.0, 0.0}))));
  EXPECT_EQ(1 << 3, grid.LabelMask(grid.geometry().LinearIndex(grid.geometry().WorldToCell({25.0, 0.0}))));
}

// Walls are the invariants of the 2.5D assumption (paper §III-E): a cell hit at heights spanning
// at least wall_min_height_span_meters (default 0.3 m) gets the wall bit; one hit at many
// nearly equal heights (a level laser, a low box) does not.
TEST(OccupancyGridTest, CellsHitAtSeveralHeightsAreWalls) {
  OccupancyGrid grid{OccupancyGridOptions()};
  const Eigen::Vector2d sensor(0.0, 0.0);
  const std::vector<uint8_t> structure = {0};
  const auto wall_bit = [&](const Eigen::Vector2d& p) {
    return (grid.LabelMask(grid.geometry().LinearIndex(grid.geometry().WorldToCell(p))) >>
            OccupancyGrid::kWallLabelBit) & 1;
  };
  for (float h : {0.50f, 0.52f, 0.49f, 0.70f}) {  // span 0.21 m: not yet a wall
    const std::vector<float> height = {h};
    grid.InsertScan(sensor, {{2.0, 0.0}}, nullptr, &structure, &height);
  }
  EXPECT_EQ(0, wall_bit({2.0, 0.0}));
  const std::vector<float> low = {0.21f};  // span 0.49 m
  grid.InsertScan(sensor, {{2.0, 0.0}}, nullptr, &structure, &low);
  EXPECT_EQ(1, wall_bit({2.0, 0.0}));
  EXPECT_EQ(1, grid.LabelMask(grid.geometry().LinearIndex(grid.geometry().WorldToCell({2.0, 0.0}))) & 1);
}

// HighestHit: the highest height a cell was hit at (to InsertScan's 2 cm steps), false for a cell
// hit only without heights (a 2D scan), a free cell, one outside the grid, and a frozen grid.
TEST(OccupancyGridTest, HighestHitIsTheHighestHeightACellWasHitAt) {
  OccupancyGrid grid{OccupancyGridOptions()};
  const Eigen::Vector2d sensor(0.0, 0.0);
  grid.InsertScan(sensor, {{1.5, 0.0}, {0.0, 1.5}}, nullptr);
  const CellIndex box = grid.geometry().WorldToCell({1.5, 0.0});  // after the grid grew
  const CellIndex flat = grid.geometry().WorldToCell({0.0, 1.5});
  double height = -1.0;
  EXPECT_FALSE(grid.HighestHit(box, &height));  // no heights yet
  for (float h : {0.30f, 0.34f, 0.31f}) {
    const std::vector<Eigen::Vector2d> point = {{1.5, 0.0}};
    const std::vector<float> heights = {h};
    grid.InsertScan(sensor, point, nullptr, nullptr, &heights);
  }
  ASSERT_TRUE(grid.HighestHit(box, &height));
  EXPECT_NEAR(0.34, height, 1e-9);
  EXPECT_FALSE(grid.HighestHit(flat, &height));  // hit by the 2D scan only
  EXPECT_FALSE(grid.HighestHit(grid.geometry().WorldToCell({0.7, 0.0}), &height));  // free: rays only
  EXPECT_FALSE(grid.HighestHit({-100000, 0}, &height));                           // outside the grid
  grid.Freeze();
  EXPECT_FALSE(grid.HighestHit(box, &height));  // a frozen grid keeps no heights
}

// One observation from outside the laser model (map merging): the cell turns observed with the
// given log-odds, clamped, and the grid grows to hold it.
TEST(OccupancyGridTest, AddCellObservationObservesOneCellAndGrows) {
  OccupancyGridOptions options;
  OccupancyGrid grid(options);
  const Eigen::Vector2d far(12.34, -5.6);
  grid.AddCellObservation(far, static_cast<float>(options.hit_log_odds));
  const CellIndex c = grid.geometry().WorldToCell(far);
  ASSERT_TRUE(grid.geometry().Contains(c));
  EXPECT_EQ(CellState::kOccupied, grid.State(c));
  EXPECT_FLOAT_EQ(static_cast<float>(options.hit_log_odds), grid.LogOdds(grid.geometry().LinearIndex(c)));
  EXPECT_EQ(c.x, grid.observed_min().x);
  EXPECT_EQ(c.y, grid.observed_max().y);
  for (int i = 0; i < 20; ++i) grid.AddCellObservation(far, -1.0f);
  EXPECT_EQ(CellState::kFree, grid.State(grid.geometry().WorldToCell(far)));
  EXPECT_FLOAT_EQ(static_cast<float>(options.min_log_odds),
                  grid.LogOdds(grid.geometry().LinearIndex(grid.geometry().WorldToCell(far))));
  // Its neighbours stay unknown.
  EXPECT_EQ(CellState::kUnknown, grid.State(grid.geometry().WorldToCell(far + Eigen::Vector2d(0.1, 0.0))));
}


// Issue #16: a scan far away (a corrupt pose) or with a non-finite point is refused, not a
// CHECK failure or an int overflow; the grid stays as it was.
TEST(OccupancyGridTest, ScansTheGridCannotContainAreRefused) {
  OccupancyGrid grid{OccupancyGridOptions()};
  std::vector<int> changed;
  ASSERT_TRUE(grid.InsertScan(Eigen::Vector2d(0, 0), {Eigen::Vector2d(1, 0)}, &changed));
  const int cells = grid.geometry().num_cells();
  EXPECT_FALSE(grid.InsertScan(Eigen::Vector2d(0, 0), {Eigen::Vector2d(1e12, 0)}, &changed));
  EXPECT_FALSE(grid.InsertScan(Eigen::Vector2d(0, 0), {Eigen::Vector2d(3e4, 3e4)}, &changed));
  EXPECT_FALSE(grid.InsertScan(Eigen::Vector2d(0, 0), {Eigen::Vector2d(std::nan(""), 0)}, &changed));
  EXPECT_EQ(3, grid.num_scans_refused());
  EXPECT_EQ(cells, grid.geometry().num_cells());
  EXPECT_FALSE(grid.CanContain(Eigen::Vector2d(-1e300, 0), Eigen::Vector2d(1e300, 0)));
  EXPECT_TRUE(grid.CanContain(Eigen::Vector2d(-100, -100), Eigen::Vector2d(100, 100)));
}

// The per-scan stamps are 16 bits: when the scan counter wraps, a cell last updated 65535
// scans ago must not look updated already. Cell A is hit by scan 1, then never again until
// scan 65537 (whose counter would equal A's stamp without the restart): its log-odds rises twice.
TEST(OccupancyGridTest, StampsRestartWhenTheScanCounterWraps) {
  OccupancyGridOptions options;
  options.max_log_odds = 10.0;  // no clamping at two hits
  OccupancyGrid grid(options);
  const Eigen::Vector2d sensor(0.0, 0.0), a(1.0, 0.0), b(0.0, 1.0);
  grid.InsertScan(sensor, {a}, nullptr);
  for (int scan = 2; scan <= 65536; ++scan) grid.InsertScan(sensor, {b}, nullptr);
  grid.InsertScan(sensor, {a}, nullptr);
  const int cell = grid.geometry().LinearIndex(grid.geometry().WorldToCell(a));
  EXPECT_FLOAT_EQ(static_cast<float>(2 * options.hit_log_odds), grid.LogOdds(cell));
}

// A cell that turns free forgets its hit point; hit again until occupied, it starts a new mean
// (its accumulator comes from the pool, possibly reused, and must start at zero).
TEST(OccupancyGridTest, HitPointRestartsAfterTheCellTurnsFree) {
  OccupancyGrid grid{OccupancyGridOptions()};
  const Eigen::Vector2d sensor(0.0, 0.0);
  const Eigen::Vector2d first(1.01, 0.01), second(1.04, 0.04), beyond(2.0, 0.0);
  grid.InsertScan(sensor, {first}, nullptr);
  const int cell = grid.geometry().LinearIndex(grid.geometry().WorldToCell(first));
  ASSERT_EQ(CellState::kOccupied, grid.State(cell));
  EXPECT_NEAR(0.0, (grid.HitPoint(cell) - first).norm(), 1e-6);
  // Rays through the cell until it is free.
  for (int i = 0; i < 5 && grid.State(cell) == CellState::kOccupied; ++i) grid.InsertScan(sensor, {beyond}, nullptr);
  ASSERT_EQ(CellState::kFree, grid.State(cell));
  EXPECT_EQ(0, grid.HitCount(cell));
  // Another cell occupied meanwhile may have taken the released accumulator.
  grid.InsertScan(sensor, {Eigen::Vector2d(0.0, -1.0)}, nullptr);
  for (int i = 0; i < 5 && grid.State(cell) != CellState::kOccupied; ++i) grid.InsertScan(sensor, {second}, nullptr);
  ASSERT_EQ(CellState::kOccupied, grid.State(cell));
  EXPECT_NEAR(0.0, (grid.HitPoint(cell) - second).norm(), 1e-6);
}

// Rays lower a cell once per scan however many of them cross it, down to min_log_odds, where a
// cell stays (InsertScan passes over such cells without marking them: it must not matter).
TEST(OccupancyGridTest, RaysLowerEachCellOncePerScanDownToTheLowestLogOdds) {
  const OccupancyGridOptions options;
  OccupancyGrid grid{options};
  auto log_odds_at = [&grid](const Eigen::Vector2d& p) {
    const CellIndex c = grid.geometry().WorldToCell(p);
    return grid.log_odds().Get(c.x, c.y);
  };
  const Eigen::Vector2d sensor(0.02, 0.02), wall(1.02, 0.02), in_front(0.52, 0.02), behind(1.52, 0.02);
  for (int i = 0; i < 7; ++i) grid.InsertScan(sensor, {wall}, nullptr);
  const float lowest = static_cast<float>(options.min_log_odds);
  ASSERT_EQ(lowest, log_odds_at(in_front));  // 7 misses of -0.4, clamped at -2
  ASSERT_FLOAT_EQ(options.max_log_odds, log_odds_at(wall));
  EXPECT_EQ(OccupancyGrid::kUnobserved, log_odds_at(behind));
  // Two rays along the same line through the wall's cell, both ending in one cell beyond it.
  const Eigen::Vector2d end(2.02, 0.02), end_too(2.02, 0.021);
  ASSERT_TRUE(grid.geometry().WorldToCell(end) == grid.geometry().WorldToCell(end_too));
  std::vector<int> changed;
  ASSERT_TRUE(grid.InsertScan(sensor, {end, end_too}, &changed));
  EXPECT_EQ(lowest, log_odds_at(in_front));
  EXPECT_FLOAT_EQ(options.max_log_odds + options.miss_log_odds, log_odds_at(wall));
  EXPECT_FLOAT_EQ(options.miss_log_odds, log_odds_at(behind));
  EXPECT_FLOAT_EQ(options.hit_log_odds, log_odds_at(end));
  // Changed: the new end cell only (the wall's cell is still occupied).
  ASSERT_EQ(1u, changed.size());
  EXPECT_EQ(grid.geometry().LinearIndex(grid.geometry().WorldToCell(end)), changed[0]);
  // A cell raised off the lowest log-odds from outside the laser model (a teammate's map) is
  // lowered by the next ray again; one taken down to the lowest stays there.
  grid.AddCellObservation(in_front, 1.f);
  EXPECT_FLOAT_EQ(options.min_log_odds + 1.0, log_odds_at(in_front));
  grid.AddCellObservation(behind, -10.f);
  ASSERT_EQ(lowest, log_odds_at(behind));
  grid.InsertScan(sensor, {end}, nullptr);
  EXPECT_FLOAT_EQ(options.min_log_odds + 1.0 + options.miss_log_odds, log_odds_at(in_front));
  EXPECT_EQ(lowest, log_odds_at(behind));
  // A cell at the lowest log-odds that a scan hits is raised by the hit, once.
  ASSERT_TRUE(grid.InsertScan(sensor, {behind, behind + Eigen::Vector2d(0.001, 0.0)}, nullptr));
  EXPECT_FLOAT_EQ(options.min_log_odds + options.hit_log_odds, log_odds_at(behind));
  // ... which needs a hit that changes the lowest log-odds in float precision.
  OccupancyGridOptions tiny_hit;
  tiny_hit.hit_log_odds = 1e-9;
  std::string error;
  EXPECT_FALSE(tiny_hit.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("too small")) << error;
}

// The noise tail behind a wall: a wall at x = 1.02 m seen 20 times from the origin, plus one stray
// end point 7 cm behind it. Rays clear what lies in front of the wall, never what lies behind,
// so the stray cell stays occupied on a single hit; DropWeakOccupiedCells (share 0.2) makes it
// unknown again: a wall cell was hit 20 times as often and nothing lies beyond the stray one. A
// lone post hit once, with no stronger neighbour, the wall's own cells and weak cells along the
// wall or in front of it stay.
TEST(OccupancyGridTest, DropWeakOccupiedCellsForgetsTheNoiseTailBehindAWall) {
  OccupancyGrid grid{OccupancyGridOptions()};
  const Eigen::Vector2d sensor(0.0, 0.0);
  std::vector<Eigen::Vector2d> wall;
  for (double y = -0.5; y <= 0.5; y += 0.01) wall.push_back({1.02, y});
  for (int k = 0; k < 20; ++k) grid.InsertScan(sensor, wall, nullptr);
  grid.InsertScan(sensor, {{1.09, 0.02}, {0.5, 2.0}}, nullptr);  // the stray hit; a post elsewhere
  const GridGeometry& g = grid.geometry();
  auto index = [&](double x, double y) { return g.LinearIndex(g.WorldToCell({x, y})); };
  ASSERT_EQ(CellState::kOccupied, grid.State(index(1.09, 0.02)));
  ASSERT_EQ(1, grid.HitCount(index(1.09, 0.02)));
  ASSERT_GE(grid.HitCount(index(1.02, 0.02)), 20);

  EXPECT_EQ(0, grid.DropWeakOccupiedCells(0.0));  // 0 keeps every cell
  EXPECT_EQ(1, grid.DropWeakOccupiedCells(0.2));
  EXPECT_EQ(CellState::kUnknown, grid.State(index(1.09, 0.02)));
  EXPECT_EQ(0, grid.HitCount(index(1.09, 0.02)));
  EXPECT_EQ(CellState::kOccupied, grid.State(index(0.5, 2.0)));  // no stronger neighbour
  for (double y = -0.45; y <= 0.45; y += 0.05) {
    EXPECT_EQ(CellState::kOccupied, grid.State(index(1.02, y))) << "wall cell at y = " << y;
  }
  EXPECT_EQ(0, grid.DropWeakOccupiedCells(0.2));  // nothing weak is left
  // A wall cell seen once between cells seen 20 times stays: the wall goes on at its far side.
  OccupancyGrid along{OccupancyGridOptions()};
  for (int k = 0; k < 20; ++k) along.InsertScan(sensor, {{1.02, 0.02}, {1.02, 0.12}}, nullptr);
  along.InsertScan(sensor, {{1.02, 0.07}}, nullptr);
  const GridGeometry& ga = along.geometry();
  ASSERT_EQ(1, along.HitCount(ga.LinearIndex(ga.WorldToCell({1.02, 0.07}))));
  EXPECT_EQ(0, along.DropWeakOccupiedCells(0.2));
  // A weak cell in front of the wall (something the robot saw there a few times) stays: the rays
  // crossed the cell on its far side, which is free, not unseen.
  OccupancyGrid front{OccupancyGridOptions()};
  for (int k = 0; k < 20; ++k) front.InsertScan(sensor, wall, nullptr);
  for (int k = 0; k < 5; ++k) front.InsertScan(sensor, {{0.97, 0.02}}, nullptr);
  const GridGeometry& gf = front.geometry();
  const int in_front = gf.LinearIndex(gf.WorldToCell({0.97, 0.02}));
  ASSERT_EQ(CellState::kOccupied, front.State(in_front));
  ASSERT_LT(front.HitCount(in_front), 4);
  EXPECT_EQ(0, front.DropWeakOccupiedCells(0.2));
  // The grid takes hits as before: the dropped cell starts afresh.
  grid.InsertScan(sensor, {{1.09, 0.02}}, nullptr);
  EXPECT_EQ(CellState::kOccupied, grid.State(index(1.09, 0.02)));
  EXPECT_EQ(1, grid.HitCount(index(1.09, 0.02)));
}

// Pieces of structure: a wall 1 m long with a one-cell gap in it (one piece: cells two apart
// join), and a post of one cell 1 m away from it. With a minimum extent of 0.25 m the post goes
// (its diagonal is 0.07 m) and the whole wall, gap and all, stays.
TEST(OccupancyGridTest, ForgetCellsMakesObservedCellsUnknownAndCountsThem) {
  OccupancyGrid grid{OccupancyGridOptions()};
  std::vector<Eigen::Vector2d> points;
  for (double y = -0.5; y <= 0.5; y += 0.01) points.push_back({1.02, y});
  grid.InsertScan(Eigen::Vector2d::Zero(), points, nullptr);
  const GridGeometry& g = grid.geometry();
  const CellIndex wall = g.WorldToCell({1.02, 0.0}), free_cell = g.WorldToCell({0.5, 0.0}),
                  unknown = g.WorldToCell({-0.5, 0.3}), outside{-100000, 5};
  ASSERT_EQ(CellState::kOccupied, grid.State(wall));
  ASSERT_EQ(CellState::kFree, grid.State(free_cell));
  ASSERT_EQ(CellState::kUnknown, grid.State(unknown));
  // Unknown and outside cells are skipped, not counted; the observed ones forget everything.
  EXPECT_EQ(2, grid.ForgetCells({wall, free_cell, unknown, outside}));
  EXPECT_EQ(CellState::kUnknown, grid.State(wall));
  EXPECT_EQ(CellState::kUnknown, grid.State(free_cell));
  EXPECT_EQ(0, grid.HitCount(g.LinearIndex(wall)));
  EXPECT_EQ(CellState::kOccupied, grid.State(g.WorldToCell({1.02, 0.2})));  // the rest of the wall stays
  EXPECT_EQ(0, grid.ForgetCells({wall}));
}

TEST(OccupancyGridTest, DropSmallOccupiedPiecesKeepsWallsAndDropsPosts) {
  OccupancyGrid grid{OccupancyGridOptions()};
  const Eigen::Vector2d sensor(0.0, 0.0);
  std::vector<Eigen::Vector2d> points;
  for (double y = -0.5; y <= 0.5; y += 0.01) {
    if (y < 0.05 || y > 0.1) points.push_back({1.02, y});  // a gap of one cell at y in [0.05, 0.1)
  }
  points.push_back({0.02, 1.02});  // the post
  grid.InsertScan(sensor, points, nullptr);
  const GridGeometry& g = grid.geometry();
  auto state = [&](double x, double y) { return grid.State(g.LinearIndex(g.WorldToCell({x, y}))); };
  ASSERT_EQ(CellState::kOccupied, state(0.02, 1.02));
  ASSERT_NE(CellState::kOccupied, state(1.02, 0.07));

  EXPECT_EQ(0, grid.DropSmallOccupiedPieces(0.0, 2));  // 0 keeps every piece
  EXPECT_EQ(1, grid.DropSmallOccupiedPieces(0.25, 2));
  EXPECT_EQ(CellState::kUnknown, state(0.02, 1.02));
  for (double y = -0.45; y <= 0.45; y += 0.05) {
    if (y < 0.04 || y > 0.11) {
      EXPECT_EQ(CellState::kOccupied, state(1.02, y)) << "wall cell at y = " << y;
    }
  }
  // Without the link across the gap the wall is two pieces of about 0.5 m: both still stay; at
  // 0.6 m both go.
  EXPECT_EQ(0, grid.DropSmallOccupiedPieces(0.25, 1));
  int wall_cells = 0;
  for (int i = 0; i < g.width() * g.height(); ++i) wall_cells += grid.IsOccupied(i) ? 1 : 0;
  EXPECT_GE(wall_cells, 19);
  EXPECT_EQ(wall_cells, grid.DropSmallOccupiedPieces(0.6, 1));
  EXPECT_EQ(CellState::kUnknown, state(1.02, 0.0));
  EXPECT_EQ(CellState::kUnknown, state(1.02, 0.3));
}

TEST(OccupancyGridTest, ResolutionOutsideItsRangeIsInvalid) {
  OccupancyGridOptions options;
  options.resolution_meters = 1e-4;
  EXPECT_FALSE(options.IsValid(nullptr));
  options.resolution_meters = 0.05;
  EXPECT_TRUE(options.IsValid(nullptr));
}

}  // namespace
}  // namespace hetslam
