#include "core/map_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "opencv2/core.hpp"
#include "opencv2/imgcodecs.hpp"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/map_io_test_" + name;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A 4 m x 3 m room: walls at x = -2, x = 2, y = -1, y = 2, scanned from the origin with one
// end point every centimetre.
OccupancyGrid SquareRoomGrid() {
  OccupancyGrid grid{OccupancyGridOptions()};
  std::vector<Eigen::Vector2d> points;
  for (double s = -1.99; s < 1.99; s += 0.01) {
    points.emplace_back(s, 1.995);
    points.emplace_back(s, -0.995);
  }
  for (double s = -0.99; s < 1.99; s += 0.01) {
    points.emplace_back(-1.995, s);
    points.emplace_back(1.995, s);
  }
  grid.InsertScan(Eigen::Vector2d(0.02, 0.02), points, nullptr);
  return grid;
}

// Observed bounding box by brute force (independent of OccupancyGrid::observed_min/max).
void ObservedBox(const OccupancyGrid& grid, CellIndex* lo, CellIndex* hi) {
  *lo = {1 << 30, 1 << 30};
  *hi = {-(1 << 30), -(1 << 30)};
  for (int y = 0; y < grid.geometry().height(); ++y) {
    for (int x = 0; x < grid.geometry().width(); ++x) {
      if (grid.State(CellIndex{x, y}) == CellState::kUnknown) continue;
      *lo = {std::min(lo->x, x), std::min(lo->y, y)};
      *hi = {std::max(hi->x, x), std::max(hi->y, y)};
    }
  }
}

uint8_t ExpectedGrey(const OccupancyGrid& grid, int x, int y) {
  const CellIndex c{x, y};
  if (!grid.geometry().Contains(c)) return kPgmUnknown;
  switch (grid.State(c)) {
    case CellState::kOccupied:
      return kPgmOccupied;
    case CellState::kFree:
      return kPgmFree;
    default:
      return kPgmUnknown;
  }
}

TEST(MapIoTest, PgmYamlFollowsMapServerConvention) {
  const OccupancyGrid grid = SquareRoomGrid();
  const std::string base = TempPath("room");
  const Status status = WriteMapPgmYaml(grid, base);
  ASSERT_TRUE(status.ok()) << status.message();

  // P5 header then width * height bytes.
  const std::string pgm = ReadFile(base + ".pgm");
  std::istringstream header(pgm);
  std::string magic;
  int width = 0, height = 0, max_value = 0;
  header >> magic >> width >> height >> max_value;
  header.get();  // the single white space before the raster
  ASSERT_EQ("P5", magic);
  ASSERT_EQ(255, max_value);
  CellIndex lo, hi;
  ObservedBox(grid, &lo, &hi);
  ASSERT_EQ(hi.x - lo.x + 1 + 2 * kMapBorderCells, width);
  ASSERT_EQ(hi.y - lo.y + 1 + 2 * kMapBorderCells, height);
  const size_t raster_at = static_cast<size_t>(header.tellg());
  ASSERT_EQ(raster_at + static_cast<size_t>(width) * height, pgm.size());

  // Every pixel: row 0 is the top (largest y), column 0 the smallest x.
  int occupied = 0, free_cells = 0;
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      const int x = lo.x - kMapBorderCells + col;
      const int y = hi.y + kMapBorderCells - row;
      const uint8_t value = static_cast<uint8_t>(pgm[raster_at + row * width + col]);
      ASSERT_EQ(ExpectedGrey(grid, x, y), value) << "row " << row << " col " << col;
      occupied += value == kPgmOccupied;
      free_cells += value == kPgmFree;
    }
  }
  EXPECT_GT(occupied, 4 * 60);      // the walls, ~14 m at 5 cm
  EXPECT_GT(free_cells, 60 * 40);   // the room's inside
  // The border is unknown.
  for (int col = 0; col < width; ++col) {
    EXPECT_EQ(kPgmUnknown, static_cast<uint8_t>(pgm[raster_at + col]));
  }

  const std::string yaml = ReadFile(base + ".yaml");
  EXPECT_THAT(yaml, HasSubstr("image: map_io_test_room.pgm\n"));
  EXPECT_THAT(yaml, HasSubstr("resolution: 0.05\n"));
  EXPECT_THAT(yaml, HasSubstr("negate: 0\n"));
  EXPECT_THAT(yaml, HasSubstr("occupied_thresh: 0.65\n"));
  EXPECT_THAT(yaml, HasSubstr("free_thresh: 0.196\n"));
  double origin_x = 0, origin_y = 0;
  const size_t at = yaml.find("origin: [");
  ASSERT_NE(std::string::npos, at);
  ASSERT_EQ(2, std::sscanf(yaml.c_str() + at, "origin: [%lf, %lf, 0.0]", &origin_x, &origin_y));
  // The origin is the lower-left corner of the lower-left pixel (bottom row, column 0).
  const Eigen::Vector2d corner =
      grid.geometry().CellMinCorner({lo.x - kMapBorderCells, lo.y - kMapBorderCells});
  EXPECT_NEAR(corner.x(), origin_x, 1e-9);
  EXPECT_NEAR(corner.y(), origin_y, 1e-9);
  // The room's walls are at -2 .. 2 and -1 .. 2: the map starts just outside them.
  EXPECT_NEAR(-2.0 - kMapBorderCells * 0.05, origin_x, 0.051);
  EXPECT_NEAR(-1.0 - kMapBorderCells * 0.05, origin_y, 0.051);
}

