// Map pictures a person can read: the occupancy map upscaled so that every cell is a crisp
// block of pixels, walls and other structure in dark colours, floor obstacles in amber,
// trajectories as smooth coloured lines with a start disc and a heading arrow at the end,
// markers (tags, inter-robot constraints) with their labels, a scale bar and a legend that
// lists only what the picture shows. (core/map_io.h WriteMapPng is the one-pixel-per-cell
// picture without any of this; core stays free of OpenCV.)
//
// Layout of the written PNG (RGB):
//
//   +---------------------------+--------+
//   | map part                  | legend |
//   | (starts at pixel (0, 0))  | panel  |
//   +---------------------------+        |
//   | scale bar strip           |        |
//   +---------------------------+--------+
//
// The map part covers the union of the observed cells of both grids, every trajectory pose,
// every marker and marker line end, plus `border_cells` unknown cells on each side, on the
// cell lattice of the structure grid. It is north up in the grid convention of
// core/grid_geometry.h: x grows to the right, y upwards, pixel row 0 is the largest y.
//
// Cell colours (RGB), in order of precedence:
//   structure occupied, kWall label bit          -> kMapPictureWallRgb       (black)
//   structure occupied, only the kFloorObstacle
//     label bit (e.g. a planner grid)            -> kMapPictureFloorObstacleRgb
//   structure occupied, otherwise                -> kMapPictureStructureRgb  (dark blue-grey)
//   floor_obstacles occupied                     -> kMapPictureFloorObstacleRgb (amber)
//   structure free                               -> kMapPictureFreeRgb       (white)
//   otherwise (unknown, or outside the grid)     -> kMapPictureUnknownRgb    (light grey)
// Label bits are core/laser_scan.h PointLabel positions in OccupancyGrid::LabelMask.
// Trajectory k is drawn in core/map_io.h TrajectoryColor(k), as in WriteMapPng.
//
// Deterministic: the same input gives the same bytes (OpenCV drawing and the PNG encoder
// run on one thread and hold no state between calls).
#ifndef HETSLAM_MERGER_MAP_PICTURE_H_
#define HETSLAM_MERGER_MAP_PICTURE_H_

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/map_io.h"
#include "core/occupancy_grid.h"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

using Rgb = std::array<uint8_t, 3>;

constexpr Rgb kMapPictureWallRgb = {0, 0, 0};
constexpr Rgb kMapPictureStructureRgb = {52, 73, 94};
// Amber: stands apart from the trajectory palette (whose orange is TrajectoryColor(3)).
constexpr Rgb kMapPictureFloorObstacleRgb = {255, 184, 0};
constexpr Rgb kMapPictureFreeRgb = {255, 255, 255};
constexpr Rgb kMapPictureUnknownRgb = {205, 205, 205};

struct MapPictureOptions {
  // The map part is upscaled by the smallest integer factor (pixels per cell, nearest
  // neighbour) that makes its shorter side at least this long...
  int min_short_side_pixels = 800;
  // ...unless the map part would then exceed this many pixels: the factor is lowered to fit,
  // down to one pixel per cell; a map part larger than this even then is an error.
  int max_pixels = 40'000'000;
  // Unknown cells around everything drawn.
  int border_cells = kMapBorderCells;
  // Width of the trajectory polylines (anti-aliased).
  int trajectory_width_pixels = 2;
  // Height of a capital letter in the legend, scale bar and marker labels.
  int text_height_pixels = 14;
  // Line widths, glyphs and text grow by max(1, shorter map side / 1000) (an integer) so that
  // a large picture stays readable when shown shrunk to a screen.

  bool IsValid(std::string* error) const;
};

struct MapPictureTrajectory {
  std::string name;          // legend entry ("trajectory <k>" when empty)
  std::vector<Pose2> poses;  // world_T_robot, in the structure grid's world frame
};

struct MapPictureMarker {
  enum class Kind {
    kTag,         // a fiducial's position: black square with a white centre
    kConstraint,  // an end of an inter-robot constraint: white diamond, black outline
    kPoint,       // anything else: black cross
  };
  Kind kind = Kind::kPoint;
  Eigen::Vector2d world = Eigen::Vector2d::Zero();  // metres, structure grid's world frame
  std::string label;                                // drawn beside the marker; may be empty
  // When set, a dashed dark grey line from `world` to this point (e.g. the other robot's end of
  // an inter-robot constraint), drawn under trajectories and markers.
  std::optional<Eigen::Vector2d> line_to_world;
};

// Where things landed in a written picture; see WriteMapPicture's `layout`.
struct MapPictureLayout {
  int width_pixels = 0;  // whole picture
  int height_pixels = 0;
  int map_width_pixels = 0;  // map part, at pixels [0, map_width) x [0, map_height)
  int map_height_pixels = 0;
  int pixels_per_cell = 0;
  // Structure-grid cells at the map part's bottom-left and top-right corners (may lie outside
  // the grid).
  CellIndex min_cell;
  CellIndex max_cell;
  // World position of the map part's bottom-left corner (min corner of min_cell), metres.
  Eigen::Vector2d map_min_corner_world = Eigen::Vector2d::Zero();
  double meters_per_pixel = 0.0;
  double scale_bar_meters = 0.0;

  // Continuous pixel coordinates (column, row) of a world point: pixel (c, r) covers
  // [c, c + 1) x [r, r + 1), row 0 at the top of the map part.
  Eigen::Vector2d WorldToPixel(const Eigen::Vector2d& p_world) const {
    return {(p_world.x() - map_min_corner_world.x()) / meters_per_pixel,
            map_height_pixels - (p_world.y() - map_min_corner_world.y()) / meters_per_pixel};
  }
};

// Renders the picture described above and writes it to `path` as a PNG. `floor_obstacles` may
// be null; when given it must have the structure grid's resolution (its origin may differ) and
// is sampled at the centres of the structure grid's cells. Both grids are only read during the
// call. `layout` (optional) receives the picture's geometry.
// Errors, each naming `path`: invalid options, different grid resolutions, a non-finite pose
// or marker position, nothing to draw (no observed cell, no pose, no marker), a map part over
// max_pixels at one pixel per cell, an encoder failure, or a file that cannot be written.
Status WriteMapPicture(const std::string& path, const OccupancyGrid& structure,
                       const OccupancyGrid* floor_obstacles,
                       const std::vector<MapPictureTrajectory>& trajectories,
                       const std::vector<MapPictureMarker>& markers,
                       const MapPictureOptions& options, MapPictureLayout* layout = nullptr);

}  // namespace hetslam

#endif  // HETSLAM_MERGER_MAP_PICTURE_H_
