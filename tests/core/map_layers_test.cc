// Scoring map layers: cell precision and recall with the one-cell tolerance, the alignment of a
// run's map frame to the world, and the run-folder / truth-folder conventions.
#include "core/map_layers.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "core/trajectory_metrics.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

// An empty (all free) 40 x 30 layer of 5 cm cells with its minimum corner at `origin`.
GridLayer EmptyLayer(const Eigen::Vector2d& origin = Eigen::Vector2d::Zero()) {
  return GridLayer::Filled(GridGeometry(origin, 0.05, 40, 30), CellState::kFree);
}

// Row `y` occupied from column x0 to x1.
void MarkRow(GridLayer* layer, int y, int x0, int x1) {
  for (int x = x0; x <= x1; ++x) layer->set({x, y}, CellState::kOccupied);
}

TEST(ScoreLayerTest, IdenticalLayersScoreOne) {
  GridLayer truth = EmptyLayer();
  MarkRow(&truth, 10, 5, 14);
  const LayerScore score = ScoreLayer(truth, Pose2(), truth, LayerScoreOptions());
  EXPECT_EQ(10, score.run_occupied_cells);
  EXPECT_EQ(10, score.run_correct_cells);
  EXPECT_EQ(10, score.truth_occupied_cells);
  EXPECT_EQ(10, score.truth_found_cells);
  EXPECT_DOUBLE_EQ(1.0, score.precision());
  EXPECT_DOUBLE_EQ(1.0, score.recall());
}

TEST(ScoreLayerTest, OneCellOffIsWithinToleranceTwoCellsAreNot) {
  GridLayer truth = EmptyLayer();
  MarkRow(&truth, 10, 5, 14);
  GridLayer one_off = EmptyLayer();
  MarkRow(&one_off, 11, 6, 15);  // one cell up and one to the right: diagonal neighbours
  LayerScoreOptions options;
  LayerScore score = ScoreLayer(one_off, Pose2(), truth, options);
  EXPECT_DOUBLE_EQ(1.0, score.precision());
  EXPECT_DOUBLE_EQ(1.0, score.recall());
  // Without tolerance nothing matches: the rows differ.
  options.tolerance_cells = 0;
  score = ScoreLayer(one_off, Pose2(), truth, options);
  EXPECT_EQ(0, score.run_correct_cells);
  EXPECT_EQ(0, score.truth_found_cells);

  GridLayer two_off = EmptyLayer();
  MarkRow(&two_off, 12, 5, 14);
  score = ScoreLayer(two_off, Pose2(), truth, LayerScoreOptions());
  EXPECT_DOUBLE_EQ(0.0, score.precision());
  EXPECT_DOUBLE_EQ(0.0, score.recall());
  options.tolerance_cells = 2;
  score = ScoreLayer(two_off, Pose2(), truth, options);
  EXPECT_DOUBLE_EQ(1.0, score.precision());
}

TEST(ScoreLayerTest, ExtraCellsCostPrecisionMissingCellsCostRecall) {
  GridLayer truth = EmptyLayer();
  MarkRow(&truth, 10, 5, 24);  // 20 cells
  GridLayer run = EmptyLayer();
  MarkRow(&run, 10, 5, 14);    // the first half of the truth (the cell at 15 is found too)
  MarkRow(&run, 25, 30, 34);   // 5 phantom cells far from any truth cell
  const LayerScore score = ScoreLayer(run, Pose2(), truth, LayerScoreOptions());
  EXPECT_EQ(15, score.run_occupied_cells);
  EXPECT_EQ(10, score.run_correct_cells);
  EXPECT_DOUBLE_EQ(10.0 / 15.0, score.precision());
  // Truth cells 5..15 lie within one cell of a run cell (15 is next to 14): 11 of 20.
  EXPECT_EQ(20, score.truth_occupied_cells);
  EXPECT_EQ(11, score.truth_found_cells);
  EXPECT_DOUBLE_EQ(11.0 / 20.0, score.recall());
}

