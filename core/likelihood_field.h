// Likelihood-field lookup table over the cells of an OccupancyGrid (paper §III-B).
//
// Each cell c stores
//   L(c) = max over occupied cells o with |o.x - c.x| <= R and |o.y - c.y| <= R of
//          exp(-d(c, o) / sigma),   d(c, o) = |centre(c) - h(o)|,
// where h(o) is o's accumulated sub-cell hit point as last PUBLISHED to the field, R the
// window radius in cells and sigma in metres; L(c) = 0 with no occupied cell in the window.
// A hit point is republished only when it moved more than `republish_distance_meters`
// from its published value, which bounds the work per scan; the table is always exactly the
// formula above for the published points (tests compare it with a brute-force rebuild).
//
// Updates are incremental: a cell turning occupied raises its window by a max; a cell
// turning free, or moving its published hit point, lowers values that it may have owned, and
// only those are recomputed from their own windows. While the field is not frozen it also
// keeps each cell's squared distance d^2 to its nearest published point (the max of
// exp(-d / sigma) is taken at the min of d, exp and sqrt being monotone), so updates compare
// squared distances and evaluate exp only for the cells whose value changes.
#ifndef HETSLAM_CORE_LIKELIHOOD_FIELD_H_
#define HETSLAM_CORE_LIKELIHOOD_FIELD_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/grid_geometry.h"
#include "core/occupancy_grid.h"

namespace hetslam {

struct LikelihoodFieldOptions {
  double sigma_meters = 0.10;            // p_hit ~ exp(-d / sigma)
  double max_distance_meters = 0.30;     // window radius R = ceil(max_distance / resolution); <= 5 m
  double republish_distance_meters = 0.005;

  bool IsValid(std::string* error) const;
};

class LikelihoodField {
 public:
  explicit LikelihoodField(const LikelihoodFieldOptions& options);

  const LikelihoodFieldOptions& options() const { return options_; }
  const GridGeometry& geometry() const { return geometry_; }
  int window_radius_cells() const { return radius_cells_; }

  // Follows a growth of the grid: values keep their world positions. The grid's border
  // margin must be at least the window radius so that no window was clipped.
  void Resize(const GridGeometry& new_geometry);

  // Applies the cells the grid reported as changed (OccupancyGrid::InsertScan). The field's
  // geometry must equal the grid's (call Resize first after growth).
  void ApplyChanges(const OccupancyGrid& grid, const std::vector<int>& changed_cells);

  // Rebuilds every value from scratch from the published hit points (the brute-force
  // reference used by tests; also valid after loading a grid).
  void RebuildAll();
  // Publishes every occupied cell's current hit point and rebuilds.
  void RebuildFrom(const OccupancyGrid& grid);

  // Frees the published hit points and squared distances (two thirds of the memory); values
  // stay readable, ApplyChanges, Resize and the rebuilds CHECK-fail afterwards.
  void Freeze();

  // Value at a cell (0 outside the grid).
  float Value(const CellIndex& c) const {
    return geometry_.Contains(c) ? values_[geometry_.LinearIndex(c)] : 0.f;
  }
  float Value(int linear_index) const { return values_[linear_index]; }
  const std::vector<float>& values() const { return values_; }

 private:
  // d^2 (m^2) from occupied cell o's published point p_o to the centre of cell c. In the
  // header so that it inlines into the window loops (an out-of-line call per cell was
  // a sixth of the instructions on FR079).
  float SquaredDistance(const CellIndex& c, const CellIndex& o, const Eigen::Vector2f& p_o) const {
    const float r = static_cast<float>(geometry_.resolution_meters());
    const float dx = (static_cast<float>(c.x - o.x) + 0.5f) * r - p_o.x();
    const float dy = (static_cast<float>(c.y - o.y) + 0.5f) * r - p_o.y();
    return dx * dx + dy * dy;
  }
  // exp(-d / sigma) for a squared distance d^2 (0 for d^2 = +inf: nothing in the window).
  float ValueFromSquaredDistance(float squared_distance) const;
  // Min d^2 over the published points in c's window (+inf when there is none).
  float RecomputeSquaredDistance(const CellIndex& c) const;
  bool HasPublished(int i) const { return published_[i].x() == published_[i].x(); }

  LikelihoodFieldOptions options_;
  GridGeometry geometry_;
  int radius_cells_ = 0;
  bool frozen_ = false;
  std::vector<float> values_;
  // values_[i] = ValueFromSquaredDistance(squared_distances_[i]); freed by Freeze. Within
  // ApplyChanges, kStale marks a cell queued in stale_cells_ for one recompute at the end.
  std::vector<float> squared_distances_;
  std::vector<int> stale_cells_;  // scratch of ApplyChanges
  // Published hit point per cell relative to the cell's own minimum corner (metres), NaN
  // when the cell does not contribute. Relative storage makes values independent of growth.
  std::vector<Eigen::Vector2f> published_;
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_LIKELIHOOD_FIELD_H_
