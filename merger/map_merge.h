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

}  // namespace hetslam

#endif  // HETSLAM_MERGER_MAP_MERGE_H_
