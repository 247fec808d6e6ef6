#include "datasets/sim/truth_layers.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <sstream>
#include <system_error>

#include "core/map_layers.h"
#include "datasets/sim/sim_text.h"
#include "glog/logging.h"

namespace hetslam {
namespace sim {
namespace {

// A lattice coordinate (world metres / resolution) within 1e-6 of a whole number is taken to
// be that number, so that a wall written on a grid line lies on it despite rounding.
double SnapToLattice(double u) {
  const double nearest = std::round(u);
  return std::abs(u - nearest) < 1e-6 ? nearest : u;
}

// Marks every cell the segment a..b passes through (Amanatides–Woo traversal in continuous
// cell coordinates; both end cells included; a tie, the segment through a cell corner,
// steps diagonally).
void RasterizeSegment(const Eigen::Vector2d& a_world, const Eigen::Vector2d& b_world,
                      GridLayer* layer) {
  const GridGeometry& g = layer->geometry;
  const double r = g.resolution_meters();
  // The origin is a whole number of cells from the world origin: subtract in cells, exactly.
  const Eigen::Vector2d origin_cells(std::round(g.origin().x() / r), std::round(g.origin().y() / r));
  const Eigen::Vector2d a(SnapToLattice(a_world.x() / r) - origin_cells.x(),
                          SnapToLattice(a_world.y() / r) - origin_cells.y());
  const Eigen::Vector2d b(SnapToLattice(b_world.x() / r) - origin_cells.x(),
                          SnapToLattice(b_world.y() / r) - origin_cells.y());
  CellIndex c{static_cast<int>(std::floor(a.x())), static_cast<int>(std::floor(a.y()))};
  const CellIndex end{static_cast<int>(std::floor(b.x())), static_cast<int>(std::floor(b.y()))};
  const Eigen::Vector2d d = b - a;
  const int step_x = d.x() > 0 ? 1 : -1;
  const int step_y = d.y() > 0 ? 1 : -1;
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const double t_delta_x = d.x() != 0.0 ? std::abs(1.0 / d.x()) : kInfinity;
  const double t_delta_y = d.y() != 0.0 ? std::abs(1.0 / d.y()) : kInfinity;
  double t_max_x = d.x() != 0.0 ? (step_x > 0 ? c.x + 1 - a.x() : a.x() - c.x) * t_delta_x : kInfinity;
  double t_max_y = d.y() != 0.0 ? (step_y > 0 ? c.y + 1 - a.y() : a.y() - c.y) * t_delta_y : kInfinity;
  const int max_steps = std::abs(end.x - c.x) + std::abs(end.y - c.y);
  CHECK(g.Contains(c) && g.Contains(end)) << "segment outside the truth grid";
  layer->set(c, CellState::kOccupied);
  for (int n = 0; n < max_steps && !(c == end); ++n) {
    const double t_next = std::min(t_max_x, t_max_y);
    if (t_max_x <= t_next) {
      t_max_x += t_delta_x;
      c.x += step_x;
    }
    if (t_max_y <= t_next) {
      t_max_y += t_delta_y;
      c.y += step_y;
    }
    if (!g.Contains(c)) break;
    layer->set(c, CellState::kOccupied);
  }
  layer->set(end, CellState::kOccupied);
}

void RasterizeOutline(const std::vector<Eigen::Vector2d>& polygon, GridLayer* layer) {
  for (size_t i = 0; i < polygon.size(); ++i) {
    RasterizeSegment(polygon[i], polygon[(i + 1) % polygon.size()], layer);
  }
}

// Marks unknown the free cells whose centre lies strictly inside the convex, counter-clockwise
// `polygon` (after every outline is drawn: an outline cell stays occupied).
void MarkInterior(const std::vector<Eigen::Vector2d>& polygon, GridLayer* layer) {
  const GridGeometry& g = layer->geometry;
  Eigen::AlignedBox2d box;
  for (const Eigen::Vector2d& p : polygon) box.extend(p);
  const CellIndex lo = g.WorldToCell(box.min()), hi = g.WorldToCell(box.max());
  for (int y = std::max(0, lo.y); y <= std::min(g.height() - 1, hi.y); ++y) {
    for (int x = std::max(0, lo.x); x <= std::min(g.width() - 1, hi.x); ++x) {
      const Eigen::Vector2d c = g.CellCenter({x, y});
      bool inside = true;
      for (size_t i = 0; i < polygon.size() && inside; ++i) {
        const Eigen::Vector2d edge = polygon[(i + 1) % polygon.size()] - polygon[i];
        const Eigen::Vector2d to_c = c - polygon[i];
        inside = edge.x() * to_c.y() - edge.y() * to_c.x() > 0.0;
      }
      if (inside && layer->at({x, y}) == CellState::kFree) layer->set({x, y}, CellState::kUnknown);
    }
  }
}

}  // namespace

bool TruthLayerOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(resolution_meters > 0.0 && resolution_meters <= 10.0)) {
    msg << "resolution_meters must be in (0, 10] (got " << resolution_meters << "); ";
  }
  if (!(floor_obstacle_max_height_meters > 0.0 && floor_obstacle_max_height_meters <= 100.0)) {
    msg << "floor_obstacle_max_height_meters must be in (0, 100] (got "
        << floor_obstacle_max_height_meters << "); ";
  }
  if (border_cells < 0 || border_cells > 1000) {
    msg << "border_cells must be in [0, 1000] (got " << border_cells << "); ";
  }
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

const char* TruthLayerName(TruthLayer layer) {
  switch (layer) {
    case TruthLayer::kWalls: return kWallsLayer;
    case TruthLayer::kFurniture: return kFurnitureLayer;
    case TruthLayer::kFloorObstacles: return kFloorObstaclesLayer;
  }
  return "unknown";
}

TruthLayer ClassifyPrism(const Prism& prism, const TruthLayerOptions& options) {
  return prism.z_max_meters < options.floor_obstacle_max_height_meters ? TruthLayer::kFloorObstacles
                                                                       : TruthLayer::kFurniture;
}

Status RasterizeTruthLayers(const World& world, const TruthLayerOptions& options,
                            TruthLayerMaps* maps) {
  CHECK(maps != nullptr);
  std::string error;
  if (!options.IsValid(&error)) return Status::Error("invalid truth layer options: " + error);
  if (world.walls().empty() && world.prisms().empty()) {
    return Status::Error("the world has no wall and no prism: no truth layer to draw");
  }
  const double r = options.resolution_meters;
  Eigen::AlignedBox2d bounds = world.Bounds();
  for (const Prism& prism : world.prisms()) {
    for (const Eigen::Vector2d& p : prism.footprint) bounds.extend(p);
  }
  // Whole cells on the world lattice: the same origin whatever the order of the geometry.
  const double lo_x = std::floor(SnapToLattice(bounds.min().x() / r)) - options.border_cells;
  const double lo_y = std::floor(SnapToLattice(bounds.min().y() / r)) - options.border_cells;
  const double hi_x = std::floor(SnapToLattice(bounds.max().x() / r)) + options.border_cells;
  const double hi_y = std::floor(SnapToLattice(bounds.max().y() / r)) + options.border_cells;
  const double cells = (hi_x - lo_x + 1) * (hi_y - lo_y + 1);
  if (cells > 4e8) {
    return Status::Error("the truth grid would have " + std::to_string(cells) +
                         " cells (limit 4e8): is the world that large?");
  }
  const GridGeometry geometry(Eigen::Vector2d(lo_x * r, lo_y * r), r,
                              static_cast<int>(hi_x - lo_x + 1), static_cast<int>(hi_y - lo_y + 1));
  TruthLayerMaps result{GridLayer::Filled(geometry, CellState::kFree),
                        GridLayer::Filled(geometry, CellState::kFree),
                        GridLayer::Filled(geometry, CellState::kFree)};
  for (const WallSegment& wall : world.walls()) RasterizeSegment(wall.a, wall.b, &result.walls);
  for (const Prism& prism : world.prisms()) {
    RasterizeOutline(prism.footprint, ClassifyPrism(prism, options) == TruthLayer::kFurniture
                                          ? &result.furniture
                                          : &result.floor_obstacles);
  }
  for (const Prism& prism : world.prisms()) {
    MarkInterior(prism.footprint, ClassifyPrism(prism, options) == TruthLayer::kFurniture ? &result.furniture
                                                                                          : &result.floor_obstacles);
  }
  *maps = std::move(result);
  return Status::Ok();
}

void AddSeenPoint(const Eigen::Vector2d& p_world, TruthLayer layer, const TruthLayerOptions& options,
                  SeenCells* seen) {
  CHECK(seen != nullptr);
  CHECK(p_world.allFinite()) << "a seen end point must be finite";
  const double r = options.resolution_meters;
  const std::pair<int, int> cell(static_cast<int>(std::floor(SnapToLattice(p_world.x() / r))),
                                 static_cast<int>(std::floor(SnapToLattice(p_world.y() / r))));
  switch (layer) {
    case TruthLayer::kWalls: seen->walls.insert(cell); break;
    case TruthLayer::kFurniture: seen->furniture.insert(cell); break;
    case TruthLayer::kFloorObstacles: seen->floor_obstacles.insert(cell); break;
  }
}

namespace {

GridLayer SeenPart(const GridLayer& truth, const std::set<std::pair<int, int>>& seen) {
  GridLayer part = GridLayer::Filled(truth.geometry, CellState::kFree);
  const double r = truth.geometry.resolution_meters();
  // The grid's origin is a whole number of cells from the world origin.
  const int x0 = static_cast<int>(std::lround(truth.geometry.origin().x() / r));
  const int y0 = static_cast<int>(std::lround(truth.geometry.origin().y() / r));
  for (const auto& [wx, wy] : seen) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const CellIndex c{wx - x0 + dx, wy - y0 + dy};
        if (truth.geometry.Contains(c) && truth.at(c) == CellState::kOccupied) part.set(c, CellState::kOccupied);
      }
    }
  }
  return part;
}

}  // namespace

