#include "core/laser_map.h"

#include <algorithm>

namespace hetslam {

OccupancyGridOptions WithFieldMargin(OccupancyGridOptions grid, const LikelihoodFieldOptions& field) {
  grid.border_margin_meters =
      std::max(grid.border_margin_meters, field.max_distance_meters + 2 * grid.resolution_meters);
  return grid;
}

LaserMap::LaserMap(const OccupancyGridOptions& grid_options,
                   const LikelihoodFieldOptions& field_options)
    : grid_(WithFieldMargin(grid_options, field_options)), field_(field_options) {}

bool LaserMap::InsertScan(const Pose2& world_T_robot, const Eigen::Vector2d& sensor_robot,
                          const std::vector<Eigen::Vector2f>& points_robot, const std::vector<PointLabel>* labels,
                          const std::vector<float>* heights) {
  points_world_.clear();
  points_world_.reserve(points_robot.size());
  for (const Eigen::Vector2f& p : points_robot) points_world_.push_back(world_T_robot * p.cast<double>());
  changed_cells_.clear();
  if (labels != nullptr) {
    labels_.clear();
    for (PointLabel label : *labels) labels_.push_back(static_cast<uint8_t>(label));
  }
  if (!grid_.InsertScan(world_T_robot * sensor_robot, points_world_, &changed_cells_,
                        labels != nullptr ? &labels_ : nullptr, heights)) {
    return false;
  }
  field_.ApplyChanges(grid_, changed_cells_);
  ++num_scans_inserted_;
  return true;
}

}  // namespace hetslam