// A box seen from above: the run marks its top inside the true outline. Cells on the truth's
// unknown interior are correct; they are not asked for in recall; a unknown run cell is no
// evidence for anything.
TEST(ScoreLayerTest, CellsInsideATrueFootprintAreCorrectButNotRequired) {
  GridLayer truth = EmptyLayer();
  MarkRow(&truth, 10, 10, 19);
  MarkRow(&truth, 14, 10, 19);
  for (int y = 11; y <= 13; ++y) {
    truth.set({10, y}, CellState::kOccupied);
    truth.set({19, y}, CellState::kOccupied);
    for (int x = 11; x <= 18; ++x) truth.set({x, y}, CellState::kUnknown);
  }
  GridLayer run = EmptyLayer();
  MarkRow(&run, 10, 10, 19);  // the outline's near side
  MarkRow(&run, 12, 11, 18);  // the top's middle row, 2 cells from the outline
  run.set({25, 25}, CellState::kOccupied);  // wrong
  const LayerScore score = ScoreLayer(run, Pose2(), truth, LayerScoreOptions());
  EXPECT_EQ(19, score.run_occupied_cells);
  EXPECT_EQ(18, score.run_correct_cells);
  EXPECT_EQ(26, score.truth_occupied_cells);
  EXPECT_EQ(16, score.truth_found_cells);  // the near side and the sides; the far side is not seen
  GridLayer union_layer;
  ASSERT_TRUE(UnionOfLayers({EmptyLayer(), truth}, {"walls", "furniture"}, &union_layer).ok());
  EXPECT_EQ(24, union_layer.CountCells(CellState::kUnknown));
  EXPECT_EQ(26, union_layer.CountCells(CellState::kOccupied));
}

TEST(ScoreLayerTest, NothingToCountIsNan) {
  GridLayer truth = EmptyLayer();
  MarkRow(&truth, 10, 5, 14);
  const LayerScore empty_run = ScoreLayer(EmptyLayer(), Pose2(), truth, LayerScoreOptions());
  EXPECT_TRUE(std::isnan(empty_run.precision()));
  EXPECT_DOUBLE_EQ(0.0, empty_run.recall());
  const LayerScore empty_truth = ScoreLayer(truth, Pose2(), EmptyLayer(), LayerScoreOptions());
  EXPECT_DOUBLE_EQ(0.0, empty_truth.precision());
  EXPECT_TRUE(std::isnan(empty_truth.recall()));
}

TEST(ScoreLayerTest, ToleranceReachesAcrossTheOtherGridsEdge) {
  GridLayer truth = EmptyLayer();
  MarkRow(&truth, 10, 0, 39);
  GridLayer run = EmptyLayer(Eigen::Vector2d(1.0, 0.0));  // starts halfway along the truth
  MarkRow(&run, 10, 0, 39);
  const LayerScore score = ScoreLayer(run, Pose2(), truth, LayerScoreOptions());
  // Run columns 0..19 lie on truth columns 20..39; run column 20 falls just past the truth
  // grid, one cell from its last occupied cell; the rest are too far.
  EXPECT_EQ(40, score.run_occupied_cells);
  EXPECT_EQ(21, score.run_correct_cells);
  EXPECT_EQ(21, score.truth_found_cells);  // truth columns 19..39 likewise
}

// The room's wall points: a 1.6 m x 1.1 m rectangle every millimetre.
std::vector<Eigen::Vector2d> RoomPointsWorld() {
  std::vector<Eigen::Vector2d> points;
  const Eigen::Vector2d lo(0.33, 0.27), hi(1.93, 1.37);
  for (double s = 0.0; s <= 1.0; s += 1e-3) {
    points.emplace_back(lo.x() + s * (hi.x() - lo.x()), lo.y());
    points.emplace_back(lo.x() + s * (hi.x() - lo.x()), hi.y());
    points.emplace_back(lo.x(), lo.y() + s * (hi.y() - lo.y()));
    points.emplace_back(hi.x(), lo.y() + s * (hi.y() - lo.y()));
  }
  return points;
}

// Every cell holding one of `points` is occupied.
GridLayer LayerOfPoints(const GridGeometry& geometry, const std::vector<Eigen::Vector2d>& points) {
  GridLayer layer = GridLayer::Filled(geometry, CellState::kFree);
  for (const Eigen::Vector2d& p : points) {
    const CellIndex c = geometry.WorldToCell(p);
    EXPECT_TRUE(geometry.Contains(c)) << p.transpose();
    layer.set(c, CellState::kOccupied);
  }
  return layer;
}

