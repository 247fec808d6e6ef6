#include "merger/map_picture.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "core/laser_scan.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "opencv2/core.hpp"
#include "opencv2/imgcodecs.hpp"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/map_picture_test_" + name;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

const Eigen::Vector2d kSensor(0.02, 0.02);
// A wall (label kWall) at x = 1.01 for y in [-0.49, 0.49], a post of other structure (label
// kStructure) at x = -0.51 for y in [-0.19, 0.19], both seen from kSensor.
const Eigen::Vector2d kWallPoint(1.01, 0.01);
const Eigen::Vector2d kPostPoint(-0.51, 0.01);
// One floor obstacle in the free space between the sensor and the wall.
const Eigen::Vector2d kObstaclePoint(0.51, 0.11);
// Free in the structure grid (on the rays to the wall), away from everything drawn.
const Eigen::Vector2d kFreePoint(0.76, -0.24);

OccupancyGrid StructureGrid() {
  OccupancyGrid grid{OccupancyGridOptions()};
  std::vector<Eigen::Vector2d> points;
  std::vector<uint8_t> labels;
  for (int k = -49; k <= 49; ++k) {
    points.emplace_back(kWallPoint.x(), 0.01 * k);
    labels.push_back(static_cast<uint8_t>(PointLabel::kWall));
  }
  for (int k = -19; k <= 19; ++k) {
    points.emplace_back(kPostPoint.x(), 0.01 * k);
    labels.push_back(static_cast<uint8_t>(PointLabel::kStructure));
  }
  grid.InsertScan(kSensor, points, nullptr, &labels);
  return grid;
}

OccupancyGrid ObstacleGrid() {
  OccupancyGrid grid{OccupancyGridOptions()};
  const std::vector<uint8_t> labels = {static_cast<uint8_t>(PointLabel::kFloorObstacle)};
  grid.InsertScan(kSensor, {kObstaclePoint}, nullptr, &labels);
  return grid;
}

// Drives from the sensor along +x, then turns right and ends heading along -y.
MapPictureTrajectory Trajectory() {
  return {"nao", {Pose2(kSensor, 0.0), Pose2(0.3, 0.02, 0.0), Pose2(0.3, -0.3, -M_PI / 2)}};
}

// Observed cell box of `grid` by brute force, widened to contain `lo`, `hi`.
void GrowByObserved(const OccupancyGrid& grid, CellIndex* lo, CellIndex* hi) {
  for (int y = 0; y < grid.geometry().height(); ++y) {
    for (int x = 0; x < grid.geometry().width(); ++x) {
      if (grid.State(CellIndex{x, y}) == CellState::kUnknown) continue;
      *lo = {std::min(lo->x, x), std::min(lo->y, y)};
      *hi = {std::max(hi->x, x), std::max(hi->y, y)};
    }
  }
}

cv::Vec3b Bgr(const Rgb& c) { return cv::Vec3b(c[2], c[1], c[0]); }

// The picture's pixel at the centre of the structure grid's cell that holds `p_world`.
cv::Vec3b PixelOfCell(const cv::Mat& image, const MapPictureLayout& layout,
                      const OccupancyGrid& grid, const Eigen::Vector2d& p_world) {
  const Eigen::Vector2d centre = grid.geometry().CellCenter(grid.geometry().WorldToCell(p_world));
  const Eigen::Vector2d pixel = layout.WorldToPixel(centre);
  return image.at<cv::Vec3b>(static_cast<int>(pixel.y()), static_cast<int>(pixel.x()));
}

cv::Vec3b PixelAt(const cv::Mat& image, const Eigen::Vector2d& pixel) {
  return image.at<cv::Vec3b>(static_cast<int>(std::floor(pixel.y())),
                             static_cast<int>(std::floor(pixel.x())));
}

