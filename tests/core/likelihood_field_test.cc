#include "core/likelihood_field.h"

#include <array>
#include <random>

#include "core/laser_map.h"
#include "core/occupancy_grid.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

// A 20 x 20 cell world (5 cm cells) with one wall along x = 0.5 m seen from the origin.
TEST(LikelihoodFieldTest, OneWallByHand) {
  LikelihoodFieldOptions field_options;
  field_options.sigma_meters = 0.05;
  field_options.max_distance_meters = 0.3;
  LaserMap map(OccupancyGridOptions(), field_options);
  std::vector<Eigen::Vector2f> wall;
  for (int i = -5; i <= 5; ++i) wall.emplace_back(0.5125f, i * 0.05f + 0.025f);
  map.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall);

  const GridGeometry& g = map.grid().geometry();
  const CellIndex wall_cell = g.WorldToCell({0.5125, 0.025});
  EXPECT_EQ(CellState::kOccupied, map.grid().State(wall_cell));
  const CellIndex free_cell = g.WorldToCell({0.2, 0.0});
  EXPECT_EQ(CellState::kFree, map.grid().State(free_cell));
  EXPECT_EQ(CellState::kUnknown, map.grid().State(g.WorldToCell({-0.5, 0.0})));
  // Cell centre of the wall cell is 0.025 - 0.0125 m... hit point (0.5125, 0.025) lies
  // 0.0125 m from its cell centre in x.
  const Eigen::Vector2d centre = g.CellCenter(wall_cell);
  const double d = (centre - Eigen::Vector2d(0.5125, 0.025)).norm();
  EXPECT_NEAR(std::exp(-d / 0.05), map.field().Value(wall_cell), 1e-5);
  // Three cells in front of the wall: distance from that centre to the nearest hit point.
  const CellIndex front{wall_cell.x - 3, wall_cell.y};
  const double d_front = std::abs(g.CellCenter(front).x() - 0.5125);
  EXPECT_NEAR(std::exp(-d_front / 0.05), map.field().Value(front), 1e-5);
  // Outside the window: zero.
  EXPECT_EQ(0.f, map.field().Value(CellIndex{wall_cell.x - 8, wall_cell.y}));
  // The observed box spans exactly the sensor cell to the wall cells.
  const CellIndex sensor_cell = g.WorldToCell({0.0, 0.0});
  EXPECT_EQ(sensor_cell.x, map.grid().observed_min().x);
  EXPECT_EQ(wall_cell.x, map.grid().observed_max().x);
  EXPECT_EQ(g.WorldToCell({0.5125, -0.225}).y, map.grid().observed_min().y);
  EXPECT_EQ(g.WorldToCell({0.5125, 0.275}).y, map.grid().observed_max().y);
}

// Seeded random insertions (including cells that turn free again) keep the incremental table
// identical to a brute-force rebuild from the same published hit points.
// With surfaces (lines through neighbouring hits) as well: the structure's 40 points form a line.
class LikelihoodFieldUpdateTest : public ::testing::TestWithParam<double> {};

TEST_P(LikelihoodFieldUpdateTest, IncrementalMatchesBruteForceOnRandomUpdates) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-3.f, 3.f);
  std::uniform_real_distribution<double> pose_xy(-1.0, 1.0), pose_th(-M_PI, M_PI);
  LikelihoodFieldOptions field_options;
  field_options.republish_distance_meters = 0.01;
  field_options.lines.max_gap_meters = GetParam();
  OccupancyGridOptions grid_options;
  grid_options.growth_step_meters = 0.5;  // grow often, to exercise Resize
  LaserMap map(grid_options, field_options);
  int turned_free = 0;
  for (int scan = 0; scan < 60; ++scan) {
    // World positions of the occupied cells before this scan.
    std::vector<Eigen::Vector2d> occupied_before;
    for (int i = 0; i < map.grid().geometry().num_cells(); ++i) {
      if (map.grid().IsOccupied(i)) {
        occupied_before.push_back(map.grid().geometry().CellCenter(map.grid().geometry().FromLinearIndex(i)));
      }
    }
    std::vector<Eigen::Vector2f> points;
    // A few persistent structures plus random clutter that later rays clear again.
    for (int i = 0; i < 40; ++i) points.emplace_back(coord(rng), coord(rng));
    for (int i = 0; i < 40; ++i) points.emplace_back(3.2f, -2.f + 0.1f * i);
    map.InsertScan(Pose2(pose_xy(rng), pose_xy(rng), pose_th(rng)), Eigen::Vector2d::Zero(), points);

    LikelihoodField reference = map.field();
    reference.RebuildAll();
    const std::vector<float> expected = reference.values().Dense(), actual = map.field().values().Dense();
    ASSERT_EQ(expected.size(), actual.size());
    for (size_t i = 0; i < expected.size(); ++i) {
      ASSERT_EQ(expected[i], actual[i]) << "scan " << scan << " cell " << i;
    }
    for (const Eigen::Vector2d& p : occupied_before) {
      turned_free += map.grid().State(map.grid().geometry().WorldToCell(p)) == CellState::kFree;
    }
  }
  // Cells must have turned free after being occupied, or the decrease path went untested.
  EXPECT_GT(turned_free, 50);
  if (GetParam() > 0) {
    EXPECT_TRUE(map.grid().has_lines());
  }
}