TEST(MapIoTest, PgmRejectsEmptyGridAndBadPath) {
  const OccupancyGrid empty{OccupancyGridOptions()};
  Status status = WriteMapPgmYaml(empty, TempPath("empty"));
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("no observed cell"));
  status = WriteMapPgmYaml(SquareRoomGrid(), TempPath("no_such_dir/map"));
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("no_such_dir/map.pgm"));
}

TEST(PngTest, GreyAndRgbRoundTripThroughOpenCv) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  // Small and odd sizes and one random image over 1 MiB compressed (several IDAT chunks).
  const int sizes[][2] = {{1, 1}, {3, 2}, {17, 5}, {300, 251}, {700, 600}};
  for (const auto& size : sizes) {
    for (int channels : {1, 3}) {
      const int width = size[0], height = size[1];
      std::vector<uint8_t> pixels(static_cast<size_t>(width) * height * channels);
      for (uint8_t& p : pixels) p = static_cast<uint8_t>(byte(rng));
      const std::string path = TempPath("roundtrip.png");
      const Status status = WritePng(path, width, height, channels, pixels);
      ASSERT_TRUE(status.ok()) << status.message();
      const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(image.empty()) << width << "x" << height << "x" << channels;
      ASSERT_EQ(width, image.cols);
      ASSERT_EQ(height, image.rows);
      ASSERT_EQ(channels, image.channels());
      ASSERT_EQ(CV_8U, image.depth());
      for (int r = 0; r < height; ++r) {
        for (int c = 0; c < width; ++c) {
          for (int k = 0; k < channels; ++k) {
            // OpenCV stores colour as BGR.
            const int cv_k = channels == 3 ? 2 - k : 0;
            const uint8_t expected = pixels[(static_cast<size_t>(r) * width + c) * channels + k];
            ASSERT_EQ(expected, image.ptr<uint8_t>(r)[c * channels + cv_k])
                << width << "x" << height << "x" << channels << " at " << r << "," << c;
          }
        }
      }
    }
  }
}