TEST(MapPictureTest, TinyWorldHasCrispCellsInTheirColours) {
  const OccupancyGrid structure = StructureGrid();
  const OccupancyGrid obstacles = ObstacleGrid();
  const std::string path = TempPath("tiny.png");
  MapPictureLayout layout;
  const MapPictureOptions options;
  const Status status =
      WriteMapPicture(path, structure, &obstacles, {Trajectory()}, {}, options, &layout);
  ASSERT_TRUE(status.ok()) << status.message();

  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty()) << path;
  EXPECT_EQ(layout.width_pixels, image.cols);
  EXPECT_EQ(layout.height_pixels, image.rows);
  // The legend panel sits right of the map and the scale strip below it.
  EXPECT_GT(image.cols, layout.map_width_pixels);
  EXPECT_GT(image.rows, layout.map_height_pixels);

  // Upscale rule: the union of both grids' observed cells (the obstacle grid's mapped onto the
  // structure grid's lattice by cell centre) plus the border, times the smallest integer that makes the shorter side >= 800 pixels.
  CellIndex lo{std::numeric_limits<int>::max(), std::numeric_limits<int>::max()};
  CellIndex hi{std::numeric_limits<int>::min(), std::numeric_limits<int>::min()};
  GrowByObserved(structure, &lo, &hi);
  CellIndex obstacle_lo{std::numeric_limits<int>::max(), std::numeric_limits<int>::max()};
  CellIndex obstacle_hi{std::numeric_limits<int>::min(), std::numeric_limits<int>::min()};
  GrowByObserved(obstacles, &obstacle_lo, &obstacle_hi);
  const GridGeometry& g = structure.geometry();
  const CellIndex o_lo = g.WorldToCell(obstacles.geometry().CellCenter(obstacle_lo));
  const CellIndex o_hi = g.WorldToCell(obstacles.geometry().CellCenter(obstacle_hi));
  lo = {std::min(lo.x, o_lo.x), std::min(lo.y, o_lo.y)};
  hi = {std::max(hi.x, o_hi.x), std::max(hi.y, o_hi.y)};
  const int width_cells = hi.x - lo.x + 1 + 2 * options.border_cells;
  const int height_cells = hi.y - lo.y + 1 + 2 * options.border_cells;
  const int short_cells = std::min(width_cells, height_cells);
  const int scale = (options.min_short_side_pixels + short_cells - 1) / short_cells;
  ASSERT_GE(scale * short_cells, options.min_short_side_pixels);
  ASSERT_LT((scale - 1) * short_cells, options.min_short_side_pixels);
  EXPECT_EQ(scale, layout.pixels_per_cell);
  EXPECT_EQ(width_cells * scale, layout.map_width_pixels);
  EXPECT_EQ(height_cells * scale, layout.map_height_pixels);
  EXPECT_EQ(lo.x - options.border_cells, layout.min_cell.x);
  EXPECT_EQ(lo.y - options.border_cells, layout.min_cell.y);

  EXPECT_EQ(Bgr(kMapPictureWallRgb), PixelOfCell(image, layout, structure, kWallPoint));
  EXPECT_EQ(Bgr(kMapPictureStructureRgb), PixelOfCell(image, layout, structure, kPostPoint));
  EXPECT_EQ(Bgr(kMapPictureFloorObstacleRgb), PixelOfCell(image, layout, structure, kObstaclePoint));
  EXPECT_EQ(Bgr(kMapPictureFreeRgb), PixelOfCell(image, layout, structure, kFreePoint));
  EXPECT_EQ(Bgr(kMapPictureUnknownRgb), image.at<cv::Vec3b>(0, 0));  // border: unknown
  // Crisp cells: every pixel of the wall cell's block has the wall colour.
  const CellIndex wall_cell = g.WorldToCell(kWallPoint);
  const Eigen::Vector2d block_top_left =
      layout.WorldToPixel(g.CellMinCorner(wall_cell) + Eigen::Vector2d(0.0, g.resolution_meters()));
  for (int r = 0; r < scale; ++r) {
    for (int c = 0; c < scale; ++c) {
      ASSERT_EQ(Bgr(kMapPictureWallRgb),
                image.at<cv::Vec3b>(static_cast<int>(std::lround(block_top_left.y())) + r,
                                    static_cast<int>(std::lround(block_top_left.x())) + c))
          << r << ", " << c;
    }
  }

  // North up: the wall (larger x) is right of the post, the obstacle (y = 0.11) above the free
  // cell (y = -0.24).
  EXPECT_GT(layout.WorldToPixel(kWallPoint).x(), layout.WorldToPixel(kPostPoint).x());
  EXPECT_LT(layout.WorldToPixel(kObstaclePoint).y(), layout.WorldToPixel(kFreePoint).y());

  // The end arrow is filled with the trajectory's colour and points along the last heading
  // (-y: down the picture); the start disc too.
  uint8_t rgb[3];
  TrajectoryColor(0, rgb);
  const cv::Vec3b trajectory_bgr(rgb[2], rgb[1], rgb[0]);
  const Eigen::Vector2d end = layout.WorldToPixel(Trajectory().poses.back().translation());
  EXPECT_EQ(trajectory_bgr, PixelAt(image, end));
  EXPECT_EQ(trajectory_bgr, PixelAt(image, end + Eigen::Vector2d(0.0, 3.0)));
  EXPECT_NE(trajectory_bgr, PixelAt(image, end + Eigen::Vector2d(6.0, -6.0)));
  EXPECT_EQ(trajectory_bgr, PixelAt(image, layout.WorldToPixel(kSensor)));

  // 1-2-5 scale bar near 15% of the map's width (1.8 m wide map: 0.27 m -> 20 cm).
  const double map_width_meters = width_cells * g.resolution_meters();
  EXPECT_GT(layout.scale_bar_meters, 0.15 * map_width_meters / 2.5);
  EXPECT_LT(layout.scale_bar_meters, 0.15 * map_width_meters * 2.5);
}

