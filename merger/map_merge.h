// Map merging (paper §V-B): a teammate's map enters a robot's map as ONE observation.
//
// Every cell the teammate has observed adds one observation to the corresponding cell of the
// merged map: +occupied_log_odds where the teammate's cell is occupied, +free_log_odds where it
// is free (the laser model's hit and miss increments by default), clamped as for scans. So cells
// the robot never saw take the teammate's state, while a wall built by many scans (log-odds near
// the clamp) barely moves: "only points that are originally unknown grid cells will be updated;
// all the others in most cases remain unchanged".
//
// Resampling: each merged-map cell whose centre falls inside the teammate's observed area takes
// the teammate's cell under that centre (nearest cell), so any rotation between the maps works.
#ifndef HETSLAM_MERGER_MAP_MERGE_H_
#define HETSLAM_MERGER_MAP_MERGE_H_

#include <optional>
#include <string>

#include "core/occupancy_grid.h"
#include "core/se2.h"

namespace hetslam {

struct MapMergeOptions {
  double occupied_log_odds = 0.85;  // one hit (OccupancyGridOptions::hit_log_odds)
  double free_log_odds = -0.4;      // one miss (OccupancyGridOptions::miss_log_odds)

  bool IsValid(std::string* error) const;
};

// Adds `teammate` (a grid in its own frame) to `merged` as one observation per cell, with the
// teammate's frame at `merged_T_teammate` in the merged map's frame. Returns the number of merged
// cells that received an observation: 0 when `merged` cannot grow to contain the teammate's map
// there (OccupancyGrid::CanContain: a non-finite or far-away transform).
int MergeMapAsOneObservation(const OccupancyGrid& teammate, const Pose2& merged_T_teammate,
                             const MapMergeOptions& options, OccupancyGrid* merged);

// How two maps agree when b's frame sits at a_T_b in a's: every occupied cell of each map, its
// centre carried into the other, is
//  - agreeing when the other map has an occupied cell within tolerance_cells (Chebyshev),
//  - conflicting when it lands on a cell the other map saw free with no occupied cell that near
//    (one robot saw a wall where the other saw through),
//  - neither on the other map's unknown cells or outside it.
// Both directions are counted (a's walls in b's free space, b's walls in a's).
// Robots whose lasers sweep different heights (the team scenarios: a UAV at 1.4 m, a wheeled
// robot at 0.3 m) see different things: under the 2.5D assumption what stands on the floor
// reaches from it up to its highest hit at least, so a laser passing below that height must
// have met it, but one passing above may have flown over it (a low box, a table's legs). With the lasers' heights
// (`heights`), an occupied cell with a recorded highest hit (OccupancyGrid::HighestHit) more than
// margin_meters below the other map's lowest ray (OnlineEstimatorStats::lowest_ray_height_meters)
// is not a conflict on that map's free space, only counted as passed_over; a cell without a
// height, or a map without a lowest ray (a 2D laser), counts as above. margin_meters must be
// >= 0 (CHECK). A level laser meets a wall and a box at the same height, so every cell of a low
// robot's map may agree but never conflict on a high one's free space (TeamEstimatorOptions::
// overlap_height_margin_meters keeps it opt-in; README, "Lasers at different heights").
struct MapAgreement {
  int agreeing = 0;
  int conflicting = 0;
  int passed_over = 0;  // on free space the other's rays may have passed over (MapHeights)
  // conflicting / (agreeing + conflicting); 1 when neither.
  double ConflictFraction() const;
};
struct MapHeights {
  std::optional<double> a_lowest_ray_meters, b_lowest_ray_meters;
  double margin_meters = 0.1;
};
MapAgreement CompareMaps(const OccupancyGrid& a, const OccupancyGrid& b, const Pose2& a_T_b, int tolerance_cells = 1,
                         const MapHeights& heights = MapHeights());

// Walls stand from the floor to the ceiling (the 2.5D assumption; paper §III-E): a laser at any
// height sees them. A robot's wall layer holds the cells its own laser hit at several heights,
// and a laser that sweeps only a low band (a humanoid's head at 0.5 m) cannot tell a wall from
// the lower face of a shelf. A teammate whose laser, at its own height, passed through the place
// where the robot's laser met that surface (the wall cell's mean hit point falls on a free cell
// of the teammate's map) and met no surface of its own within min_surface_distance_meters of it
// (the hit points of its occupied cells) has seen that it is not a wall. Every such cell of
// `walls` (a wall layer, SubmapGraph::Layer::kWalls) becomes unknown; `teammate` is the
// teammate's structure map, its frame at walls_T_teammate in the walls' frame. Both grids must
// not be frozen (their hit points are read). Returns the number of cells dropped. The caller
// drops the pieces this leaves too short to be walls (OccupancyGrid::DropSmallOccupiedPieces).
int DropWallsSeenThrough(const OccupancyGrid& teammate, const Pose2& walls_T_teammate,
                         double min_surface_distance_meters, OccupancyGrid* walls);

}  // namespace hetslam

#endif  // HETSLAM_MERGER_MAP_MERGE_H_