INSTANTIATE_TEST_SUITE_P(PointsAndSurfaces, LikelihoodFieldUpdateTest, ::testing::Values(0.0, 0.5));

// Paper §III-E: a map that keeps a wall field holds, next to its likelihood field, the field
// of the wall cells alone (cells hit across a height span). By hand: a wall at x = 1 m hit at
// 0.2 m and 0.6 m (span 0.4 m >= 0.3 m) and a box face at x = 1.5 m hit at 0.2 m only; the
// window is 0.3 m, so the box lies outside the wall's window.
TEST(LikelihoodFieldTest, WallFieldIsTheFieldOfTheWallCellsAlone) {
  LaserMap map(OccupancyGridOptions(), LikelihoodFieldOptions(), /*keep_wall_field=*/true);
  std::vector<Eigen::Vector2f> wall, box;
  for (int i = -6; i <= 6; ++i) {
    wall.emplace_back(1.025f, i * 0.05f + 0.025f);
    box.emplace_back(1.525f, i * 0.05f + 0.025f);
  }
  const std::vector<float> low(wall.size(), 0.2f), high(wall.size(), 0.6f);
  map.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), box, nullptr, &low);
  // Labels but no wall yet: no wall field (nothing to hold).
  EXPECT_EQ(nullptr, map.wall_field());
  map.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall, nullptr, &low);
  EXPECT_EQ(nullptr, map.wall_field());
  map.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall, nullptr, &high);
  ASSERT_NE(nullptr, map.wall_field());
  const LikelihoodField& walls = *map.wall_field();
  const GridGeometry& g = map.grid().geometry();
  EXPECT_EQ(g.origin(), walls.geometry().origin());
  EXPECT_EQ(g.num_cells(), walls.geometry().num_cells());
  const CellIndex wall_cell = g.WorldToCell({1.025, 0.025});
  const CellIndex box_cell = g.WorldToCell({1.525, 0.025});
  ASSERT_TRUE(map.grid().LabelMask(g.LinearIndex(wall_cell)) & (1u << OccupancyGrid::kWallLabelBit));
  ASSERT_FALSE(map.grid().LabelMask(g.LinearIndex(box_cell)) & (1u << OccupancyGrid::kWallLabelBit));
  // On the wall and in front of it both fields agree (the wall is the nearest surface).
  EXPECT_NEAR(1.f, walls.Value(wall_cell), 1e-5);
  EXPECT_FLOAT_EQ(map.field().Value(wall_cell), walls.Value(wall_cell));
  EXPECT_FLOAT_EQ(map.field().Value(CellIndex{wall_cell.x - 3, wall_cell.y}),
                  walls.Value(CellIndex{wall_cell.x - 3, wall_cell.y}));
  // The box is structure (field 1 on it) but not a wall.
  EXPECT_NEAR(1.f, map.field().Value(box_cell), 1e-5);
  EXPECT_EQ(0.f, walls.Value(box_cell));
  // Frozen together, on the same box.
  LaserMap frozen = map;
  frozen.Freeze();
  ASSERT_NE(nullptr, frozen.wall_field());
  EXPECT_TRUE(frozen.wall_field()->frozen());
  EXPECT_EQ(frozen.field().geometry().origin(), frozen.wall_field()->geometry().origin());
  const GridGeometry& f = frozen.grid().geometry();
  // On the wall d = 0: code 255, value 1 exactly.
  EXPECT_NEAR(walls.Value(wall_cell), frozen.wall_field()->Value(f.WorldToCell({1.025, 0.025})), 1e-5);
  EXPECT_EQ(0.f, frozen.wall_field()->Value(f.WorldToCell({1.525, 0.025})));
}

