// Likelihood-field lookup table over the cells of an OccupancyGrid (paper §III-B).
//
// Each cell c stores
//   L(c) = max over occupied cells o with |o.x - c.x| <= R and |o.y - c.y| <= R of
//          exp(-d(c, o) / sigma),
// where d(c, o) is the distance from centre(c) to the surface piece o stands for, as last
// PUBLISHED to the field: the segment through o's accumulated sub-cell hit point h(o) along
// its line direction u(o), of half length l(o) (OccupancyGrid::Line; l = 0: the point h(o)):
//   d^2 = ((c - h) . n)^2 + max(0, |(c - h) . u| - l)^2,   n ⟂ u.
// R is the window radius in cells and sigma in metres; L(c) = 0 with no occupied cell in the
// window. The segments make a wall seen at a grazing angle, whose hits are dotted up to a
// few decimetres apart, score as the continuous surface it is: with points only, the field
// dips between the dots, more where the wall was seen sparsely (ahead of the robot, at long
// range) than where it was seen densely (where the robot has been), and a scan matched
// against it is pulled back along a corridor (tests/frontends/corridor_bias_test.cc).
// A cell is republished only when its hit point moved more than `republish_distance_meters`,
// its half length changed by more than that or its direction by more than
// `republish_angle_radians`, which bounds the work per scan; the table is always exactly the
// formula above for the published segments (tests compare it with a brute-force rebuild).
//
// Updates are incremental: a cell turning occupied raises its window by a max; a cell
// turning free, or moving its published segment, lowers values that it may have owned, and
// only those are recomputed from their own windows. While the field is not frozen it also
// keeps each cell's squared distance d^2 to its nearest published segment (the max of
// exp(-d / sigma) is taken at the min of d, exp and sqrt being monotone), so updates compare
// squared distances and evaluate exp only for the cells whose value changes.
//
// A field may be restricted to the occupied cells that carry a label (`surface_labels`, bits
// of OccupancyGrid::LabelMask): with the wall bit it is the likelihood field of the walls alone
// (paper §III-E), the second channel of a LaserMap's wall-weighted matching (core/laser_map.h
// wall_field). The formula above then runs over those cells only; everything else is the same.
#ifndef HETSLAM_CORE_LIKELIHOOD_FIELD_H_
#define HETSLAM_CORE_LIKELIHOOD_FIELD_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/grid_geometry.h"
#include "core/sparse_tiles.h"
#include "core/tiled_index.h"
#include "core/occupancy_grid.h"

namespace hetslam {

struct LikelihoodFieldOptions {
  double sigma_meters = 0.10;            // p_hit ~ exp(-d / sigma)
  double max_distance_meters = 0.30;     // window radius R = ceil(max_distance / resolution); <= 5 m
  double republish_distance_meters = 0.005;
  double republish_angle_radians = 0.035;  // 2°
  // The surfaces a LaserMap gives its hits (core/laser_map.h EstimateScanLines). Off by
  // default (max_gap_meters 0: distances to hit points only): measured, the surfaces improve
  // Intel's relations (0.0229 → 0.0207 m) and leave the simulated corridors as they are, but
  // bend MIT CSAIL's map (ATE against GMapping 0.175 → 10.9 m, 105 instead of 196 closures).
  ScanLineOptions lines = [] {
    ScanLineOptions off;
    off.max_gap_meters = 0.0;
    return off;
  }();

  bool IsValid(std::string* error) const;
};

class LikelihoodField {
 public:
  // `surface_labels`: 0, every occupied cell is a surface; else only the occupied cells whose
  // label mask (OccupancyGrid::LabelMask) has one of these bits.
  explicit LikelihoodField(const LikelihoodFieldOptions& options, uint8_t surface_labels = 0);

