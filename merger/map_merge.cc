#include "merger/map_merge.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "glog/logging.h"

namespace hetslam {

bool MapMergeOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(occupied_log_odds > 0)) msg << "occupied_log_odds must be > 0; ";
  if (!(free_log_odds < 0)) msg << "free_log_odds must be < 0; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

int MergeMapAsOneObservation(const OccupancyGrid& teammate, const Pose2& merged_T_teammate,
                             const MapMergeOptions& options, OccupancyGrid* merged) {
  std::string error;
  CHECK(options.IsValid(&error)) << "invalid MapMergeOptions: " << error;
  const CellIndex lo = teammate.observed_min(), hi = teammate.observed_max();
  if (hi.x < lo.x || hi.y < lo.y) return 0;  // nothing observed
  const GridGeometry& source = teammate.geometry();
  // The teammate's observed box in the merged frame.
  const Eigen::Vector2d box_min = source.CellMinCorner(lo);
  const Eigen::Vector2d box_max = source.CellMinCorner({hi.x + 1, hi.y + 1});
  Eigen::Vector2d min = Eigen::Vector2d::Constant(INFINITY), max = Eigen::Vector2d::Constant(-INFINITY);
  for (const Eigen::Vector2d& corner : {box_min, box_max, Eigen::Vector2d(box_min.x(), box_max.y()),
                                        Eigen::Vector2d(box_max.x(), box_min.y())}) {
    const Eigen::Vector2d p = merged_T_teammate * corner;
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  // A teammate placed far away (a wrong or corrupt link) would grow the merged grid past its
  // size limit: nothing is merged (issue #16).
  if (!merged->CanContain(min, max)) return 0;
  merged->EnsureContains(min, max);
  const GridGeometry& target = merged->geometry();
  const CellIndex first = target.WorldToCell(min), last = target.WorldToCell(max);
  const Pose2 teammate_T_merged = merged_T_teammate.inverse();
  // Decide every cell first, then add: the grid does not grow inside the box (EnsureContains
  // above), but keep the reads of `teammate` apart from the writes in case both are one grid.
  std::vector<std::pair<Eigen::Vector2d, float>> observations;
  for (int y = first.y; y <= last.y; ++y) {
    for (int x = first.x; x <= last.x; ++x) {
      const Eigen::Vector2d centre = target.CellCenter({x, y});
      const CellIndex c = source.WorldToCell(teammate_T_merged * centre);
      if (!source.Contains(c)) continue;
      const CellState state = teammate.State(c);
      if (state == CellState::kUnknown) continue;
      observations.emplace_back(centre, static_cast<float>(state == CellState::kOccupied ? options.occupied_log_odds
                                                                                          : options.free_log_odds));
    }
  }
  for (const auto& [centre, delta] : observations) merged->AddCellObservation(centre, delta);
  return static_cast<int>(observations.size());
}

namespace {

// Occupied cells of `from` checked against `to`, with from's frame at to_T_from in to's; a cell
// whose highest hit is below `passed_over_below` (metres; -inf: none) does not conflict.
void CountAgreement(const OccupancyGrid& from, const OccupancyGrid& to, const Pose2& to_T_from, int tolerance_cells,
                    double passed_over_below, MapAgreement* agreement) {
  const CellIndex lo = from.observed_min(), hi = from.observed_max();
  const GridGeometry& source = from.geometry();
  const GridGeometry& target = to.geometry();
  for (int y = lo.y; y <= hi.y; ++y) {
    for (int x = lo.x; x <= hi.x; ++x) {
      if (from.State(CellIndex{x, y}) != CellState::kOccupied) continue;
      const CellIndex c = target.WorldToCell(to_T_from * source.CellCenter({x, y}));
      if (!target.Contains(c)) continue;
      const CellState state = to.State(c);
      if (state == CellState::kUnknown) continue;
      bool near_occupied = state == CellState::kOccupied;
      for (int dy = -tolerance_cells; dy <= tolerance_cells && !near_occupied; ++dy) {
        for (int dx = -tolerance_cells; dx <= tolerance_cells && !near_occupied; ++dx) {
          const CellIndex n{c.x + dx, c.y + dy};
          near_occupied = target.Contains(n) && to.State(n) == CellState::kOccupied;
        }
      }
      double highest_hit;
      if (near_occupied) {
        ++agreement->agreeing;
      } else if (std::isfinite(passed_over_below) && from.HighestHit({x, y}, &highest_hit) &&
                 highest_hit < passed_over_below) {
        ++agreement->passed_over;  // `state` is free here, its rays maybe above
      } else {
        ++agreement->conflicting;  // `state` is free here
      }
    }
  }
}

}  // namespace

double MapAgreement::ConflictFraction() const {
  const int total = agreeing + conflicting;
  return total > 0 ? static_cast<double>(conflicting) / static_cast<double>(total) : 1.0;
}

MapAgreement CompareMaps(const OccupancyGrid& a, const OccupancyGrid& b, const Pose2& a_T_b, int tolerance_cells,
                         const MapHeights& heights) {
  CHECK(heights.margin_meters >= 0) << "CompareMaps: negative height margin " << heights.margin_meters;
  // Hits below a map's lowest ray less the margin may stand under its rays.
  const auto below = [&](const std::optional<double>& lowest_ray) {
    return lowest_ray.has_value() ? *lowest_ray - heights.margin_meters : -std::numeric_limits<double>::infinity();
  };
  MapAgreement agreement;
  CountAgreement(b, a, a_T_b, tolerance_cells, below(heights.a_lowest_ray_meters), &agreement);
  CountAgreement(a, b, a_T_b.inverse(), tolerance_cells, below(heights.b_lowest_ray_meters), &agreement);
  return agreement;
}

int DropWallsSeenThrough(const OccupancyGrid& teammate, const Pose2& walls_T_teammate,
                         double min_surface_distance_meters, OccupancyGrid* walls) {
  CHECK(min_surface_distance_meters >= 0) << "DropWallsSeenThrough: negative distance";
  CHECK(!walls->frozen() && !teammate.frozen()) << "DropWallsSeenThrough reads hit points: grids not frozen";
  const GridGeometry& wall_cells = walls->geometry();
  const GridGeometry& mate = teammate.geometry();
  const Pose2::PointTransform to_teammate(walls_T_teammate.inverse());
  const int reach = static_cast<int>(std::ceil(min_surface_distance_meters / mate.resolution_meters()));
  const double min_squared = min_surface_distance_meters * min_surface_distance_meters;
  std::vector<CellIndex> seen_through;
  const CellIndex lo = walls->observed_min(), hi = walls->observed_max();
  for (int y = lo.y; y <= hi.y; ++y) {
    for (int x = lo.x; x <= hi.x; ++x) {
      const int i = wall_cells.LinearIndex({x, y});
      if (!walls->IsOccupied(i)) continue;
      // Where the robot's laser met the surface, in the teammate's map.
      const Eigen::Vector2d q = to_teammate(walls->HitPoint(i));
      const CellIndex c = mate.WorldToCell(q);
      if (!mate.Contains(c) || teammate.State(c) != CellState::kFree) continue;
      bool surface_near = false;
      for (int dy = -reach; dy <= reach && !surface_near; ++dy) {
        for (int dx = -reach; dx <= reach && !surface_near; ++dx) {
          const CellIndex n{c.x + dx, c.y + dy};
          if (!mate.Contains(n)) continue;
          const int j = mate.LinearIndex(n);
          surface_near = teammate.IsOccupied(j) && (teammate.HitPoint(j) - q).squaredNorm() < min_squared;
        }
      }
      if (!surface_near) seen_through.push_back({x, y});
    }
  }
  return walls->ForgetCells(seen_through);
}

}  // namespace hetslam
