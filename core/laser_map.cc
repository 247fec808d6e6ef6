#include "core/laser_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "Eigen/Geometry"

namespace hetslam {

OccupancyGridOptions WithFieldMargin(OccupancyGridOptions grid, const LikelihoodFieldOptions& field) {
  grid.border_margin_meters =
      std::max(grid.border_margin_meters, field.max_distance_meters + 2 * grid.resolution_meters);
  return grid;
}

std::vector<ScanLine> EstimateScanLines(const ScanLineOptions& options,
                                        const std::vector<Eigen::Vector2f>& points) {
  const int n = static_cast<int>(points.size());
  std::vector<ScanLine> lines(n);
  if (options.max_gap_meters <= 0.0 || n < 3) return lines;
  const float max_gap = static_cast<float>(options.max_gap_meters);
  const float radius = static_cast<float>(options.fit_radius_meters);
  const float max_mean_square = static_cast<float>(options.max_rms_meters * options.max_rms_meters);
  auto gap = [&](int a, int b) { return (points[a] - points[b]).norm(); };
  for (int i = 0; i < n; ++i) {
    const float gap_before = i > 0 ? gap(i - 1, i) : std::numeric_limits<float>::infinity();
    const float gap_after = i + 1 < n ? gap(i, i + 1) : std::numeric_limits<float>::infinity();
    int first = i, last = i;
    // Immediate neighbours always, then outwards while within the radius, or while fewer than
    // three points are in (the last point of a run, at the end of a sparse wall, still gets
    // its line from the two before it).
    auto take_more = [&](int candidate, int count) {
      return count < 3 || (points[candidate] - points[i]).norm() <= radius;
    };
    while (first > 0 && gap(first - 1, first) <= max_gap &&
           (first == i || take_more(first - 1, last - first + 1))) {
      --first;
    }
    while (last + 1 < n && gap(last, last + 1) <= max_gap &&
           (last == i || take_more(last + 1, last - first + 1))) {
      ++last;
    }
    const int count = last - first + 1;
    if (count < 3) continue;
    Eigen::Vector2f mean = Eigen::Vector2f::Zero();
    for (int j = first; j <= last; ++j) mean += points[j];
    mean /= static_cast<float>(count);
    Eigen::Matrix2f scatter = Eigen::Matrix2f::Zero();
    for (int j = first; j <= last; ++j) scatter += (points[j] - mean) * (points[j] - mean).transpose();
    scatter /= static_cast<float>(count);
    // Eigen values of the symmetric 2x2 scatter in closed form.
    const float half_trace = 0.5f * scatter.trace();
    const float root = std::sqrt(0.25f * (scatter(0, 0) - scatter(1, 1)) * (scatter(0, 0) - scatter(1, 1)) +
                                 scatter(0, 1) * scatter(0, 1));
    const float smaller = half_trace - root;
    if (!(smaller <= max_mean_square)) continue;
    const float theta = 0.5f * std::atan2(2.f * scatter(0, 1), scatter(0, 0) - scatter(1, 1));
    float half_length = 0.f;
    if (gap_before <= max_gap) half_length = std::max(half_length, 0.5f * gap_before);
    if (gap_after <= max_gap) half_length = std::max(half_length, 0.5f * gap_after);
    lines[i].direction = Eigen::Vector2f(std::cos(theta), std::sin(theta));
    lines[i].half_length = half_length;
  }
  return lines;
}

namespace {
// The grid's origin in whole cells: cell c of the grid is cell c + offset of the world-aligned
// lattice (core/occupancy_grid.cc keeps the origin a multiple of the resolution).
CellIndex LatticeOffset(const GridGeometry& g) {
  return {static_cast<int>(std::lround(g.origin().x() / g.resolution_meters())),
          static_cast<int>(std::lround(g.origin().y() / g.resolution_meters()))};
}
}  // namespace

LaserMap::LaserMap(const OccupancyGridOptions& grid_options,
                   const LikelihoodFieldOptions& field_options, bool keep_wall_field)
    : grid_(WithFieldMargin(grid_options, field_options)), field_(field_options), keep_wall_field_(keep_wall_field) {}

bool LaserMap::InsertScan(const Pose2& world_T_robot, const Eigen::Vector2d& sensor_robot,
                          const std::vector<Eigen::Vector2f>& points_robot, const std::vector<PointLabel>* labels,
                          const std::vector<float>* heights, bool update_field) {
  points_world_.clear();
  points_world_.reserve(points_robot.size());
  const Pose2::PointTransform to_world(world_T_robot);
  for (const Eigen::Vector2f& p : points_robot) points_world_.push_back(to_world(p.cast<double>()));
  changed_cells_.clear();
  if (labels != nullptr) {
    labels_.clear();
    for (PointLabel label : *labels) labels_.push_back(static_cast<uint8_t>(label));
  }
  const std::vector<ScanLine>* lines = nullptr;
  if (field_.options().lines.max_gap_meters > 0.0) {
    lines_ = EstimateScanLines(field_.options().lines, points_robot);
    const Eigen::Rotation2Df rotation(static_cast<float>(world_T_robot.theta()));
    for (ScanLine& line : lines_) line.direction = rotation * line.direction;
    lines = &lines_;
  }
  if (!grid_.InsertScan(world_T_robot * sensor_robot, points_world_, &changed_cells_,
                        labels != nullptr ? &labels_ : nullptr, heights, lines)) {
    return false;
  }
  if (!update_field && !keep_wall_field_) {
    const GridGeometry& g = grid_.geometry();
    const CellIndex lattice = LatticeOffset(g);
    for (const int i : changed_cells_) {
      const CellIndex c = g.FromLinearIndex(i);
      pending_.push_back({c.x + lattice.x, c.y + lattice.y});
    }
    ++num_scans_inserted_;
    return true;
  }
  UpdateField();
  field_.ApplyChanges(grid_, changed_cells_);
  if (keep_wall_field_ && grid_.has_labels()) {
    if (wall_field_.has_value()) {
      wall_field_->ApplyChanges(grid_, changed_cells_);
    } else {
      // Created with the first wall cell (every cell that turns wall is hit, so listed), from
      // the whole grid: from then on it follows the changes like field_.
      constexpr uint8_t kWall = 1u << OccupancyGrid::kWallLabelBit;
      const bool any_wall = std::any_of(changed_cells_.begin(), changed_cells_.end(), [&](int i) {
        return grid_.IsOccupied(i) && (grid_.LabelMask(i) & kWall) != 0;
      });
      if (any_wall) {
        wall_field_.emplace(field_.options(), kWall);
        wall_field_->RebuildFrom(grid_);
      }
    }
  }
  ++num_scans_inserted_;
  return true;
}

void LaserMap::UpdateField() {
  if (pending_.empty()) return;
  const GridGeometry& g = grid_.geometry();
  const CellIndex lattice = LatticeOffset(g);
  std::vector<int> cells;
  cells.reserve(pending_.size());
  for (const CellIndex& c : pending_) cells.push_back(g.LinearIndex({c.x - lattice.x, c.y - lattice.y}));
  // Each cell once, in one order whatever the scans' order of changes.
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  std::vector<CellIndex>().swap(pending_);
  field_.ApplyChanges(grid_, cells);
}

void LaserMap::Freeze() {
  if (grid_.frozen()) return;
  UpdateField();
  // Field values are non-zero only within the window radius of an occupied (so observed)
  // cell; two more cells keep the border at 0 for the bicubic cost and bilinear scores.
  grid_.Freeze(field_.window_radius_cells() + 2);
  field_.Freeze(grid_.geometry());
  if (wall_field_.has_value()) wall_field_->Freeze(grid_.geometry());
  std::vector<int>().swap(changed_cells_);
  std::vector<Eigen::Vector2d>().swap(points_world_);
  std::vector<uint8_t>().swap(labels_);
  std::vector<ScanLine>().swap(lines_);
}

size_t LaserMap::MemoryBytes() const {
  return grid_.MemoryBytes() + field_.MemoryBytes() + (wall_field_.has_value() ? wall_field_->MemoryBytes() : 0) +
         pending_.capacity() * sizeof(CellIndex) + changed_cells_.capacity() * sizeof(int) +
         points_world_.capacity() * sizeof(Eigen::Vector2d) + labels_.capacity() + lines_.capacity() * sizeof(ScanLine);
}

}  // namespace hetslam