// Without keep_wall_field, or without labels (a level scan, every CARMEN log), no wall field.
TEST(LikelihoodFieldTest, NoWallFieldWithoutTheOptionOrLabels) {
  std::vector<Eigen::Vector2f> wall;
  for (int i = -6; i <= 6; ++i) wall.emplace_back(1.025f, i * 0.05f + 0.025f);
  const std::vector<float> low(wall.size(), 0.2f), high(wall.size(), 0.6f);
  LaserMap without_option{OccupancyGridOptions(), LikelihoodFieldOptions()};
  without_option.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall, nullptr, &low);
  without_option.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall, nullptr, &high);
  EXPECT_EQ(nullptr, without_option.wall_field());
  LaserMap without_labels(OccupancyGridOptions(), LikelihoodFieldOptions(), /*keep_wall_field=*/true);
  without_labels.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall);
  without_labels.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall);
  EXPECT_EQ(nullptr, without_labels.wall_field());
}

// The wall field is exact under incremental updates: on seeded random scans with random hit
// heights (cells turning wall, and cells turning free again), it equals a field of the wall
// cells rebuilt from scratch.
TEST(LikelihoodFieldTest, WallFieldIncrementalMatchesRebuildOnRandomUpdates) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> coord(-3.f, 3.f), height(0.1f, 1.0f);
  std::uniform_real_distribution<double> pose_xy(-1.0, 1.0), pose_th(-M_PI, M_PI);
  LikelihoodFieldOptions field_options;
  // Every moved hit point republished: the field then equals one built from the grid's
  // current hit points of its wall cells (which cells are walls is what is tested here).
  field_options.republish_distance_meters = 0.0;
  OccupancyGridOptions grid_options;
  grid_options.growth_step_meters = 0.5;  // grow often, to exercise Resize
  LaserMap map(grid_options, field_options, /*keep_wall_field=*/true);
  constexpr uint8_t kWall = 1u << OccupancyGrid::kWallLabelBit;
  int wall_cells = 0;
  for (int scan = 0; scan < 40; ++scan) {
    std::vector<Eigen::Vector2f> points;
    std::vector<float> heights;
    for (int i = 0; i < 40; ++i) {
      points.emplace_back(coord(rng), coord(rng));
      heights.push_back(height(rng));
    }
    for (int i = 0; i < 40; ++i) {
      points.emplace_back(3.2f, -2.f + 0.1f * i);
      heights.push_back(height(rng));
    }
    map.InsertScan(Pose2(pose_xy(rng), pose_xy(rng), pose_th(rng)), Eigen::Vector2d::Zero(), points, nullptr, &heights);
    if (map.wall_field() == nullptr) continue;
    LikelihoodField reference(field_options, kWall);
    reference.RebuildFrom(map.grid());
    const std::vector<float> expected = reference.values().Dense(), actual = map.wall_field()->values().Dense();
    ASSERT_EQ(expected.size(), actual.size());
    wall_cells = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
      ASSERT_EQ(expected[i], actual[i]) << "scan " << scan << " cell " << i;
      wall_cells += map.wall_field()->IsSurface(map.grid(), static_cast<int>(i));
    }
  }
  ASSERT_NE(nullptr, map.wall_field());
  EXPECT_GT(wall_cells, 20);
}

