// The true map layers of a simulated world (paper §III-D/E), for scoring a run's map layers
// (core/map_layers.h): what a perfect mapper would put in each layer, in the world frame.
//
//   walls            every wall segment (`wall` and `box` statements: full-height vertical
//                    surfaces, the invariants under the 2.5D assumption).
//   furniture        the footprint outline of every prism whose top is at or above H: table
//                    legs and tops, shelf parts, obstacles at least H tall. Structure a level
//                    2D laser sees as an obstacle at some height; raised parts (a table's top,
//                    a shelf's upper part) are included, so no single laser height sees all
//                    of it (a humanoid's laser at 0.5 m never sees a 0.74 m table top).
//   floor_obstacles  the footprint outline of every prism whose top is below H: the random
//                    obstacles and `obstacle` boxes of the shipped scenarios, and any table
//                    leg or shelf part lower than H.
//
// H = floor_obstacle_max_height_meters, by default 0.5 m: the height of the humanoid's laser
// with its head level (datasets/sim/robot_spec.h). Whatever is lower is passed over by that
// level scan and reaches a humanoid's map only through tilted scans, which hit it at heights
// that change with the head pitch: the objects that break the 2.5D assumption, which the paper
// marks as floor obstacles (null score in matching, occupied for the planner). The rule is
// per prism (one part of an object) and by height only, not by the scenario statement.
//
// Rasterisation: one grid for all three layers, `resolution_meters` cells on the world lattice
// (the origin a whole number of cells from the world origin) covering every wall end point and
// prism vertex plus `border_cells` cells on each side. A cell is occupied in a layer when one
// of the layer's segments (a wall, an edge of a footprint) passes through it: the segment's
// cells by grid traversal, a point on a cell boundary belonging to the cell above / to the
// right (core/grid_geometry.h: cells are half-open), a segment through a cell corner stepping
// diagonally. Positions within 1e-6 cells of a grid line are taken to be on it, so that
// geometry on whole multiples of the resolution rasterises as written. A cell whose centre lies
// strictly inside a footprint and that no outline marks is unknown in the prism's layer
// (map_server's 205): occupied by the object, but only a beam from above can hit it there
// (core/map_layers.h counts a run cell on it as correct, and does not ask for it in recall).
// Every other cell is free: the truth is known everywhere.
#ifndef HETSLAM_DATASETS_SIM_TRUTH_LAYERS_H_
#define HETSLAM_DATASETS_SIM_TRUTH_LAYERS_H_

#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/map_io.h"
#include "core/status.h"
#include "datasets/sim/world.h"

namespace hetslam {
namespace sim {

struct TruthLayerOptions {
  double resolution_meters = 0.05;
  // H above: a prism whose top (z_max) is below this is a floor obstacle, else furniture.
  double floor_obstacle_max_height_meters = 0.5;
  int border_cells = kMapBorderCells;

  // Resolution in (0, 10] m, H in (0, 100] m, border in [0, 1000] cells.
  bool IsValid(std::string* error) const;
};

enum class TruthLayer { kWalls, kFurniture, kFloorObstacles };

// The layer's file stem: "walls", "furniture", "floor_obstacles" (core/map_layers.h).
const char* TruthLayerName(TruthLayer layer);

// kFloorObstacles when prism.z_max_meters < H, else kFurniture.
TruthLayer ClassifyPrism(const Prism& prism, const TruthLayerOptions& options);

struct TruthLayerMaps {
  GridLayer walls;
  GridLayer furniture;
  GridLayer floor_obstacles;
};

// The three layers of `world` (on one grid, see above). Errors: invalid options, a world
// with neither walls nor prisms, a grid over 4e8 cells.
Status RasterizeTruthLayers(const World& world, const TruthLayerOptions& options,
                            TruthLayerMaps* maps);

// What one robot's laser returned from, per true layer: the world-lattice cells (x = floor(px
// / resolution), y likewise) of its beams' noise-free end points on walls, on furniture and on
// floor obstacles (floor and ceiling hits, and beams without a return, are not kept). A true
// cell no beam ever reached (the far side of an obstacle, a room the robot never looked into)
// cannot be mapped from that log, so recall is also scored against the seen cells.
struct SeenCells {
  std::set<std::pair<int, int>> walls, furniture, floor_obstacles;
};
// Adds the end point `p_world` of a beam that hit `layer` (CHECK-fails on a non-finite point).
void AddSeenPoint(const Eigen::Vector2d& p_world, TruthLayer layer, const TruthLayerOptions& options,
                  SeenCells* seen);
// `maps` restricted to their seen cells: a true cell stays occupied when an end point of its
// layer lies in it or in one of its eight neighbours (an end point on an outline can round into
// the next cell), every other cell is free. Same grid as `maps`.
TruthLayerMaps SeenTruthLayers(const TruthLayerMaps& maps, const SeenCells& seen);

// Writes <directory>/walls.pgm/.yaml, furniture.pgm/.yaml and floor_obstacles.pgm/.yaml
// (core/map_io.h, WriteMapPgmYaml: occupied 0, free 254; the YAML origin is the world
// position of the lower-left corner of the lower-left cell; comment lines at the top of each
// YAML state the layer's rule and H). `directory` is created if missing. `paths` (optional)
// receives the six file paths in that order.
// `seen_by` non-empty: the maps are SeenTruthLayers of that robot, and the YAML comments say so.
Status WriteTruthLayers(const std::string& directory, const TruthLayerMaps& maps,
                        const TruthLayerOptions& options, std::vector<std::string>* paths,
                        const std::string& seen_by = "");

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_TRUTH_LAYERS_H_
