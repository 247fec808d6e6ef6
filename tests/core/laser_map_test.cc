#include "core/laser_map.h"

#include <cmath>

#include "core/occupancy_grid.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

// Points along x = 2 (a wall), every `spacing` metres from y = -1 to 1, in beam order.
std::vector<Eigen::Vector2f> Wall(float spacing) {
  std::vector<Eigen::Vector2f> points;
  for (float y = -1.f; y <= 1.f + 1e-4f; y += spacing) points.emplace_back(2.f, y);
  return points;
}

TEST(EstimateScanLinesTest, AWallGetsItsDirectionAndHalfTheGap) {
  const ScanLineOptions options;  // max_gap 0.5 m
  const std::vector<Eigen::Vector2f> wall = Wall(0.2f);
  const std::vector<ScanLine> lines = EstimateScanLines(options, wall);
  ASSERT_EQ(wall.size(), lines.size());
  for (size_t i = 0; i < lines.size(); ++i) {
    // Every point, the two ends included (their line comes from the two points before them).
    EXPECT_NEAR(0.1f, lines[i].half_length, 1e-5f) << i;
    EXPECT_NEAR(1.f, std::abs(lines[i].direction.y()), 1e-5f) << i;
  }
}

TEST(EstimateScanLinesTest, NoLineAtCornersAcrossGapsOrWhenOff) {
  ScanLineOptions options;
  // An L: along y at x = 2, then along x at y = 1 (the corner at (2, 1)).
  std::vector<Eigen::Vector2f> corner;
  for (int i = 0; i <= 10; ++i) corner.emplace_back(2.f, -1.f + 0.2f * i);
  for (int i = 1; i <= 10; ++i) corner.emplace_back(2.f - 0.2f * i, 1.f);
  std::vector<ScanLine> lines = EstimateScanLines(options, corner);
  EXPECT_EQ(0.f, lines[10].half_length);  // the corner point: its neighbours are not collinear
  EXPECT_GT(lines[3].half_length, 0.f);
  EXPECT_GT(lines[15].half_length, 0.f);
  EXPECT_NEAR(1.f, std::abs(lines[15].direction.x()), 1e-5f);
  // Points farther apart than line_max_gap: no line.
  lines = EstimateScanLines(options, Wall(0.6f));
  for (const ScanLine& line : lines) EXPECT_EQ(0.f, line.half_length);
  // Off.
  options.max_gap_meters = 0.0;
  lines = EstimateScanLines(options, Wall(0.2f));
  for (const ScanLine& line : lines) EXPECT_EQ(0.f, line.half_length);
  // Noise beyond line_max_rms: zig-zag 6 cm off the line every other point.
  options.max_gap_meters = 0.5;
  std::vector<Eigen::Vector2f> zigzag = Wall(0.2f);
  for (size_t i = 0; i < zigzag.size(); i += 2) zigzag[i].x() += 0.06f;
  lines = EstimateScanLines(options, zigzag);
  for (const ScanLine& line : lines) EXPECT_EQ(0.f, line.half_length);
}

TEST(OccupancyGridLineTest, AveragesAxesAndRejectsDisagreement) {
  OccupancyGrid grid{OccupancyGridOptions()};
  const Eigen::Vector2d sensor(0.0, 0.0);
  const std::vector<Eigen::Vector2d> point{{1.0125, 0.0125}};
  ScanLine up;  // a line along y: direction (0, 1) and (0, -1) are the same axis
  up.direction = Eigen::Vector2f(0.f, 1.f);
  up.half_length = 0.1f;
  ScanLine down = up;
  down.direction = Eigen::Vector2f(0.f, -1.f);
  down.half_length = 0.2f;
  std::vector<ScanLine> lines{up};
  grid.InsertScan(sensor, point, nullptr, nullptr, nullptr, &lines);
  lines = {down};
  grid.InsertScan(sensor, point, nullptr, nullptr, nullptr, &lines);
  const int cell = grid.geometry().LinearIndex(grid.geometry().WorldToCell(point[0]));
  ASSERT_TRUE(grid.IsOccupied(cell));
  ScanLine line = grid.Line(cell);
  EXPECT_NEAR(0.15f, line.half_length, 1e-6f);
  EXPECT_NEAR(1.f, std::abs(line.direction.y()), 1e-6f);
  EXPECT_GE(line.direction.x(), -1e-6f);  // half-angle in (-π/2, π/2]
  // A hit without a line shortens the piece the cell stands for (mean over all hits).
  grid.InsertScan(sensor, point, nullptr, nullptr, nullptr, nullptr);
  EXPECT_NEAR(0.1f, grid.Line(cell).half_length, 1e-6f);
  // A perpendicular line of the same weight: the axes disagree, no line.
  ScanLine across;
  across.direction = Eigen::Vector2f(1.f, 0.f);
  across.half_length = 0.3f;
  lines = {across};
  grid.InsertScan(sensor, point, nullptr, nullptr, nullptr, &lines);
  EXPECT_EQ(0.f, grid.Line(cell).half_length);
}