// Maps are long runs and rows like the one above: matches that run on across scanline ends
// (over the filter byte, 0, which a run of zeros takes along), rows equal to the one above
// with a few bytes changed, runs longer than deflate's 258, widths of 1 and 2 bytes.
TEST(PngTest, RunsAndRepeatedRowsAcrossScanlinesRoundTrip) {
  std::mt19937 rng(11);
  const uint8_t greys[] = {0, 0, 255, 205, 128};
  std::uniform_int_distribution<int> pick(0, 4), run_length(1, 400), percent(0, 99);
  const int sizes[][2] = {{1, 40}, {2, 30}, {5, 20}, {300, 60}, {301, 41}};
  for (const auto& size : sizes) {
    for (int channels : {1, 3}) {
      const int width = size[0], height = size[1];
      const size_t row_bytes = static_cast<size_t>(width) * channels;
      std::vector<uint8_t> pixels(row_bytes * height);
      for (int r = 0; r < height; ++r) {
        uint8_t* row = pixels.data() + r * row_bytes;
        const int kind = percent(rng);
        if (r > 0 && kind < 40) {  // the row above, a few bytes changed
          std::copy(row - row_bytes, row, row);
          for (int k = 0; k < 3; ++k) row[std::uniform_int_distribution<size_t>(0, row_bytes - 1)(rng)] = greys[pick(rng)];
        } else if (kind < 60) {  // one grey throughout (zeros join the filter bytes around)
          std::fill(row, row + row_bytes, greys[pick(rng)]);
        } else {  // runs of greys
          for (size_t x = 0; x < row_bytes;) {
            const size_t end = std::min(row_bytes, x + run_length(rng));
            std::fill(row + x, row + end, greys[pick(rng)]);
            x = end;
          }
        }
      }
      const std::string path = TempPath("runs.png");
      ASSERT_TRUE(WritePng(path, width, height, channels, pixels).ok());
      const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(image.empty()) << width << "x" << height << "x" << channels;
      ASSERT_EQ(width, image.cols);
      ASSERT_EQ(height, image.rows);
      for (int r = 0; r < height; ++r) {
        for (int c = 0; c < width; ++c) {
          for (int k = 0; k < channels; ++k) {
            const int cv_k = channels == 3 ? 2 - k : 0;
            ASSERT_EQ(pixels[r * row_bytes + c * channels + k], image.ptr<uint8_t>(r)[c * channels + cv_k])
                << width << "x" << height << "x" << channels << " at " << r << "," << c;
          }
        }
      }
    }
  }
  // One grey throughout is one run: a 1000 x 1000 image in well under 1% of its bytes.
  const std::string path = TempPath("flat.png");
  ASSERT_TRUE(WritePng(path, 1000, 1000, 1, std::vector<uint8_t>(1000 * 1000, 205)).ok());
  std::ifstream file(path, std::ios::binary | std::ios::ate);
  EXPECT_LT(static_cast<long>(file.tellg()), 10000);
  const cv::Mat flat = cv::imread(path, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(flat.empty());
  EXPECT_EQ(1000000, cv::countNonZero(flat == 205));
}

// Issue #15 (the map picture drawn a band at a time): the row writer gives the bytes of the
// whole-image writer however the rows are split, narrow images (whose 258-byte matches reach
// several rows ahead) and a noisy one whose stream fills more than one 1 MiB chunk included.
TEST(PngTest, RowWriterGivesTheWholeImagesBytesInAnyBands) {
  std::mt19937 rng(5);
  const uint8_t greys[] = {0, 0, 255, 205, 128};
  std::uniform_int_distribution<int> pick(0, 4), byte(0, 255), percent(0, 99);
  const int sizes[][3] = {{1, 60, 1}, {3, 50, 3}, {40, 30, 1}, {301, 41, 3}, {1200, 1000, 1}};
  for (const auto& size : sizes) {
    const int width = size[0], height = size[1], channels = size[2];
    const size_t row_bytes = static_cast<size_t>(width) * channels;
    std::vector<uint8_t> pixels(row_bytes * height);
    const bool noisy = width * height >= 1000000;
    for (int r = 0; r < height; ++r) {
      uint8_t* row = pixels.data() + r * row_bytes;
      const int kind = percent(rng);
      for (size_t x = 0; x < row_bytes; ++x) row[x] = noisy ? static_cast<uint8_t>(byte(rng)) : greys[pick(rng)];
      if (!noisy && r > 0 && kind < 50) std::copy(row - row_bytes, row, row);  // as the row above
    }
    const std::string whole_path = TempPath("whole.png");
    ASSERT_TRUE(WritePngFromBuffer(whole_path, width, height, channels, pixels.data()).ok());
    const std::string whole = ReadFile(whole_path);
    if (noisy) {
      // More than one IDAT chunk.
      const size_t first = whole.find("IDAT");
      ASSERT_NE(std::string::npos, first);
      EXPECT_NE(std::string::npos, whole.find("IDAT", first + 4));
    }
    for (const int band : {1, 2, 7, 64}) {
      const std::string path = TempPath("bands.png");
      std::filesystem::remove(path);
      PngRowWriter writer;
      ASSERT_TRUE(writer.Open(path, width, height, channels).ok());
      for (int r = 0; r < height; r += band) {
        ASSERT_TRUE(writer.AddRows(pixels.data() + r * row_bytes, std::min(band, height - r)).ok());
      }
      EXPECT_FALSE(std::filesystem::exists(path)) << "not before Finish";
      ASSERT_TRUE(writer.Finish().ok());
      EXPECT_TRUE(ReadFile(path) == whole) << width << "x" << height << "x" << channels << " in bands of " << band;
    }
  }
}

TEST(PngTest, RowWriterRefusesWrongRowCountsAndLeavesNoFile) {
  const std::string path = TempPath("rows.png");
  std::filesystem::remove(path);
  const std::vector<uint8_t> rows(4 * 3, 128);
  {
    PngRowWriter writer;
    ASSERT_TRUE(writer.Open(path, 4, 3, 1).ok());
    EXPECT_THAT(writer.Open(path, 4, 3, 1).message(), HasSubstr("already in use"));
    ASSERT_TRUE(writer.AddRows(rows.data(), 2).ok());
    EXPECT_THAT(writer.AddRows(rows.data(), 2).message(), HasSubstr("2 rows given with 1 of 3 left"));
    EXPECT_THAT(writer.Finish().message(), HasSubstr("2 of 3 rows given"));
  }  // destroyed unfinished: its temporary file goes
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  PngRowWriter unopened;
  EXPECT_THAT(unopened.AddRows(rows.data(), 1).message(), HasSubstr("before Open"));
  EXPECT_THAT(unopened.Finish().message(), HasSubstr("before Open"));
  EXPECT_THAT(unopened.Open(TempPath("no_such_dir/x.png"), 1, 1, 1).message(), HasSubstr("no_such_dir"));
  PngRowWriter finished;
  ASSERT_TRUE(finished.Open(path, 4, 3, 1).ok());
  ASSERT_TRUE(finished.AddRows(rows.data(), 3).ok());
  ASSERT_TRUE(finished.Finish().ok());
  EXPECT_THAT(finished.AddRows(rows.data(), 1).message(), HasSubstr("after Finish"));
  EXPECT_THAT(finished.Finish().message(), HasSubstr("after Finish"));
}

TEST(PngTest, FileStructureIsValid) {
  const std::string path = TempPath("structure.png");
  ASSERT_TRUE(WritePng(path, 2, 1, 1, {0, 255}).ok());
  const std::string png = ReadFile(path);
  ASSERT_GE(png.size(), 8u + 25u + 12u);
  EXPECT_EQ(std::string("\x89PNG\r\n\x1a\n", 8), png.substr(0, 8));
  EXPECT_EQ("IHDR", png.substr(12, 4));
  // The IEND chunk and its well-known CRC ae 42 60 82.
  EXPECT_EQ(std::string("\0\0\0\0IEND\xae\x42\x60\x82", 12), png.substr(png.size() - 12));
  // IDAT: zlib header 78 01; one final block with the fixed Huffman codes (the first three
  // bits: BFINAL 1, BTYPE 01) of the literals 0 (filter byte), 0 and 255 and the end code:
  // 3 + 8 + 8 + 9 + 7 = 35 bits, 5 bytes; then Adler-32 of {0, 0, 255}: a = 256,
  // b = 1 + 1 + 256 = 258 -> 0x01020100, and the chunk's CRC.
  const size_t idat = png.find("IDAT");
  ASSERT_NE(std::string::npos, idat);
  const uint32_t length = (static_cast<uint8_t>(png[idat - 4]) << 24) | (static_cast<uint8_t>(png[idat - 3]) << 16) |
                          (static_cast<uint8_t>(png[idat - 2]) << 8) | static_cast<uint8_t>(png[idat - 1]);
  ASSERT_EQ(2u + 5u + 4u, length);
  EXPECT_EQ(std::string("\x78\x01", 2), png.substr(idat + 4, 2));
  EXPECT_EQ(0x3, static_cast<uint8_t>(png[idat + 6]) & 0x7);
  EXPECT_EQ(std::string("\x01\x02\x01\x00", 4), png.substr(idat + 4 + 7, 4));
}

// A map is long runs of one grey and rows like the one above: it compresses (the file was once
// written with stored blocks, 1.0 bytes a pixel) and decodes to the same pixels.
TEST(PngTest, MapLikeImagesCompress) {
  const int width = 1200, height = 900;
  std::vector<uint8_t> pixels(static_cast<size_t>(width) * height * 3, 205);
  for (int y = 100; y < 800; ++y) {
    for (int x = 100; x < 1100; ++x) {
      const bool wall = y == 100 || y == 799 || x == 100 || x == 1099 || (x == 600 && y < 500);
      for (int k = 0; k < 3; ++k) pixels[(static_cast<size_t>(y) * width + x) * 3 + k] = wall ? 0 : 254;
    }
  }
  const std::string path = TempPath("map_like.png");
  ASSERT_TRUE(WritePng(path, width, height, 3, pixels).ok());
  EXPECT_LT(ReadFile(path).size(), pixels.size() / 100);
  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_EQ(height, image.rows);
  ASSERT_EQ(width, image.cols);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      ASSERT_EQ(pixels[(static_cast<size_t>(y) * width + x) * 3], image.ptr<uint8_t>(y)[x * 3]) << x << "," << y;
    }
  }
}

