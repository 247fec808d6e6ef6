// The true map layers of a simulated world: which object goes to which layer (the floor-obstacle
// height rule), which cells a wall or an outline marks, and the files a team dataset carries.
#include "datasets/sim/truth_layers.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/map_layers.h"
#include "datasets/sim/robot_spec.h"
#include "datasets/sim/team_simulator.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

using ::testing::HasSubstr;

using CellSet = std::set<std::pair<int, int>>;

CellSet OccupiedCells(const GridLayer& layer) {
  CellSet cells;
  for (int y = 0; y < layer.geometry.height(); ++y) {
    for (int x = 0; x < layer.geometry.width(); ++x) {
      if (layer.at({x, y}) == CellState::kOccupied) cells.insert({x, y});
    }
  }
  return cells;
}

// 10 cm cells and no border: lattice coordinates are world decimetres, so every expected cell
// below can be read off the coordinates.
TruthLayerOptions DecimetreOptions() {
  TruthLayerOptions options;
  options.resolution_meters = 0.1;
  options.border_cells = 0;
  return options;
}

TruthLayerMaps Rasterize(const World& world, const TruthLayerOptions& options) {
  TruthLayerMaps maps;
  const Status status = RasterizeTruthLayers(world, options, &maps);
  EXPECT_TRUE(status.ok()) << status.message();
  return maps;
}

// A wall along the bottom row, an 80 cm tall box (furniture) with its sides on grid lines and
// a 20 cm tall obstacle (a floor obstacle) inside cells.
TEST(TruthLayersTest, WallBoxAndLowObstacleGoToTheirLayersOnTheExpectedCells) {
  World world;
  world.AddWall(Eigen::Vector2d(0.05, 0.05), Eigen::Vector2d(0.95, 0.05));
  world.AddBoxPrism(Eigen::Vector2d(0.5, 0.5), Eigen::Vector2d(0.4, 0.2), 0.0, 0.0, 0.8,
                    Surface::kFurniture);
  world.AddBoxPrism(Eigen::Vector2d(0.2, 0.8), Eigen::Vector2d(0.1, 0.1), 0.0, 0.0, 0.2,
                    Surface::kObstacle);
  const TruthLayerMaps maps = Rasterize(world, DecimetreOptions());

  // One grid: from the wall's start cell (0, 0) to the obstacle's top-right cell (row 8) and
  // the wall's end cell (column 9).
  const GridGeometry& g = maps.walls.geometry;
  EXPECT_NEAR(0.0, g.origin().x(), 1e-12);
  EXPECT_NEAR(0.0, g.origin().y(), 1e-12);
  EXPECT_EQ(10, g.width());
  EXPECT_EQ(9, g.height());
  for (const GridLayer* layer : {&maps.furniture, &maps.floor_obstacles}) {
    EXPECT_EQ(g.width(), layer->geometry.width());
    EXPECT_EQ(g.height(), layer->geometry.height());
    EXPECT_EQ(g.origin(), layer->geometry.origin());
  }

  // The wall: y = 0.05 is row 0, x from 0.05 to 0.95 covers columns 0..9.
  CellSet walls;
  for (int x = 0; x <= 9; ++x) walls.insert({x, 0});
  EXPECT_EQ(walls, OccupiedCells(maps.walls));

  // The box outline: corners (0.3, 0.4) and (0.7, 0.6) on grid lines. A line on a grid line
  // belongs to the cells above / to the right of it (half-open cells), so the left and bottom
  // sides mark column 3 and row 4, the right and top sides column 7 and row 6.
  CellSet furniture;
  for (int x = 3; x <= 7; ++x) {
    furniture.insert({x, 4});
    furniture.insert({x, 6});
  }
  furniture.insert({3, 5});
  furniture.insert({7, 5});
  EXPECT_EQ(furniture, OccupiedCells(maps.furniture));

  // The obstacle: corners (0.15, 0.75) and (0.25, 0.85), inside cells: columns 1..2, rows 7..8.
  const CellSet floor_obstacles = {{1, 7}, {2, 7}, {1, 8}, {2, 8}};
  EXPECT_EQ(floor_obstacles, OccupiedCells(maps.floor_obstacles));

  // The box's interior (cell centres strictly inside, off the outline) is unknown: occupied by
  // the box, seen only from above. Every other cell is free: the truth is known everywhere.
  CellSet interior;
  for (int y = 0; y < g.height(); ++y) {
    for (int x = 0; x < g.width(); ++x) {
      if (maps.furniture.at({x, y}) == CellState::kUnknown) interior.insert({x, y});
    }
  }
  EXPECT_EQ(CellSet({{4, 5}, {5, 5}, {6, 5}}), interior);
  EXPECT_EQ(0, maps.walls.CountCells(CellState::kUnknown));
  EXPECT_EQ(0, maps.floor_obstacles.CountCells(CellState::kUnknown));  // all outline
}