// Freezing a finished map keeps what matching reads: cell states and likelihood values at every
// world position, over a box cropped to the observed cells (plus the window), and frees the rest.
TEST(LikelihoodFieldTest, FreezeKeepsStatesAndValues) {
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  std::vector<Eigen::Vector2f> wall;
  for (int i = -20; i <= 20; ++i) wall.emplace_back(1.0f, i * 0.05f);
  map.InsertScan(Pose2(0.1, 0.2, 0.3), Eigen::Vector2d::Zero(), wall);
  const GridGeometry before = map.grid().geometry();
  const std::vector<float> values = map.field().values().Dense();
  std::vector<CellState> states;
  for (int i = 0; i < before.num_cells(); ++i) states.push_back(map.grid().State(i));
  const size_t bytes_before = map.MemoryBytes();
  map.Freeze();
  const LikelihoodField::FrozenCodes& codes = map.field().frozen_codes();
  const double sigma = map.field().options().sigma_meters, step = codes.distance_step_meters;
  const double cap = map.field().window_radius_cells() * map.field().geometry().resolution_meters();
  EXPECT_NEAR(0.3 / 254 * (6.5 / 6) * std::sqrt(2.0), step, 1e-9);  // the window's corner over 254 steps
  EXPECT_TRUE(map.grid().frozen());
  EXPECT_TRUE(map.field().frozen());
  EXPECT_EQ(0, map.field().values().width());
  EXPECT_EQ(0, map.field().values().num_allocated_tiles());
  const GridGeometry& after = map.grid().geometry();
  // The 2 m wall seen from 1 m fits in a few metres; the grid had its growth slack around it.
  EXPECT_LT(after.num_cells(), before.num_cells() / 2);
  EXPECT_EQ(after.origin(), map.field().geometry().origin());
  // The layers being built are tiled already (core/tiled_index.h); freezing still drops the
  // squared distances, published segments, hit accumulators and float log-odds.
  EXPECT_LT(map.MemoryBytes(), bytes_before / 5);
  int kept = 0;
  for (int y = 0; y < before.height(); ++y) {
    for (int x = 0; x < before.width(); ++x) {
      const Eigen::Vector2d centre = before.CellCenter({x, y});
      const int i = before.LinearIndex({x, y});
      ASSERT_EQ(states[i], map.grid().StateAt(centre)) << "cell " << x << ", " << y;
      // The distance rounded to the nearest step (the value exp(-d / sigma) then within
      // value * half a step / sigma); a surface in the window stays a surface (not 0); the
      // refinement's squared distance is that distance, capped at the window radius.
      const CellIndex at = after.WorldToCell(centre);
      const float frozen_value = map.field().Value(at);
      ASSERT_NEAR(values[i], frozen_value, values[i] * 0.5 * step / sigma * 1.01 + 1e-6) << "cell " << x << ", " << y;
      ASSERT_EQ(values[i] == 0.f, frozen_value == 0.f) << "cell " << x << ", " << y;
      if (values[i] > 0.f && after.Contains(at)) {
        const double d = std::min(-sigma * std::log(static_cast<double>(values[i])), cap);
        ASSERT_NEAR(d, std::sqrt(codes.squared_distance[map.field().FrozenCode(at.x, at.y)]), 0.5 * step + 1e-5)
            << "cell " << x << ", " << y;
      }
      kept += after.Contains(after.WorldToCell(centre));
    }
  }
  EXPECT_EQ(after.num_cells(), kept);  // the crop is on the same lattice
  // The border stays 0, as the scan cost's nearest-border extrapolation assumes.
  for (int x = 0; x < after.width(); ++x) {
    EXPECT_EQ(0.f, map.field().Value(CellIndex{x, 0}));
    EXPECT_EQ(0.f, map.field().Value(CellIndex{x, after.height() - 1}));
  }
  EXPECT_EQ(CellState::kUnknown, map.grid().StateAt(Eigen::Vector2d(100.0, -100.0)));
  map.Freeze();  // idempotent
  EXPECT_EQ(after.num_cells(), map.grid().geometry().num_cells());
  EXPECT_DEATH(map.InsertScan(Pose2(), Eigen::Vector2d::Zero(), wall), "frozen");
  EXPECT_DEATH(map.grid().LogOdds(0), "frozen");
}