TEST(MapPictureTest, SameInputGivesSameBytes) {
  const OccupancyGrid structure = StructureGrid();
  const OccupancyGrid obstacles = ObstacleGrid();
  MapPictureMarker tag;
  tag.kind = MapPictureMarker::Kind::kTag;
  tag.world = Eigen::Vector2d(0.9, 0.4);
  tag.label = "tag 7";
  MapPictureMarker constraint;
  constraint.kind = MapPictureMarker::Kind::kConstraint;
  constraint.world = Eigen::Vector2d(0.1, -0.4);
  constraint.label = "nao - pepper";
  constraint.line_to_world = Eigen::Vector2d(0.6, -0.4);
  const std::vector<MapPictureMarker> markers = {tag, constraint};
  const std::string first = TempPath("first.png"), second = TempPath("second.png");
  ASSERT_TRUE(
      WriteMapPicture(first, structure, &obstacles, {Trajectory()}, markers, {}).ok());
  ASSERT_TRUE(
      WriteMapPicture(second, structure, &obstacles, {Trajectory()}, markers, {}).ok());
  const std::string bytes = ReadFile(first);
  EXPECT_FALSE(bytes.empty());
  EXPECT_EQ(bytes, ReadFile(second));
}

TEST(MapPictureTest, ScaleIsLoweredToStayWithinMaxPixels) {
  const OccupancyGrid structure = StructureGrid();
  MapPictureLayout full, limited;
  ASSERT_TRUE(
      WriteMapPicture(TempPath("full.png"), structure, nullptr, {}, {}, {}, &full).ok());
  ASSERT_GT(full.pixels_per_cell, 3);
  const int cells = (full.max_cell.x - full.min_cell.x + 1) * (full.max_cell.y - full.min_cell.y + 1);
  MapPictureOptions options;
  options.max_pixels = cells * 9 + 1;  // room for 3 x 3 pixels per cell, not 4 x 4
  const Status status =
      WriteMapPicture(TempPath("limited.png"), structure, nullptr, {}, {}, options, &limited);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(3, limited.pixels_per_cell);
  EXPECT_LE(static_cast<long long>(limited.map_width_pixels) * limited.map_height_pixels,
            options.max_pixels);
}