TEST(TruthLayersTest, FloorObstacleRuleIsTheTopHeightAgainstH) {
  const TruthLayerOptions options;
  // H is the humanoid's level laser height: lower objects reach its map only through tilted scans.
  EXPECT_DOUBLE_EQ(DefaultRobotSpec("nao", RobotKind::kHumanoid).body_T_laser.translation().z(),
                   options.floor_obstacle_max_height_meters);
  Prism prism;
  prism.footprint = {{0, 0}, {1, 0}, {1, 1}};
  prism.z_max_meters = 0.499;
  EXPECT_EQ(TruthLayer::kFloorObstacles, ClassifyPrism(prism, options));
  prism.z_max_meters = 0.5;  // as tall as H: a level laser at H touches its top
  EXPECT_EQ(TruthLayer::kFurniture, ClassifyPrism(prism, options));
  // By height, not by kind: a tall "obstacle" is furniture.
  prism.surface = Surface::kObstacle;
  prism.z_max_meters = 0.9;
  EXPECT_EQ(TruthLayer::kFurniture, ClassifyPrism(prism, options));
  EXPECT_STREQ("walls", TruthLayerName(TruthLayer::kWalls));
  EXPECT_STREQ("furniture", TruthLayerName(TruthLayer::kFurniture));
  EXPECT_STREQ("floor_obstacles", TruthLayerName(TruthLayer::kFloorObstacles));
}

TEST(TruthLayersTest, TablePartsAreClassifiedEachByItsOwnTop) {
  // A 0.74 m table: top and legs (0.70 m) are furniture. A 0.45 m coffee table: all of it is
  // below H, a floor obstacle.
  for (const double height : {0.74, 0.45}) {
    SCOPED_TRACE(height);
    World world;
    world.AddTable(Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(1.2, 0.8), 0.0, height);
    const TruthLayerMaps maps = Rasterize(world, TruthLayerOptions());
    const bool tall = height >= 0.5;
    EXPECT_EQ(tall, maps.furniture.CountCells(CellState::kOccupied) > 0);
    EXPECT_EQ(!tall, maps.floor_obstacles.CountCells(CellState::kOccupied) > 0);
    EXPECT_EQ(0, maps.walls.CountCells(CellState::kOccupied));
  }
}

TEST(TruthLayersTest, DiagonalThroughCornersStepsDiagonally) {
  World world;
  world.AddWall(Eigen::Vector2d(0.05, 0.05), Eigen::Vector2d(0.35, 0.35));
  const TruthLayerMaps maps = Rasterize(world, DecimetreOptions());
  const CellSet expected = {{0, 0}, {1, 1}, {2, 2}, {3, 3}};
  EXPECT_EQ(expected, OccupiedCells(maps.walls));
}

// Against brute force: the cells of dense samples along random segments are all marked, and
// nothing more is marked than the |dx| + |dy| + 1 cells a segment without corner crossings
// passes through.
TEST(TruthLayersTest, SegmentCellsMatchDenseSamplingOnRandomSegments) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> coordinate(-2.0, 2.0);
  const TruthLayerOptions options;  // 5 cm, border 5
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector2d a(coordinate(rng), coordinate(rng));
    const Eigen::Vector2d b(coordinate(rng), coordinate(rng));
    World world;
    world.AddWall(a, b);
    const TruthLayerMaps maps = Rasterize(world, options);
    const GridGeometry& g = maps.walls.geometry;
    const CellSet marked = OccupiedCells(maps.walls);
    CellSet sampled;
    const int samples = 20000;
    for (int k = 0; k <= samples; ++k) {
      const CellIndex c = g.WorldToCell(a + (b - a) * (static_cast<double>(k) / samples));
      sampled.insert({c.x, c.y});
    }
    const CellIndex ca = g.WorldToCell(a), cb = g.WorldToCell(b);
    ASSERT_TRUE(std::includes(marked.begin(), marked.end(), sampled.begin(), sampled.end()))
        << "trial " << trial;
    ASSERT_LE(marked.size(), static_cast<size_t>(std::abs(cb.x - ca.x) + std::abs(cb.y - ca.y) + 1))
        << "trial " << trial;
  }
}