TEST(PngTest, RejectsBadArguments) {
  EXPECT_THAT(WritePng(TempPath("bad.png"), 0, 5, 1, {}).message(), HasSubstr("empty"));
  EXPECT_THAT(WritePng(TempPath("bad.png"), 2, 2, 2, std::vector<uint8_t>(8)).message(),
              HasSubstr("channels must be 1 or 3"));
  EXPECT_THAT(WritePng(TempPath("bad.png"), 2, 2, 3, std::vector<uint8_t>(11)).message(),
              HasSubstr("11 pixel bytes given for 2 x 2 x 3"));
  EXPECT_THAT(WritePng(TempPath("no_such_dir/x.png"), 1, 1, 1, {0}).message(),
              HasSubstr("no_such_dir/x.png"));
}

TEST(MapPngTest, DrawsMapAndColouredTrajectoriesWithStartMarkers) {
  const OccupancyGrid grid = SquareRoomGrid();
  // Two trajectories inside the room and one that leaves it to the right (x = 3.5): the
  // picture must grow to include it.
  const std::vector<std::vector<Pose2>> trajectories = {
      {Pose2(-1.0, 0.0, 0), Pose2(1.0, 0.0, 0)},
      {Pose2(-1.0, 1.0, 0), Pose2(0.0, 1.5, 0), Pose2(1.0, 1.0, 0)},
      {Pose2(0.0, -0.5, 0), Pose2(3.5, -0.5, 0)}};
  const std::string path = TempPath("map.png");
  const Status status = WriteMapPng(grid, trajectories, path);
  ASSERT_TRUE(status.ok()) << status.message();
  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());

  const GridGeometry& g = grid.geometry();
  CellIndex lo, hi;
  ObservedBox(grid, &lo, &hi);
  const int max_x = g.WorldToCell(Eigen::Vector2d(3.5, 0)).x;
  EXPECT_EQ(max_x - lo.x + 1 + 2 * kMapBorderCells, image.cols);
  EXPECT_EQ(hi.y - lo.y + 1 + 2 * kMapBorderCells, image.rows);
  auto pixel_of = [&](const Eigen::Vector2d& p) {
    const CellIndex c = g.WorldToCell(p);
    return cv::Point(c.x - (lo.x - kMapBorderCells), (hi.y + kMapBorderCells) - c.y);
  };
  auto colour_at = [&](const Eigen::Vector2d& p) {
    const cv::Vec3b bgr = image.at<cv::Vec3b>(pixel_of(p));
    return std::vector<int>{bgr[2], bgr[1], bgr[0]};
  };
  auto colour_of = [](int index) {
    uint8_t rgb[3];
    TrajectoryColor(index, rgb);
    return std::vector<int>{rgb[0], rgb[1], rgb[2]};
  };
  // Distinct colours.
  EXPECT_NE(colour_of(0), colour_of(1));
  EXPECT_NE(colour_of(1), colour_of(2));
  EXPECT_NE(colour_of(0), colour_of(2));
  // Start markers and points on the polylines (away from other drawings).
  EXPECT_EQ(colour_of(0), colour_at({-1.0, 0.0}));
  EXPECT_EQ(colour_of(0), colour_at({0.6, 0.0}));
  EXPECT_EQ(colour_of(1), colour_at({-1.0, 1.0}));
  EXPECT_EQ(colour_of(1), colour_at({0.0, 1.5}));
  EXPECT_EQ(colour_of(2), colour_at({3.0, -0.5}));
  // The start marker has a black ring 4 pixels out; a pixel 10 cells away is plain map.
  const cv::Point start = pixel_of({-1.0, 1.0});
  const cv::Vec3b ring = image.at<cv::Vec3b>(start + cv::Point(0, 4));
  EXPECT_EQ(cv::Vec3b(0, 0, 0), ring);
  // The map: a wall cell is black, the room's free inside white-ish, outside the grid grey.
  const std::vector<int> black = {0, 0, 0}, free_grey = {254, 254, 254},
                         unknown = {205, 205, 205};
  EXPECT_EQ(black, colour_at({1.995, -0.2}));
  EXPECT_EQ(free_grey, colour_at({-0.5, -0.3}));
  EXPECT_EQ(unknown, colour_at({3.5, 1.5}));
}