// A wall seen at a grazing angle is hit every 20 cm: with surfaces the field is as high between
// the hits as on them; with hit points only it dips to exp(-0.1 / sigma) between them.
TEST(LaserMapTest, DottedWallScoresAsAContinuousWall) {
  for (const double gap : {0.5, 0.0}) {
    LikelihoodFieldOptions field;
    field.lines.max_gap_meters = gap;
    LaserMap map(OccupancyGridOptions(), field);
    std::vector<Eigen::Vector2f> wall;
    for (int i = -5; i <= 5; ++i) wall.emplace_back(2.0125f, 0.2f * i + 0.0125f);
    map.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall);
    const GridGeometry& g = map.grid().geometry();
    const float on_hit = map.field().Value(g.WorldToCell({2.0125, 0.0125}));
    const float between = map.field().Value(g.WorldToCell({2.0125, 0.1125}));
    if (gap > 0) {
      EXPECT_NEAR(on_hit, between, 1e-4f);
    } else {
      EXPECT_LT(between, 0.5f * on_hit);
    }
  }
}

// A map whose field is left behind (InsertScan without update_field, as a front end's newer
// submap) and brought up to date at once holds the field of a map updated scan by scan. With
// the republish tolerance at 0 both publish every changed cell's current surface, so their
// values are equal; the scans move the robot 6 m, so the grid grows while changes wait.
// Reading the field while changes wait is a programmer error.
TEST(LaserMapTest, AFieldBroughtUpToDateAtOnceEqualsOneUpdatedEveryScan) {
  LikelihoodFieldOptions field;
  field.republish_distance_meters = 0.0;
  field.republish_angle_radians = 0.0;
  LaserMap every_scan(OccupancyGridOptions(), field), at_once(OccupancyGridOptions(), field);
  for (int k = 0; k < 7; ++k) {
    // A corridor's two walls, seen from x = k, with a little noise from k.
    std::vector<Eigen::Vector2f> points;
    for (int i = -20; i <= 20; ++i) {
      const float noise = 0.004f * static_cast<float>(std::sin(3.0 * k + i));
      points.emplace_back(0.1f * i, 1.0f + noise);
      points.emplace_back(0.1f * i, -1.2f - noise);
    }
    const Pose2 pose(1.0 * k, 0.02 * k, 0.01 * k);
    ASSERT_TRUE(every_scan.InsertScan(pose, Eigen::Vector2d::Zero(), points));
    ASSERT_TRUE(at_once.InsertScan(pose, Eigen::Vector2d::Zero(), points, nullptr, nullptr, /*update_field=*/false));
    EXPECT_FALSE(at_once.field_up_to_date());
  }
  EXPECT_DEATH(at_once.field(), "changes not applied");
  at_once.UpdateField();
  ASSERT_TRUE(at_once.field_up_to_date());
  const GridGeometry& g = every_scan.grid().geometry();
  ASSERT_EQ(g.num_cells(), at_once.grid().geometry().num_cells());
  ASSERT_EQ(g.origin(), at_once.grid().geometry().origin());
  int non_zero = 0;
  for (int y = 0; y < g.height(); ++y) {
    for (int x = 0; x < g.width(); ++x) {
      const float value = every_scan.field().Value({x, y});
      non_zero += value > 0.f;
      ASSERT_EQ(value, at_once.field().Value({x, y})) << "cell " << x << ", " << y;
    }
  }
  EXPECT_GT(non_zero, 1000);
}

}  // namespace
}  // namespace hetslam