TEST(TruthLayersTest, RejectsAnEmptyWorldAndBadOptions) {
  TruthLayerMaps maps;
  EXPECT_THAT(RasterizeTruthLayers(World(), TruthLayerOptions(), &maps).message(),
              HasSubstr("no wall and no prism"));
  World world;
  world.AddWall(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0));
  TruthLayerOptions options;
  options.floor_obstacle_max_height_meters = 0.0;
  EXPECT_THAT(RasterizeTruthLayers(world, options, &maps).message(),
              HasSubstr("floor_obstacle_max_height_meters"));
}

// A shipped scenario through the simulator: the dataset carries the three layers, they read
// back as written, the low box is a floor obstacle and the shelf and table are furniture.
TEST(TruthLayersTest, TeamDatasetCarriesTheLayersOfItsWorld) {
  Scenario scenario;
  const Status read = ReadScenarioFile(
      std::string(HETSLAM_SOURCE_DIR) + "/datasets/scenarios/humanoid_static_tilt.scenario",
      &scenario);
  ASSERT_TRUE(read.ok()) << read.message();
  TeamSimulatorOptions options;
  options.max_duration_seconds = 1.0;
  options.render_images = false;
  std::mt19937_64 rng(1);
  TeamSimulationResult result;
  ASSERT_TRUE(SimulateTeam(scenario, options, &rng, &result).ok());
  const std::string dir = testing::TempDir() + "/truth_layers_test_dataset";
  std::filesystem::remove_all(dir);
  TeamDatasetFiles files;
  const Status written = WriteTeamDataset(dir, scenario, result, options, {}, &files);
  ASSERT_TRUE(written.ok()) << written.message();
  EXPECT_EQ(dir + "/truth_layers", files.truth_layers_directory);
  ASSERT_EQ(6u, files.truth_layer_paths.size());

  TruthLayerMaps expected;
  ASSERT_TRUE(RasterizeTruthLayers(result.world, options.truth_layers, &expected).ok());
  for (const auto& [name, layer] : {std::make_pair("walls", &expected.walls),
                                    std::make_pair("furniture", &expected.furniture),
                                    std::make_pair("floor_obstacles", &expected.floor_obstacles)}) {
    SCOPED_TRACE(name);
    const std::string yaml = dir + "/truth_layers/" + name + ".yaml";
    EXPECT_TRUE(std::filesystem::exists(dir + "/truth_layers/" + name + ".pgm"));
    GridLayer read_back;
    const Status status = ReadMapPgmYaml(yaml, &read_back);
    ASSERT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(layer->geometry.width(), read_back.geometry.width());
    EXPECT_EQ(layer->geometry.height(), read_back.geometry.height());
    EXPECT_NEAR(0.0, (layer->geometry.origin() - read_back.geometry.origin()).norm(), 1e-9);
    EXPECT_TRUE(layer->cells == read_back.cells);
    EXPECT_GT(read_back.CountCells(CellState::kOccupied), 0);
  }
  // The room's walls run from x = 0 to 6 and y = 0 to 5: 121 cells per long wall and 101 per
  // short one (both end cells: an end on a grid line marks the cell it starts), corners shared.
  EXPECT_EQ(2 * 121 + 2 * 101 - 4, expected.walls.CountCells(CellState::kOccupied));
  // The 0.15 m box at (2.3, 2.5) is a floor obstacle; the shelf at y in [4.55, 5] and the
  // table around (3.5, 1.0) are furniture.
  const GridGeometry& g = expected.walls.geometry;
  auto occupied_near = [&g](const GridLayer& layer, const Eigen::Vector2d& p) {
    const CellIndex c = g.WorldToCell(p);
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (layer.at({c.x + dx, c.y + dy}) == CellState::kOccupied) return true;
      }
    }
    return false;
  };
  EXPECT_TRUE(occupied_near(expected.floor_obstacles, {2.15, 2.5}));  // the box's west side
  EXPECT_FALSE(occupied_near(expected.furniture, {2.15, 2.5}));
  EXPECT_TRUE(occupied_near(expected.furniture, {4.0, 4.55}));        // the shelf's front
  EXPECT_TRUE(occupied_near(expected.furniture, {2.9, 1.0}));         // the table top's west side
  EXPECT_FALSE(occupied_near(expected.floor_obstacles, {4.0, 4.55}));

  // The robot's seen layers: on the same grid, inside the true ones, not empty (the standing
  // robot sees the walls in front of it), and not all of them (it never sees behind itself
  // in one second).
  ASSERT_EQ(1u, result.robots.size());
  const std::string seen_dir = dir + "/" + result.robots[0].name + "/seen_layers";
  for (const auto& [name, layer] : {std::make_pair("walls", &expected.walls),
                                    std::make_pair("furniture", &expected.furniture),
                                    std::make_pair("floor_obstacles", &expected.floor_obstacles)}) {
    SCOPED_TRACE(name);
    GridLayer seen;
    const Status status = ReadMapPgmYaml(seen_dir + "/" + name + ".yaml", &seen);
    ASSERT_TRUE(status.ok()) << status.message();
    ASSERT_EQ(layer->cells.size(), seen.cells.size());
    for (size_t i = 0; i < seen.cells.size(); ++i) {
      if (seen.cells[i] == CellState::kOccupied) {
        ASSERT_EQ(CellState::kOccupied, layer->cells[i]) << i;
      }
    }
  }
  GridLayer seen_walls;
  ASSERT_TRUE(ReadMapPgmYaml(seen_dir + "/walls.yaml", &seen_walls).ok());
  EXPECT_GT(seen_walls.CountCells(CellState::kOccupied), 20);
  EXPECT_LT(seen_walls.CountCells(CellState::kOccupied), expected.walls.CountCells(CellState::kOccupied));
}