// ValuesBlock gives Value of every cell of the block, before and after Freeze, for blocks
// inside the grid, across its edges and wholly outside it (0 there), of widths that start and
// end inside tiles and across them.
TEST(LikelihoodFieldTest, ValuesBlockIsTheValueOfEachCell) {
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  std::vector<Eigen::Vector2f> wall;
  for (int i = -20; i <= 20; ++i) wall.emplace_back(1.0f, i * 0.05f);
  map.InsertScan(Pose2(0.1, 0.2, 0.3), Eigen::Vector2d::Zero(), wall);
  for (const bool frozen : {false, true}) {
    if (frozen) map.Freeze();
    const LikelihoodField& field = map.field();
    const int width = field.geometry().width(), height = field.geometry().height();
    int nonzero = 0;
    for (const auto& [x0, y0, w, h] : {std::array<int, 4>{0, 0, width, height}, std::array<int, 4>{-5, -3, 14, 14},
                                      std::array<int, 4>{width - 9, height / 2 - 7, 14, 14},
                                      std::array<int, 4>{width / 2 - 7, height / 2 - 7, 15, 13},
                                      std::array<int, 4>{width / 2 + 3, height / 2 + 1, 1, 1},
                                      std::array<int, 4>{width + 4, -20, 6, 5}}) {
      std::vector<float> block(static_cast<size_t>(w) * h, -1.f);
      field.ValuesBlock(x0, y0, w, h, block.data());
      for (int y = y0; y < y0 + h; ++y) {
        for (int x = x0; x < x0 + w; ++x) {
          const float value = block[static_cast<size_t>(y - y0) * w + (x - x0)];
          ASSERT_EQ(field.Value(CellIndex{x, y}), value) << (frozen ? "frozen " : "") << x << ", " << y;
          nonzero += value != 0.f;
        }
      }
    }
    EXPECT_GT(nonzero, 100) << "the blocks must see the wall";
  }
}

// MayBeNonZeroNear (issue #15: loop searches that cannot reach a score are skipped) is sound:
// true whenever some cell within the radius holds a value, checked by brute force at cells in,
// around and far outside the grid; and tight to the 8 × 8 tile: false whenever no cell within
// the radius plus two tiles does (for cells inside the grid; outside it the test is looser).
// Before Freeze it is always true.
TEST(LikelihoodFieldTest, MayBeNonZeroNearAgreesWithABruteForceSearch) {
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  std::vector<Eigen::Vector2f> points;
  for (int i = -20; i <= 20; ++i) points.emplace_back(1.0f, i * 0.05f);  // a 2 m wall
  points.emplace_back(-2.0f, 1.5f);                                       // and a post
  map.InsertScan(Pose2(0.1, 0.2, 0.3), Eigen::Vector2d::Zero(), points);
  EXPECT_TRUE(map.field().MayBeNonZeroNear(CellIndex{-1000, -1000}, 0));  // not frozen yet
  map.Freeze();
  const LikelihoodField& field = map.field();
  const GridGeometry& g = field.geometry();
  auto any_within = [&](const CellIndex& c, int r) {
    for (int y = std::max(0, c.y - r); y <= std::min(g.height() - 1, c.y + r); ++y) {
      for (int x = std::max(0, c.x - r); x <= std::min(g.width() - 1, c.x + r); ++x) {
        if (field.Value(CellIndex{x, y}) > 0.f) return true;
      }
    }
    return false;
  };
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> x(-30, g.width() + 30), y(-30, g.height() + 30), radius(0, 24);
  int sound = 0, tight = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const CellIndex c{x(rng), y(rng)};
    const int r = radius(rng);
    const bool may = field.MayBeNonZeroNear(c, r);
    if (any_within(c, r)) {
      ASSERT_TRUE(may) << "cell " << c.x << ", " << c.y << " radius " << r;
      ++sound;
    }
    if (g.Contains(c) && !any_within(c, r + 2 * SparseTiles<uint8_t>::kTileSize)) {
      ASSERT_FALSE(may) << "cell " << c.x << ", " << c.y << " radius " << r;
      ++tight;
    }
  }
  EXPECT_GT(sound, 100);  // both sides were exercised
  EXPECT_GT(tight, 50);
  EXPECT_FALSE(field.MayBeNonZeroNear(CellIndex{-1000, -1000}, 10));
  EXPECT_TRUE(field.MayBeNonZeroNear(CellIndex{-1000, -1000}, 100000));
  LaserMap empty{OccupancyGridOptions(), LikelihoodFieldOptions()};
  empty.Freeze();
  EXPECT_FALSE(empty.field().MayBeNonZeroNear(CellIndex{0, 0}, 1000));
}

// An empty map freezes to an empty grid.
TEST(LikelihoodFieldTest, FreezeEmptyMap) {
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  map.Freeze();
  EXPECT_EQ(0, map.grid().geometry().num_cells());
  EXPECT_EQ(0, map.field().geometry().num_cells());
  EXPECT_EQ(CellState::kUnknown, map.grid().StateAt(Eigen::Vector2d::Zero()));
  EXPECT_EQ(0.f, map.field().Value(CellIndex{0, 0}));
}

}  // namespace
}  // namespace hetslam