TruthLayerMaps SeenTruthLayers(const TruthLayerMaps& maps, const SeenCells& seen) {
  return {SeenPart(maps.walls, seen.walls), SeenPart(maps.furniture, seen.furniture),
          SeenPart(maps.floor_obstacles, seen.floor_obstacles)};
}

Status WriteTruthLayers(const std::string& directory, const TruthLayerMaps& maps,
                        const TruthLayerOptions& options, std::vector<std::string>* paths,
                        const std::string& seen_by) {
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec) return Status::Error("cannot create '" + directory + "': " + ec.message());
  const std::string h = Fixed(options.floor_obstacle_max_height_meters, 3);
  const struct {
    TruthLayer layer;
    const GridLayer* map;
    std::string rule;
  } layers[] = {
      {TruthLayer::kWalls, &maps.walls, "every wall segment (full-height walls and boxes)"},
      {TruthLayer::kFurniture, &maps.furniture,
       "footprint outlines of the prisms whose top is at or above " + h + " m"},
      {TruthLayer::kFloorObstacles, &maps.floor_obstacles,
       "footprint outlines of the prisms whose top is below " + h + " m"},
  };
  if (paths != nullptr) paths->clear();
  for (const auto& entry : layers) {
    const std::string base = (std::filesystem::path(directory) / TruthLayerName(entry.layer)).string();
    HETSLAM_RETURN_IF_ERROR(WriteMapPgmYaml(
        *entry.map, base,
        {std::string("hetslam simulator truth layer '") + TruthLayerName(entry.layer) +
             "', world frame (datasets/sim/truth_layers.h)",
         "occupied: " + entry.rule + (entry.layer == TruthLayer::kWalls ? "" : "; unknown: inside a footprint") +
             (seen_by.empty() ? std::string()
                              : ", only the cells within one cell of an end point of " + seen_by +
                                    "'s laser beams on them (SeenTruthLayers)")}));
    if (paths != nullptr) {
      paths->push_back(base + ".pgm");
      paths->push_back(base + ".yaml");
    }
  }
  return Status::Ok();
}

}  // namespace sim
}  // namespace hetslam