TEST(MapPngTest, RejectsNothingToDrawAndFarAwayPoses) {
  const OccupancyGrid empty{OccupancyGridOptions()};
  Status status = WriteMapPng(empty, {}, TempPath("nothing.png"));
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("nothing.png"));
  EXPECT_THAT(status.message(), HasSubstr("no observed cell and no pose"));
  status = WriteMapPng(SquareRoomGrid(), {{Pose2(0, 0, 0), Pose2(1e7, 0, 0)}}, TempPath("far.png"));
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("limit 1e8"));
  status = WriteMapPng(SquareRoomGrid(), {{Pose2(NAN, 0, 0)}}, TempPath("nan.png"));
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("trajectory 0 pose 0 is not finite"));
  // Trajectories alone (no map) still draw.
  status = WriteMapPng(empty, {{Pose2(0, 0, 0), Pose2(1, 1, 0)}}, TempPath("only_path.png"));
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_FALSE(cv::imread(TempPath("only_path.png")).empty());
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

TEST(MapReaderTest, GridLayerRoundTripsThroughPgmYaml) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> state(0, 2);
  // An odd size, an origin off the lattice of whole metres, a resolution other than 5 cm.
  GridLayer layer = GridLayer::Filled(GridGeometry(Eigen::Vector2d(-1.25, 2.5), 0.1, 7, 5),
                                      CellState::kUnknown);
  for (CellState& cell : layer.cells) cell = static_cast<CellState>(state(rng));
  layer.set({0, 0}, CellState::kOccupied);  // the lower-left cell: last raster row, first byte
  const std::string base = TempPath("layer");
  const Status written = WriteMapPgmYaml(layer, base, {"a comment", "another"});
  ASSERT_TRUE(written.ok()) << written.message();
  const std::string yaml = ReadFile(base + ".yaml");
  EXPECT_EQ(0u, yaml.find("# a comment\n# another\nimage: map_io_test_layer.pgm\n"));
  // Image row 0 is the top: the lower-left cell is the first byte of the last row.
  const std::string pgm = ReadFile(base + ".pgm");
  ASSERT_EQ(std::string("P5\n7 5\n255\n").size() + 35, pgm.size());
  EXPECT_EQ(static_cast<char>(kPgmOccupied), pgm[pgm.size() - 7]);

  GridLayer read;
  const Status status = ReadMapPgmYaml(base + ".yaml", &read);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(7, read.geometry.width());
  EXPECT_EQ(5, read.geometry.height());
  EXPECT_DOUBLE_EQ(0.1, read.geometry.resolution_meters());
  EXPECT_DOUBLE_EQ(-1.25, read.geometry.origin().x());
  EXPECT_DOUBLE_EQ(2.5, read.geometry.origin().y());
  EXPECT_TRUE(layer.cells == read.cells);
}