  const LikelihoodFieldOptions& options() const { return options_; }
  const GridGeometry& geometry() const { return geometry_; }
  int window_radius_cells() const { return radius_cells_; }
  uint8_t surface_labels() const { return surface_labels_; }
  // Whether occupied cell i of `grid` is a surface of this field (see surface_labels).
  bool IsSurface(const OccupancyGrid& grid, int i) const {
    return grid.IsOccupied(i) && (surface_labels_ == 0 || (grid.LabelMask(i) & surface_labels_) != 0);
  }

  // Follows a growth of the grid: values keep their world positions. The grid's border
  // margin must be at least the window radius so that no window was clipped.
  void Resize(const GridGeometry& new_geometry);

  // Applies the cells the grid reported as changed (OccupancyGrid::InsertScan). The field's
  // geometry must equal the grid's (call Resize first after growth).
  void ApplyChanges(const OccupancyGrid& grid, const std::vector<int>& changed_cells);

  // Rebuilds every value from scratch from the published hit points (the brute-force
  // reference used by tests; also valid after loading a grid).
  void RebuildAll();
  // Publishes every surface cell's current hit point and rebuilds.
  void RebuildFrom(const OccupancyGrid& grid);

  // For a finished submap: frees the published hit points and squared distances and keeps,
  // over `kept` (a box of the current geometry on the same lattice: the frozen grid's,
  // OccupancyGrid::Freeze), each cell's distance d to its nearest published surface as an 8-bit
  // code (FrozenCodes: 0, no surface in the window; else d rounded to a step of 1/254 of the
  // largest distance within the window, 1.8 mm with the defaults), in 8 × 8 tiles where a tile of
  // zeros is not stored (core/sparse_tiles.h: a byte a cell near surfaces, nothing away from
  // them, instead of the float values and squared distances, 8 bytes a cell of their tiles, and
  // the pooled segments). The value of a code is exp(-d / sigma) at its distance, so a value
  // that is not 0 stays not 0 and "no surface in the window" keeps its meaning for the
  // free-space penalty; the refinement reads the distances themselves (FrozenCodes::
  // squared_distance: no logarithm). Every value left out of the box must be 0, which holds
  // when it covers the window radius around every occupied cell.
  // Values stay readable through Value (0 outside, as before); values() is then empty;
  // ApplyChanges, Resize and the rebuilds CHECK-fail. Idempotent.
  void Freeze(const GridGeometry& kept);
  // What a frozen field's codes stand for (shared by every field with the same sigma, window
  // and resolution).
  struct FrozenCodes {
    double sigma_meters = 0.0;
    double window_meters = 0.0;  // the distance of code 1
    double cap_meters = 0.0;     // of squared_distance
    double distance_step_meters = 0.0;  // d = (255 - code) * step for code >= 1
    float value[256] = {};               // exp(-d / sigma); value[0] = 0
    // d^2 with d capped at the window radius (R * resolution; code 0: the cap), as the
    // refinement reads distances (factors/scan_cost.h).
    double squared_distance[256] = {};
  };
  bool frozen() const { return frozen_; }
  // False only if no cell within `radius_cells` (Chebyshev distance, cells) of `c` holds a value
  // other than 0; `c` may lie outside the grid (the answer is then looser). Exact to the 8 × 8
  // tile of a frozen field (the Chebyshev distance of each tile to the nearest stored one is
  // kept, a byte a tile); always true before Freeze. For bounds on scores: when false, no pose
  // that keeps a point within `radius_cells` of `c` gives it a likelihood (issue #15: loop
  // searches that cannot reach their score are skipped).
  bool MayBeNonZeroNear(const CellIndex& c, int radius_cells) const;
  // A frozen field's codes in their tiles (empty before Freeze): which 8 × 8 tiles hold any.
  const SparseTiles<uint8_t>& frozen_tiles() const { return frozen_codes_; }
  // What the codes stand for (CHECK-fails before Freeze).
  const FrozenCodes& frozen_codes() const;
  // Bytes held by the per-cell arrays (capacity).
  size_t MemoryBytes() const;