// A run maps the room in its own frame (the robot's start pose, here rotated by 37° and moved)
// and drives a loop; aligning its trajectory to the truth finds world_T_map, and the map then
// scores 1.0, as it must: every run cell holds a point of a wall, and so does a truth cell.
TEST(ScoreLayerTest, RotatedAndTranslatedMapScoresOneAfterAlignment) {
  const Pose2 world_T_map(1.1, -0.4, 37.0 * M_PI / 180.0);
  const std::vector<Eigen::Vector2d> points_world = RoomPointsWorld();
  std::vector<Eigen::Vector2d> points_map;
  for (const Eigen::Vector2d& p : points_world) points_map.push_back(world_T_map.inverse() * p);
  const GridLayer truth =
      LayerOfPoints(GridGeometry(Eigen::Vector2d(0.0, 0.0), 0.05, 46, 34), points_world);
  const GridLayer run =
      LayerOfPoints(GridGeometry(Eigen::Vector2d(-2.0, -2.0), 0.05, 80, 80), points_map);

  std::vector<StampedPose2> truth_trajectory, run_trajectory;
  for (int k = 0; k < 40; ++k) {
    const double a = 2.0 * M_PI * k / 40;
    const Pose2 world_T_robot(1.1 + 0.4 * std::cos(a), 0.8 + 0.3 * std::sin(a), a + M_PI / 2);
    truth_trajectory.push_back({0.1 * k, world_T_robot});
    run_trajectory.push_back({0.1 * k, world_T_map.inverse() * world_T_robot});
  }
  const TrajectoryAlignment alignment = AlignTrajectory(run_trajectory, truth_trajectory);
  ASSERT_EQ(40, alignment.matched);
  EXPECT_FALSE(alignment.rotation_from_headings);
  EXPECT_NEAR(0.0, (alignment.truth_T_estimate.translation() - world_T_map.translation()).norm(),
              1e-9);
  EXPECT_NEAR(0.0, WrapAngle(alignment.truth_T_estimate.theta() - world_T_map.theta()), 1e-9);

  const LayerScore aligned =
      ScoreLayer(run, alignment.truth_T_estimate, truth, LayerScoreOptions());
  EXPECT_GT(aligned.run_occupied_cells, 108);  // at least the 5.4 m of walls in 5 cm cells
  EXPECT_DOUBLE_EQ(1.0, aligned.precision());
  EXPECT_DOUBLE_EQ(1.0, aligned.recall());
  // Unaligned (the map frame taken for the world) the same map scores poorly.
  const LayerScore unaligned = ScoreLayer(run, Pose2(), truth, LayerScoreOptions());
  EXPECT_LT(unaligned.precision(), 0.3);
  EXPECT_LT(unaligned.recall(), 0.3);
}

TEST(AlignTrajectoryTest, StandingRobotTakesTheRotationFromItsHeadings) {
  // Truth: standing at (2, 3) facing 0.3 rad; the estimate in its start frame stands at the
  // origin facing 0 with millimetre jitter: the positions say nothing about the rotation.
  std::mt19937 rng(5);
  std::normal_distribution<double> jitter(0.0, 1e-3);
  std::vector<StampedPose2> truth, estimate;
  for (int k = 0; k < 30; ++k) {
    truth.push_back({0.1 * k, Pose2(2.0, 3.0, 0.3)});
    estimate.push_back({0.1 * k, Pose2(jitter(rng), jitter(rng), jitter(rng))});
  }
  const TrajectoryAlignment alignment = AlignTrajectory(estimate, truth);
  EXPECT_TRUE(alignment.rotation_from_headings);
  EXPECT_NEAR(0.3, alignment.truth_T_estimate.theta(), 2e-3);
  EXPECT_NEAR(2.0, alignment.truth_T_estimate.x(), 2e-3);
  EXPECT_NEAR(3.0, alignment.truth_T_estimate.y(), 2e-3);
  // No pair within the stamp tolerance: no alignment.
  EXPECT_EQ(0, AlignTrajectory(estimate, {{100.0, Pose2()}}).matched);
}

TEST(UnionOfLayersTest, UnitesOccupiedCellsAndRejectsDifferentGrids) {
  GridLayer a = EmptyLayer(), b = EmptyLayer();
  MarkRow(&a, 3, 0, 9);
  MarkRow(&b, 3, 5, 14);
  GridLayer both;
  ASSERT_TRUE(UnionOfLayers({a, b}, {"a", "b"}, &both).ok());
  EXPECT_EQ(15, both.CountCells(CellState::kOccupied));
  EXPECT_EQ(40 * 30 - 15, both.CountCells(CellState::kFree));
  const Status status =
      UnionOfLayers({a, EmptyLayer(Eigen::Vector2d(0.05, 0.0))}, {"walls", "furniture"}, &both);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("'walls' and 'furniture' are not on the same grid"));
}

class ScoreRunLayersTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = ::testing::TempDir() + "/map_layers_test_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_ + "/truth");
    std::filesystem::create_directories(root_ + "/run");
    GridLayer walls = EmptyLayer(), furniture = EmptyLayer(), floor_obstacles = EmptyLayer();
    MarkRow(&walls, 2, 0, 39);
    MarkRow(&furniture, 15, 10, 19);
    MarkRow(&floor_obstacles, 25, 30, 34);
    ASSERT_TRUE(WriteMapPgmYaml(walls, root_ + "/truth/walls").ok());
    ASSERT_TRUE(WriteMapPgmYaml(furniture, root_ + "/truth/furniture").ok());
    ASSERT_TRUE(WriteMapPgmYaml(floor_obstacles, root_ + "/truth/floor_obstacles").ok());
    // The run's map: the walls and the furniture, plus the floor obstacles it should have
    // left out (5 of 55 cells wrong).
    GridLayer map = EmptyLayer();
    MarkRow(&map, 2, 0, 39);
    MarkRow(&map, 15, 10, 19);
    MarkRow(&map, 25, 30, 34);
    ASSERT_TRUE(WriteMapPgmYaml(map, root_ + "/run/map").ok());
  }

  std::string root_;
};

TEST_F(ScoreRunLayersTest, ScoresThePresentLayersAndNamesTheAbsentOnes) {
  RunLayersReport report;
  const Status status =
      ScoreRunLayers(root_ + "/run", root_ + "/truth", Pose2(), LayerScoreOptions(), &report);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(4u, report.layers.size());
  const RunLayerResult& map = report.layers[0];
  EXPECT_EQ("map", map.spec.run_stem);
  ASSERT_TRUE(map.present);
  EXPECT_EQ(55, map.score.run_occupied_cells);
  EXPECT_EQ(50, map.score.run_correct_cells);  // the floor obstacles are not walls or furniture
  EXPECT_EQ(50, map.score.truth_occupied_cells);
  EXPECT_EQ(50, map.score.truth_found_cells);
  for (int i = 1; i < 4; ++i) EXPECT_FALSE(report.layers[i].present) << report.layers[i].spec.run_stem;

  const std::string table = FormatRunLayersTable(report);
  EXPECT_THAT(table, HasSubstr("walls + furniture"));
  EXPECT_THAT(table, HasSubstr("0.9091"));  // 50 / 55
  EXPECT_THAT(table, HasSubstr("absent"));

  const std::string csv_path = root_ + "/scores.csv";
  ASSERT_TRUE(WriteRunLayersCsv(report, csv_path).ok());
  std::ifstream in(csv_path);
  const std::string csv((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(
      "layer,truth,status,precision,recall,run_occupied,run_correct,truth_occupied,truth_found,"
      "tolerance_cells,seen_recall,seen_occupied,seen_found\n"
      "map,walls+furniture,scored,0.909091,1.000000,55,50,50,50,1,,,\n"
      "walls,walls,absent,,,,,,,1,,,\n"
      "floor_obstacles,floor_obstacles,absent,,,,,,,1,,,\n"
      "planner,walls+furniture+floor_obstacles,absent,,,,,,,1,,,\n"
      "map_on_floor_obstacles,floor_obstacles,counted,,,55,5,,,1,,,\n",
      csv);
  // The 5 floor-obstacle cells the map should have left out are counted on their own too.
  EXPECT_EQ(5, report.map_on_floor_obstacles);
  EXPECT_THAT(table, HasSubstr("map.pgm on true floor obstacles: 5 of 55 occupied cells"));
}

// Floor obstacles in the localisation map (paper §III-E): a run cell counts when it is within
// the tolerance of a true floor obstacle and not of a wall or furniture cell; an obstacle
// against a wall cannot be told from the wall at that tolerance.
TEST(CountCellsOnFloorObstaclesTest, CountsCellsOnObstaclesAwayFromStructure) {
  GridLayer structure = EmptyLayer(), obstacles = EmptyLayer();
  MarkRow(&structure, 2, 0, 39);   // a wall
  MarkRow(&obstacles, 3, 10, 12);  // a box against it
  MarkRow(&obstacles, 20, 5, 8);   // a box in the open
  GridLayer run = EmptyLayer();
  MarkRow(&run, 2, 0, 39);   // the wall: not counted
  MarkRow(&run, 3, 10, 12);  // the box against the wall: next to the wall, not counted
  MarkRow(&run, 21, 5, 6);   // half the open box, a cell off: counted
  MarkRow(&run, 25, 30, 31); // elsewhere: not counted (wrong, but not a floor obstacle)
  EXPECT_EQ(2, CountCellsOnFloorObstacles(run, Pose2(), obstacles, structure, LayerScoreOptions()));
  LayerScoreOptions exact;
  exact.tolerance_cells = 0;
  // Without tolerance the open box's cells a cell off are not on it, and the box against the
  // wall is no longer next to the wall's cells: its 3 cells count.
  EXPECT_EQ(3, CountCellsOnFloorObstacles(run, Pose2(), obstacles, structure, exact));
  // A map frame 1 m along x from the world's: the open box's cells 20 columns further in it.
  GridLayer shifted = EmptyLayer();
  MarkRow(&shifted, 21, 25, 26);
  EXPECT_EQ(2, CountCellsOnFloorObstacles(shifted, Pose2(-1.0, 0.0, 0.0), obstacles, structure, LayerScoreOptions()));
  EXPECT_EQ(0, CountCellsOnFloorObstacles(shifted, Pose2(), obstacles, structure, LayerScoreOptions()));
}

TEST_F(ScoreRunLayersTest, SeenLayersGiveTheRecallOfWhatTheRobotSaw) {
  // The robot's laser returned from half the wall row and all the furniture; the run's map has
  // only the first 15 wall cells: recall 25 / 50 of the truth, 25 / 30 of what was seen.
  std::filesystem::create_directories(root_ + "/seen");
  GridLayer walls = EmptyLayer(), furniture = EmptyLayer(), floor_obstacles = EmptyLayer();
  MarkRow(&walls, 2, 0, 19);
  MarkRow(&furniture, 15, 10, 19);
  ASSERT_TRUE(WriteMapPgmYaml(walls, root_ + "/seen/walls").ok());
  ASSERT_TRUE(WriteMapPgmYaml(furniture, root_ + "/seen/furniture").ok());
  ASSERT_TRUE(WriteMapPgmYaml(floor_obstacles, root_ + "/seen/floor_obstacles").ok());
  GridLayer map = EmptyLayer();
  MarkRow(&map, 2, 0, 14);
  MarkRow(&map, 15, 10, 19);
  ASSERT_TRUE(WriteMapPgmYaml(map, root_ + "/run/map").ok());
  RunLayersReport report;
  const Status status = ScoreRunLayers(root_ + "/run", root_ + "/truth", Pose2(), LayerScoreOptions(), &report,
                                       root_ + "/seen");
  ASSERT_TRUE(status.ok()) << status.message();
  const RunLayerResult& result = report.layers[0];
  // Within one cell: wall cells 0..15 of the truth are found.
  EXPECT_EQ(50, result.score.truth_occupied_cells);
  EXPECT_EQ(26, result.score.truth_found_cells);
  EXPECT_EQ(30, result.seen.truth_occupied_cells);
  EXPECT_EQ(26, result.seen.truth_found_cells);
  EXPECT_DOUBLE_EQ(1.0, result.score.precision());
  EXPECT_THAT(FormatRunLayersTable(report), HasSubstr("26/30"));
  const std::string csv_path = root_ + "/scores.csv";
  ASSERT_TRUE(WriteRunLayersCsv(report, csv_path).ok());
  std::ifstream in(csv_path);
  const std::string csv((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(csv, HasSubstr("map,walls+furniture,scored,1.000000,0.520000,25,25,50,26,1,0.866667,30,26\n"));
}

TEST_F(ScoreRunLayersTest, PlannerLayerIsScoredAgainstAllThree) {
  std::filesystem::copy_file(root_ + "/run/map.pgm", root_ + "/run/planner.pgm");
  std::ofstream(root_ + "/run/planner.yaml")
      << "image: planner.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n";
  RunLayersReport report;
  ASSERT_TRUE(
      ScoreRunLayers(root_ + "/run", root_ + "/truth", Pose2(), LayerScoreOptions(), &report).ok());
  const RunLayerResult& planner = report.layers[3];
  ASSERT_TRUE(planner.present);
  EXPECT_DOUBLE_EQ(1.0, planner.score.precision());
  EXPECT_DOUBLE_EQ(1.0, planner.score.recall());
}

TEST_F(ScoreRunLayersTest, ErrorsNameWhatIsMissing) {
  RunLayersReport report;
  std::filesystem::remove(root_ + "/truth/furniture.yaml");
  Status status =
      ScoreRunLayers(root_ + "/run", root_ + "/truth", Pose2(), LayerScoreOptions(), &report);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("furniture.yaml"));
  std::filesystem::create_directories(root_ + "/empty_run");
  status = ScoreRunLayers(root_ + "/empty_run", root_ + "/truth", Pose2(), LayerScoreOptions(),
                          &report);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(),
              HasSubstr("none of the run layers (map.pgm, walls.pgm, floor_obstacles.pgm, "
                        "planner.pgm)"));
  LayerScoreOptions bad;
  bad.tolerance_cells = -1;
  EXPECT_THAT(
      ScoreRunLayers(root_ + "/run", root_ + "/truth", Pose2(), bad, &report).message(),
      HasSubstr("tolerance_cells"));
}

}  // namespace
}  // namespace hetslam