// Issue #15: the picture is drawn and written a band of rows at a time. A long straight
// trajectory across a large room crosses several bands; each row's stroke lies on one line
// (no jog where a band's edge clipped it: without the bands' margins the stroke moved by a
// pixel there).
TEST(MapPictureTest, StrokesCrossTheBandsWithoutASeam) {
  // A 40 m square room seen from its centre: 800 x 800 cells, drawn at one pixel a cell.
  OccupancyGrid structure{OccupancyGridOptions()};
  std::vector<Eigen::Vector2d> walls;
  for (double s = -19.99; s < 19.99; s += 0.01) {
    walls.emplace_back(s, 19.995);
    walls.emplace_back(s, -19.995);
    walls.emplace_back(19.995, s);
    walls.emplace_back(-19.995, s);
  }
  structure.InsertScan(Eigen::Vector2d(0.01, 0.01), walls, nullptr);
  const Eigen::Vector2d from(-15.0, -17.0), to(13.0, 16.0);
  // Many short steps, as a trajectory's poses are.
  MapPictureTrajectory straight{"straight", {}};
  for (int k = 0; k <= 400; ++k) straight.poses.emplace_back(from + (to - from) * (k / 400.0), 0.0);
  const std::string path = TempPath("bands.png");
  MapPictureLayout layout;
  ASSERT_TRUE(WriteMapPicture(path, structure, nullptr, {straight}, {}, MapPictureOptions(), &layout).ok());
  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  ASSERT_GT(image.rows, 700);  // several bands of ~512 KiB (~170 rows at this width)
  const Eigen::Vector2d a = layout.WorldToPixel(from), b = layout.WorldToPixel(to);
  // Each row's darkness-weighted centre of the stroke, away from its ends' glyphs.
  std::vector<Eigen::Vector2d> centres;
  for (int row = static_cast<int>(b.y()) + 30; row < static_cast<int>(a.y()) - 30; ++row) {
    const double expected_x = a.x() + (b.x() - a.x()) * (row + 0.5 - a.y()) / (b.y() - a.y());
    double weight = 0.0, sum = 0.0;
    for (int col = static_cast<int>(expected_x) - 8; col <= static_cast<int>(expected_x) + 8; ++col) {
      const cv::Vec3b bgr = image.at<cv::Vec3b>(row, col);
      const double dark = 255.0 - std::min({bgr[0], bgr[1], bgr[2]});
      weight += dark;
      sum += dark * (col + 0.5);
    }
    ASSERT_GT(weight, 0.0) << "row " << row;
    centres.emplace_back(sum / weight, row + 0.5);
  }
  ASSERT_GT(centres.size(), 500u);
  // Least-squares line x = c0 + c1 y through the centres; no row strays from it.
  double sy = 0, sx = 0, syy = 0, sxy = 0;
  for (const Eigen::Vector2d& c : centres) {
    sx += c.x();
    sy += c.y();
    syy += c.y() * c.y();
    sxy += c.x() * c.y();
  }
  const double n = static_cast<double>(centres.size());
  const double c1 = (n * sxy - sx * sy) / (n * syy - sy * sy), c0 = (sx - c1 * sy) / n;
  double worst = 0.0;
  int worst_row = -1;
  for (const Eigen::Vector2d& c : centres) {
    const double off = std::abs(c.x() - (c0 + c1 * c.y()));
    if (off > worst) worst = off, worst_row = static_cast<int>(c.y());
  }
  EXPECT_LT(worst, 0.25) << "at row " << worst_row;
}

TEST(MapPictureTest, ErrorsNameTheFile) {
  const OccupancyGrid structure = StructureGrid();

  const std::string unwritable = TempPath("no_such_folder/map.png");
  Status status = WriteMapPicture(unwritable, structure, nullptr, {Trajectory()}, {}, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(unwritable));

  const std::string path = TempPath("error.png");
  MapPictureTrajectory bad = Trajectory();
  bad.poses[1] = Pose2(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0);
  status = WriteMapPicture(path, structure, nullptr, {bad}, {}, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(path));
  EXPECT_THAT(status.message(), HasSubstr("pose 1 is not finite"));

  MapPictureMarker marker;
  marker.line_to_world = Eigen::Vector2d(std::numeric_limits<double>::infinity(), 0.0);
  status = WriteMapPicture(path, structure, nullptr, {}, {marker}, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("marker 0"));

  // A pose 10 km away in x and y: 200000 x 200000 cells, over 40 million even at one pixel each.
  MapPictureTrajectory far = Trajectory();
  far.poses.push_back(Pose2(10'000.0, 10'000.0, 0.0));
  status = WriteMapPicture(path, structure, nullptr, {far}, {}, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(path));
  EXPECT_THAT(status.message(), HasSubstr("max_pixels"));

  // Alone (no observed cell in an empty grid) but far beyond any cell index.
  const OccupancyGrid empty{OccupancyGridOptions()};
  status = WriteMapPicture(path, empty, nullptr, {{"lost", {Pose2(1e300, 0.0, 0.0)}}}, {}, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("1e12 cells"));

  MapPictureOptions options;
  options.min_short_side_pixels = 0;
  status = WriteMapPicture(path, structure, nullptr, {}, {}, options);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("min_short_side_pixels"));

  OccupancyGridOptions coarse;
  coarse.resolution_meters = 0.1;
  const OccupancyGrid coarse_obstacles(coarse);
  status = WriteMapPicture(path, structure, &coarse_obstacles, {}, {}, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("resolution"));

  status = WriteMapPicture(path, empty, nullptr, {}, {}, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("nothing to draw"));
}

}  // namespace
}  // namespace hetslam