// A seen end point keeps the true cells of its layer within one cell of it, nothing else, and
// only in its own layer.
TEST(TruthLayersTest, SeenLayersKeepTheTrueCellsNearEndPointsOfTheirLayer) {
  World world;
  world.AddWall({0.0, 0.0}, {2.0, 0.0});
  world.AddBoxPrism({1.05, 1.05}, {0.2, 0.2}, 0.0, 0.0, 0.2, Surface::kObstacle);
  const TruthLayerOptions options = DecimetreOptions();
  const TruthLayerMaps maps = Rasterize(world, options);
  SeenCells seen;
  AddSeenPoint({0.55, 0.0}, TruthLayer::kWalls, options, &seen);           // wall cell (5, 0)
  AddSeenPoint({0.95, 1.05}, TruthLayer::kFloorObstacles, options, &seen);  // the box's west side
  AddSeenPoint({1.55, 0.0}, TruthLayer::kFurniture, options, &seen);       // no furniture there
  EXPECT_EQ(1u, seen.walls.size());
  const TruthLayerMaps kept = SeenTruthLayers(maps, seen);
  const GridGeometry& g = maps.walls.geometry;
  const Eigen::Vector2i offset(static_cast<int>(std::lround(g.origin().x() / 0.1)),
                               static_cast<int>(std::lround(g.origin().y() / 0.1)));
  CellSet walls;
  for (const auto& [x, y] : OccupiedCells(kept.walls)) walls.insert({x + offset.x(), y + offset.y()});
  EXPECT_EQ(CellSet({{4, 0}, {5, 0}, {6, 0}}), walls);
  EXPECT_EQ(0, kept.furniture.CountCells(CellState::kOccupied));
  const CellSet obstacles = OccupiedCells(kept.floor_obstacles);
  EXPECT_FALSE(obstacles.empty());
  for (const auto& [x, y] : obstacles) EXPECT_LE(x + offset.x(), 10);  // the west side and its corners
  EXPECT_LT(obstacles.size(), OccupiedCells(maps.floor_obstacles).size());
}

}  // namespace
}  // namespace sim
}  // namespace hetslam
