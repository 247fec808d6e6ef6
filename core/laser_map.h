// An occupancy grid with its likelihood-field lookup table kept in step: the map a scan
// matcher matches against and a SLAM front end inserts into.
#ifndef HETSLAM_CORE_LASER_MAP_H_
#define HETSLAM_CORE_LASER_MAP_H_

#include <optional>
#include <vector>

#include "Eigen/Core"
#include "core/laser_scan.h"
#include "core/likelihood_field.h"
#include "core/occupancy_grid.h"
#include "core/se2.h"
#include "glog/logging.h"

namespace hetslam {

// `grid` with its border margin raised to cover the likelihood window of `field` (plus two
// cells), so that no window clips: the grid options a LaserMap uses.
OccupancyGridOptions WithFieldMargin(OccupancyGridOptions grid, const LikelihoodFieldOptions& field);

// The surface each point of a scan lies on (robot frame directions), from its neighbours in
// beam order (`points_robot` as the scan gives them): the run of consecutive points, each at
// most options.max_gap_meters from the previous, within options.fit_radius_meters
// of point i (and always its immediate neighbours within the gap, and farther ones until there
// are three) is fitted with a line
// (principal axis); with at least three points and an RMS distance to the line of at most
// options.max_rms_meters, point i gets that direction and half the larger gap to its
// immediate neighbours as its half length (the piece of surface between the beams it stands
// for). Otherwise, and for every point when max_gap_meters is 0, half_length 0.
std::vector<ScanLine> EstimateScanLines(const ScanLineOptions& options,
                                        const std::vector<Eigen::Vector2f>& points_robot);

class LaserMap {
 public:
  // The grid's border margin is raised to cover the likelihood window so no window clips.
  // `keep_wall_field`: also keep the likelihood field of the wall cells alone (wall_field()).
  LaserMap(const OccupancyGridOptions& grid_options, const LikelihoodFieldOptions& field_options,
           bool keep_wall_field = false);

  // Inserts points given in the robot frame, seen from `sensor_robot` (sensor origin in the
  // robot frame), with the robot at `world_T_robot`.
  // `labels` (optional, one PointLabel per point) and `heights` (optional, metres above the
  // floor) feed the grid's label layer (core/occupancy_grid.h: walls from the height span).
  // False when the grid refused the scan (OccupancyGrid::InsertScan: non-finite or too far).
  // With `update_field` false the likelihood field is left behind: the cells the scan changed
  // are kept and applied, each once, by the next UpdateField() (or InsertScan with
  // update_field, or Freeze). A front end inserts every scan into two submaps but matches
  // against one: the other's field is brought up to date when it is matched against, its
  // changes of ~20 scans at once (Intel: map insertion 35% faster). Without keep_wall_field
  // only (the wall field is always updated with the scan).
  bool InsertScan(const Pose2& world_T_robot, const Eigen::Vector2d& sensor_robot,
                  const std::vector<Eigen::Vector2f>& points_robot,
                  const std::vector<PointLabel>* labels = nullptr, const std::vector<float>* heights = nullptr,
                  bool update_field = true);
  // Applies the changes InsertScan(update_field = false) left for the field (none: no-op).
  // The field then holds what it would after a rebuild from the grid, up to the republish
  // tolerance (core/likelihood_field.h), measured from the points it published before.
  void UpdateField();
  bool field_up_to_date() const { return pending_.empty(); }

  // Keeps only what matching needs (cell states, labels, likelihood distance codes, the wall
  // field's in the same compact 8-bit tiles: nothing stored away from walls) over the observed
  // box grown by the likelihood window and two cells (so the border values stay 0, as
  // factors/scan_cost.h assumes); no more insertion. See OccupancyGrid::Freeze.
  void Freeze();
  // Bytes held by the grid's and the field's cell arrays and the scratch buffers (capacity).
  size_t MemoryBytes() const;

  const OccupancyGrid& grid() const { return grid_; }
  // Up to date (UpdateField) when read: a field left behind is a programmer error.
  const LikelihoodField& field() const {
    CHECK(pending_.empty()) << "LaserMap::field() with " << pending_.size() << " changes not applied (UpdateField)";
    return field_;
  }
  // Paper §III-E, walls weigh more in matching: with keep_wall_field, the likelihood field
  // (same options) of the occupied cells carrying the wall label (OccupancyGrid::kWallLabelBit:
  // hit across a height span), kept in step with field() on the same geometry and frozen with
  // it, so that a matcher reads both at the same cell. Null until the first wall cell appears
  // (a map without labels or walls never holds one), and without keep_wall_field.
  const LikelihoodField* wall_field() const { return wall_field_.has_value() ? &*wall_field_ : nullptr; }
  int num_scans_inserted() const { return num_scans_inserted_; }

 private:
  OccupancyGrid grid_;
  LikelihoodField field_;
  bool keep_wall_field_ = false;
  std::optional<LikelihoodField> wall_field_;  // see wall_field()
  std::vector<int> changed_cells_;  // scratch
  // Cells changed since the field was last updated (InsertScan without update_field), on the
  // world-aligned lattice (cell index + origin / resolution), so that a grid that grows in
  // between moves nothing.
  std::vector<CellIndex> pending_;
  std::vector<Eigen::Vector2d> points_world_;  // scratch
  std::vector<uint8_t> labels_;                // scratch
  std::vector<ScanLine> lines_;                // scratch
  int num_scans_inserted_ = 0;
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_LASER_MAP_H_