TEST(MapReaderTest, ReadsAnOccupancyGridMapBackCellForCell) {
  const OccupancyGrid grid = SquareRoomGrid();
  const std::string base = TempPath("room_read");
  ASSERT_TRUE(WriteMapPgmYaml(grid, base).ok());
  GridLayer read;
  const Status status = ReadMapPgmYaml(base + ".yaml", &read);
  ASSERT_TRUE(status.ok()) << status.message();
  CellIndex lo, hi;
  ObservedBox(grid, &lo, &hi);
  // The read map is the observed box plus the border, in the grid's own world frame.
  ASSERT_EQ(hi.x - lo.x + 1 + 2 * kMapBorderCells, read.geometry.width());
  for (int y = 0; y < read.geometry.height(); ++y) {
    for (int x = 0; x < read.geometry.width(); ++x) {
      const Eigen::Vector2d centre = read.geometry.CellCenter({x, y});
      const CellIndex c = grid.geometry().WorldToCell(centre);
      const CellState expected =
          grid.geometry().Contains(c) ? grid.State(c) : CellState::kUnknown;
      ASSERT_EQ(expected, read.at({x, y})) << x << "," << y;
    }
  }
}

TEST(MapReaderTest, FollowsMapServerOptions) {
  // Header comments, max value 100, negate 1, a relative image path in a sub-folder, quotes,
  // comments and unknown keys in the YAML.
  std::filesystem::create_directories(TempPath("sub"));
  std::string pgm = "P5\n# made by hand\n3 1\n100\n";
  pgm += std::string{static_cast<char>(0), static_cast<char>(50), static_cast<char>(100)};
  WriteText(TempPath("sub/hand.pgm"), pgm);
  WriteText(TempPath("hand.yaml"),
            "# hand made\nimage: \"map_io_test_sub/hand.pgm\"\nresolution: 0.5\norigin: [1, -2, 0]\n"
            "negate: 1\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n"
            "something_else: 3\n");
  GridLayer read;
  const Status status = ReadMapPgmYaml(TempPath("hand.yaml"), &read);
  ASSERT_TRUE(status.ok()) << status.message();
  // negate 1: p = v / max. 0 -> free, 0.5 -> unknown, 1 -> occupied.
  ASSERT_EQ(3u, read.cells.size());
  EXPECT_EQ(CellState::kFree, read.at({0, 0}));
  EXPECT_EQ(CellState::kUnknown, read.at({1, 0}));
  EXPECT_EQ(CellState::kOccupied, read.at({2, 0}));
  EXPECT_EQ(Eigen::Vector2d(1.0, -2.0), read.geometry.origin());
}