  // Value at a cell (0 outside the grid).
  float Value(const CellIndex& c) const {
    if (!geometry_.Contains(c)) return 0.f;
    return frozen_ ? codes_->value[frozen_codes_.Get(c.x, c.y)] : values_.Get(c.x, c.y);
  }
  float Value(int linear_index) const { return Value(geometry_.FromLinearIndex(linear_index)); }
  // Values of cells (x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1) into v[0..3] (0 outside
  // the grid): the neighbourhood of a bilinear lookup, read with one tile lookup when frozen.
  void Values2x2(int x, int y, float* v) const {
    if (x >= 0 && y >= 0 && x + 1 < geometry_.width() && y + 1 < geometry_.height()) {
      if (!frozen_) {
        values_.Get2x2(x, y, v);
        return;
      }
      uint8_t q[4];
      frozen_codes_.Get2x2(x, y, q);
      for (int k = 0; k < 4; ++k) v[k] = codes_->value[q[k]];
      return;
    }
    v[0] = Value(CellIndex{x, y});
    v[1] = Value(CellIndex{x + 1, y});
    v[2] = Value(CellIndex{x, y + 1});
    v[3] = Value(CellIndex{x + 1, y + 1});
  }
  // Values of the w × h cells from (x0, y0) into out[(y - y0) * w + (x - x0)] (0 outside the
  // grid): Value of each, read a tile row at a time (a block around a point that is scored at
  // many nearby positions, ScanMatcher's score profile).
  void ValuesBlock(int x0, int y0, int w, int h, float* out) const {
    const int x_begin = std::clamp(x0, 0, geometry_.width()), x_end = std::clamp(x0 + w, 0, geometry_.width());
    for (int y = y0; y < y0 + h; ++y) {
      float* row = out + static_cast<size_t>(y - y0) * w;
      if (y < 0 || y >= geometry_.height() || x_begin >= x_end) {
        std::fill(row, row + w, 0.f);
        continue;
      }
      std::fill(row, row + (x_begin - x0), 0.f);
      std::fill(row + (x_end - x0), row + w, 0.f);
      if (!frozen_) {
        values_.GetRow(x_begin, y, x_end - x_begin, row + (x_begin - x0));
        continue;
      }
      for (int x = x_begin; x < x_end;) {
        const int end = std::min(x_end, (x | (SparseTiles<uint8_t>::kTileSize - 1)) + 1);
        const uint8_t* q = frozen_codes_.TileRow(x, y);
        float* o = row + (x - x0);
        if (q == nullptr) {
          std::fill(o, o + (end - x), codes_->value[0]);
        } else {
          for (int k = 0; k < end - x; ++k) o[k] = codes_->value[q[k]];
        }
        x = end;
      }
    }
  }
  // The values before Freeze, in 8 × 8 tiles that exist only where some cell of theirs is not
  // 0 (within the window radius of a surface; empty, every cell 0, after Freeze). Readers walk
  // rows tile by tile (TiledGrid::TileRow) or read cells (Get, Get2x2).
  const TiledGrid<float>& values() const { return values_; }
  // SparseTiles::TileRow of the frozen codes (null: all 0 to the tile's right edge).
  const uint8_t* FrozenCodesTileRow(int x, int y) const { return frozen_codes_.TileRow(x, y); }
  // The code of one cell inside the grid.
  uint8_t FrozenCode(int x, int y) const { return frozen_codes_.Get(x, y); }

