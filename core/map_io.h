// Writing and reading maps, and writing pictures: the ROS map_server PGM + YAML pair, and PNG
// images written by a small self-contained encoder (no zlib, no OpenCV: core depends on Eigen
// and glog only).
//
// Image convention (core/grid_geometry.h): image row 0 is the TOP of the map, i.e. the
// largest y; image column c is grid column x. Maps are cropped to the observed bounding box
// of the grid plus `kMapBorderCells` cells on each side.
#ifndef HETSLAM_CORE_MAP_IO_H_
#define HETSLAM_CORE_MAP_IO_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/occupancy_grid.h"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

// Cells of unknown space kept around the observed bounding box in written maps.
constexpr int kMapBorderCells = 5;

// Grey levels of the map_server "trinary" convention (negate 0): p = (255 - v) / 255, so
// occupied (p = 1) > occupied_thresh 0.65, free (p = 0.004) < free_thresh 0.196, and unknown
// (p = 0.196078...) falls between the thresholds.
constexpr uint8_t kPgmOccupied = 0;
constexpr uint8_t kPgmFree = 254;
constexpr uint8_t kPgmUnknown = 205;

// A map as one state per cell: what a map_server PGM + YAML pair holds, in memory. The cells
// follow core/grid_geometry.h (row y counts UP from the minimum corner `geometry.origin()`,
// linear index y * width + x), NOT the image's top-down rows; the readers and writers below
// do the flip. A map layer of a run, or a true layer of a simulated world.
struct GridLayer {
  GridGeometry geometry;
  std::vector<CellState> cells;  // geometry.num_cells() entries

  // A layer of `geometry` with every cell in `state`.
  static GridLayer Filled(const GridGeometry& geometry, CellState state) {
    return {geometry, std::vector<CellState>(static_cast<size_t>(geometry.num_cells()), state)};
  }
  CellState at(const CellIndex& c) const { return cells[geometry.LinearIndex(c)]; }
  void set(const CellIndex& c, CellState state) { cells[geometry.LinearIndex(c)] = state; }
  int CountCells(CellState state) const;
};

// Writes `<path_without_extension>.pgm` (binary P5, 8-bit, values above) and
// `<path_without_extension>.yaml` with
//   image: <basename>.pgm, resolution: <m/cell>, origin: [x, y, 0.0],
//   negate: 0, occupied_thresh: 0.65, free_thresh: 0.196
// where origin is the world position of the lower-left corner of the lower-left pixel (the
// minimum corner of the cropped area), as map_server expects. An error names the file; a
// grid with no observed cell is an error.
Status WriteMapPgmYaml(const OccupancyGrid& grid, const std::string& path_without_extension);

// The same pair for a GridLayer, every cell written (no cropping, no border added): the YAML
// origin is geometry.origin(). `yaml_comment_lines` are written first, each as `# line`
// (map_server and ReadMapPgmYaml skip them). An error names the file; an empty layer is an
// error. CHECK-fails when the cell count does not match the geometry.
Status WriteMapPgmYaml(const GridLayer& layer, const std::string& path_without_extension,
                       const std::vector<std::string>& yaml_comment_lines = {});

// Reads a map_server map: the YAML at `yaml_path` (`key: value` lines, `#` comments; keys
// image, resolution and origin required; negate (0/1, default 0), occupied_thresh (0.65),
// free_thresh (0.196) and mode (only `trinary`) optional; others ignored) and the image it
// names (relative to the YAML's folder unless absolute; binary PGM P5, max value <= 255).
// A pixel v becomes p = (255 - v) / 255 (negate 1: v / 255, after scaling v to 0..255):
// occupied when p > occupied_thresh, free when p < free_thresh, unknown otherwise, as
// map_server's trinary mode does; the grey levels above read back as written. The origin's
// yaw must be 0 (a rotated map_server origin is not supported). Errors name the file (and the
// YAML line).
Status ReadMapPgmYaml(const std::string& yaml_path, GridLayer* layer);

// Writes an 8-bit PNG, greyscale (channels = 1) or RGB (channels = 3). `pixels` is row-major,
// row 0 at the top, channels interleaved: size width * height * channels. The image data is
// one deflate block with the fixed Huffman codes (runs of a byte and of the row above: maps
// shrink ~100x) with the zlib Adler-32 and chunk CRC-32 that every decoder checks. Width and
// height must be in [1, 2^31 - 1].
Status WritePng(const std::string& path, int width, int height, int channels,
                const std::vector<uint8_t>& pixels);
// The same from `pixels` pointing at width * height * channels bytes (an image's own buffer,
// with no copy into a vector). A separate name: `{0}` would otherwise pick this overload.
Status WritePngFromBuffer(const std::string& path, int width, int height, int channels, const uint8_t* pixels);

// The same PNG written a band of rows at a time, so that the image need not be in memory whole
// (the map picture: issue #15): the bytes of WritePngFromBuffer on all the rows, however they
// are split. The file appears under `path` only when Finish succeeds (until then it is `path` +
// ".tmp", removed if the writer is destroyed unfinished). Holds the rows it has not encoded yet
// and the one before them (a position's encoding reads the row above and 258 bytes ahead).
class PngRowWriter {
 public:
  PngRowWriter();
  ~PngRowWriter();
  PngRowWriter(const PngRowWriter&) = delete;
  PngRowWriter& operator=(const PngRowWriter&) = delete;

  // Errors: a size or channel count WritePng refuses, a file that cannot be opened, a second
  // Open.
  Status Open(const std::string& path, int width, int height, int channels);
  // The next `count` rows (each width * channels bytes, one after the other); an error beyond
  // the image's height.
  Status AddRows(const uint8_t* rows, int count);
  // After the last row: writes the end of the stream and moves the file into place; an error
  // when rows are missing or the file could not be written.
  Status Finish();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Renders the map (occupied black, free white, unknown grey, as in the PGM) and draws each
// trajectory (world_T_robot poses, in the grid's world frame) as a 1-pixel polyline in its own
// colour, with a filled disc at its first pose, and writes it as an RGB PNG at one pixel per
// cell. The picture covers the observed map and every trajectory pose, plus the border.
// Errors: nothing to draw (no observed cell and no pose), a non-finite pose, or a picture
// over 100 million pixels.
Status WriteMapPng(const OccupancyGrid& grid, const std::vector<std::vector<Pose2>>& trajectories,
                   const std::string& path);

// The colour (RGB) WriteMapPng uses for trajectory `index`; colours repeat after 8.
void TrajectoryColor(int index, uint8_t rgb[3]);

}  // namespace hetslam

#endif  // HETSLAM_CORE_MAP_IO_H_