TEST(MapReaderTest, ErrorsNameTheFile) {
  const std::string yaml = TempPath("bad.yaml");
  const std::string image_line = "image: map_io_test_bad.pgm\n";  // TempPath("bad.pgm")
  WriteText(TempPath("bad.pgm"), "P5\n2 2\n255\n\xfe\xfe\xfe\xfe");
  GridLayer read;
  struct Case {
    std::string yaml_text;
    std::string expected;
  } cases[] = {
      {"resolution: 0.05\norigin: [0, 0, 0]\n", "bad.yaml: no 'image' key"},
      {image_line + "origin: [0, 0, 0]\n", "no 'resolution' key"},
      {image_line + "resolution: -1\norigin: [0, 0, 0]\n", "bad.yaml:2: resolution must be"},
      {image_line + "resolution: 0.05\norigin: [0, 0, 0.3]\n", "origin yaw 0.3 is not supported"},
      {image_line + "resolution: 0.05\norigin: 0 0 0\n", "origin must be `[x, y, yaw]`"},
      {image_line + "resolution: 0.05\norigin: [0, 0, 0]\nmode: scale\n", "mode 'scale'"},
      {image_line + "resolution 0.05\n", "bad.yaml:2: expected `key: value`"},
      {"image: missing.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "missing.pgm"},
  };
  for (const Case& c : cases) {
    WriteText(yaml, c.yaml_text);
    const Status status = ReadMapPgmYaml(yaml, &read);
    ASSERT_FALSE(status.ok()) << c.yaml_text;
    EXPECT_THAT(status.message(), HasSubstr(c.expected)) << c.yaml_text;
  }
  EXPECT_THAT(ReadMapPgmYaml(TempPath("no_such.yaml"), &read).message(),
              HasSubstr("no_such.yaml"));
  // Image problems name the image.
  WriteText(yaml, image_line + "resolution: 0.05\norigin: [0, 0, 0]\n");
  WriteText(TempPath("bad.pgm"), "P2\n2 2\n255\n0 0 0 0\n");
  EXPECT_THAT(ReadMapPgmYaml(yaml, &read).message(), HasSubstr("bad.pgm' is not a binary PGM"));
  WriteText(TempPath("bad.pgm"), "P5\n2 2\n255\n\xfe");
  EXPECT_THAT(ReadMapPgmYaml(yaml, &read).message(), HasSubstr("raster is truncated"));
  WriteText(TempPath("bad.pgm"), "P5\n2 x\n255\n");
  EXPECT_THAT(ReadMapPgmYaml(yaml, &read).message(), HasSubstr("PGM height 'x'"));
}

}  // namespace
}  // namespace hetslam