 private:
  // A published surface piece: hit point relative to the cell's minimum corner (metres; NaN
  // when the cell does not contribute), unit direction, half length (0: a point).
  struct Segment {
    Eigen::Vector2f point;
    Eigen::Vector2f direction;
    float half_length;
  };
  // d^2 (m^2) from occupied cell o's published segment s to the centre of cell c (NaN when s
  // is unpublished). In the header so that it inlines into the window loops (an out-of-line
  // call per cell was a sixth of the instructions on FR079).
  float SquaredDistance(const CellIndex& c, const CellIndex& o, const Segment& s) const {
    const float r = static_cast<float>(geometry_.resolution_meters());
    const float dx = (static_cast<float>(c.x - o.x) + 0.5f) * r - s.point.x();
    const float dy = (static_cast<float>(c.y - o.y) + 0.5f) * r - s.point.y();
    const float along = dx * s.direction.x() + dy * s.direction.y();
    const float across = dy * s.direction.x() - dx * s.direction.y();
    // No branch for points: with half_length 0 this is across^2 + along^2 = dx^2 + dy^2.
    const float beyond = std::max(0.f, std::abs(along) - s.half_length);
    return across * across + beyond * beyond;
  }
  // exp(-d / sigma) for a squared distance d^2 (0 for d^2 = +inf: nothing in the window).
  float ValueFromSquaredDistance(float squared_distance) const;
  static const FrozenCodes& SharedFrozenCodes(double sigma_meters, double window_meters, double cap_meters);
  // f(cell, segment index) for every published cell of [x0, x1] x [y0, y1] (inside the grid),
  // row by row, tile by tile: a tile without published points is skipped whole.
  template <typename F>
  void ForEachPublished(int x0, int x1, int y0, int y1, F f) const {
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1;) {
        const int end = std::min(x1 + 1, (x | (TiledIndex::kTileSize - 1)) + 1);
        const int32_t* index = published_index_.TileRow(x, y);
        if (index != nullptr) {
          for (int k = 0; k < end - x; ++k) {
            if (index[k] >= 0) f(CellIndex{x + k, y}, index[k]);
          }
        }
        x = end;
      }
    }
  }
  // Min d^2 over the published points in c's window (+inf when there is none).
  float RecomputeSquaredDistance(const CellIndex& c) const;
  // Every cell of stale_cells_ recomputed so (ApplyChanges' last step).
  void RecomputeStaleCells();
  bool HasPublished(int i) const { return published_index_.GetLinear(i) >= 0; }
  const Segment& Published(int i) const {
    const int32_t index = published_index_.GetLinear(i);
    return index >= 0 ? segments_[index] : kUnpublished;
  }
  // Publishes `s` for cell i (kUnpublished, NaN point: withdraws it).
  void SetPublished(int i, const Segment& s);
  static const Segment kUnpublished;
  // The segment occupied cell i of `grid` stands for, relative to the cell's minimum corner.
  Segment SegmentOf(const OccupancyGrid& grid, int i) const;

  LikelihoodFieldOptions options_;
  GridGeometry geometry_;
  int radius_cells_ = 0;
  uint8_t surface_labels_ = 0;
  bool frozen_ = false;
  TiledGrid<float> values_;             // empty (all 0) once frozen
  SparseTiles<uint8_t> frozen_codes_;  // empty until frozen
  const FrozenCodes* codes_ = nullptr;  // set by Freeze (shared, never freed)
  // Per tile of frozen_codes_ (row-major), the Chebyshev distance in tiles to the nearest
  // stored tile, capped at 255 (255 also when no tile is stored); empty until frozen.
  std::vector<uint8_t> tile_distances_;
  // values_ = ValueFromSquaredDistance(squared_distances_) cell by cell (+inf, tile not
  // allocated, where values_ is 0); freed by Freeze. Within ApplyChanges, kStale marks a cell
  // queued in stale_cells_ for one recompute at the end, and a value of kPendingValue a cell
  // whose squared distance was lowered, queued once in pending_values_ for its value at the end.
  TiledGrid<float> squared_distances_;
  std::vector<int> stale_cells_;     // scratch of ApplyChanges
  std::vector<int> pending_values_;  // scratch of ApplyChanges
  // Published segment per cell, its point relative to the cell's own minimum corner; relative
  // storage makes values independent of growth. Only occupied cells publish, a few percent:
  // the segments sit in a pool, indexed per cell (-1: none) in tiles that exist only where
  // some cell publishes (core/tiled_index.h).
  TiledIndex published_index_;
  std::vector<Segment> segments_;
  std::vector<int32_t> free_segments_;  // released entries of segments_, reused first
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_LIKELIHOOD_FIELD_H_
