// Log-odds occupancy grid over 5 cm cells (by default) that grows as the robot explores,
// with the per-cell accumulated sub-cell hit point of paper §III-B.
//
// Grid convention: see core/grid_geometry.h. Cell states:
//   unknown  – never observed (log-odds exactly 0 and no observation),
//   occupied – log-odds > occupied_threshold_log_odds,
//   free     – observed and not occupied.
// Each cell keeps the running mean of the laser end points that fell into it while it was
// occupied ("hit point"); the likelihood field measures distances to these means rather than
// to cell centres, which keeps sub-cell precision in scan matching.
#ifndef HETSLAM_CORE_OCCUPANCY_GRID_H_
#define HETSLAM_CORE_OCCUPANCY_GRID_H_

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/grid_geometry.h"
#include "core/sparse_tiles.h"
#include "core/tiled_index.h"
#include "core/se2.h"

namespace hetslam {

struct OccupancyGridOptions {
  double resolution_meters = 0.05;  // in [0.005, 10] (IsValid)
  double hit_log_odds = 0.85;     // log(0.7 / 0.3)
  double miss_log_odds = -0.4;    // log(0.4 / 0.6)
  double min_log_odds = -2.0;     // clamping keeps cells able to change state
  double max_log_odds = 3.5;
  double occupied_threshold_log_odds = 0.0;
  // Distance the grid keeps between any observed cell and its border, so that neighbourhood
  // operations (the likelihood field) never clip. Growth adds at least this much.
  double border_margin_meters = 1.0;
  // When growing, the grid adds this much extra room beyond what is needed, so that growth
  // (a copy) stays rare.
  double growth_step_meters = 2.0;
  // See InsertScan's `heights`.
  double wall_min_height_span_meters = 0.3;

  bool IsValid(std::string* error) const;
};

// The surface an end point lies on, from its neighbouring beams (core/laser_map.h
// EstimateScanLines): a unit direction in the world frame and the half length of the surface
// piece the point stands for (half the gap to its neighbours). half_length 0: no line (an
// isolated point, a corner, clutter); the direction is then irrelevant.
struct ScanLine {
  Eigen::Vector2f direction = Eigen::Vector2f::UnitX();
  float half_length = 0.f;
};

// How EstimateScanLines (core/laser_map.h) finds the surface each end point lies on:
// neighbouring beams' end points at most `max_gap_meters` apart (0: no lines), fitted within
// `fit_radius_meters` of the point, form a line when their RMS distance to the fitted line is
// at most `max_rms_meters`.
struct ScanLineOptions {
  double max_gap_meters = 0.5;
  double fit_radius_meters = 0.25;
  double max_rms_meters = 0.02;

  bool IsValid(std::string* error) const;
};

enum class CellState : uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

class OccupancyGrid {
 public:
  explicit OccupancyGrid(const OccupancyGridOptions& options);

  const OccupancyGridOptions& options() const { return options_; }
  const GridGeometry& geometry() const { return geometry_; }

  // Makes sure the box [min, max] (world, metres) plus the border margin lies in the grid,
  // growing it if needed. Returns true when the geometry changed. Growth keeps every cell's
  // contents and world position; linear indices change.
  // CHECK-fails unless CanContain(min_world, max_world).
  bool EnsureContains(const Eigen::Vector2d& min_world, const Eigen::Vector2d& max_world);

  // The grid is limited to kMaxCells cells (1.6 GB of cell data; 1 km x 1 km at 5 cm): false
  // when containing the box would exceed that, or when the box is not finite. Computed in
  // doubles, so any box can be asked about.
  static constexpr double kMaxCells = 4e8;
  bool CanContain(const Eigen::Vector2d& min_world, const Eigen::Vector2d& max_world) const;

  // Inserts one scan: rays from `sensor_world` to each end point lower the log-odds of the
  // cells they cross (once per cell per scan); each end cell is raised once per scan and its
  // hit point accumulated. The grid grows to contain all points. `changed_cells` (optional)
  // receives the linear indices (in the geometry after growth) of the cells whose state went
  // to or from occupied, or whose hit point was updated while occupied.
  // `labels` (optional, one per point, each < 8: what the point is, e.g. the front end's
  // PointLabel) feeds the label layer: each end cell ORs in bit (1 << label).
  // `heights` (optional, one per point: metres above the floor, from a 2.5D projection) feeds
  // the height span of each end cell; a cell hit at heights spanning at least
  // wall_min_height_span_meters is a wall (paper §III-E: walls are the invariants of the 2.5D
  // assumption, hit wherever the tilt puts the beam) and gets the wall bit (1 << kWallLabelBit).
  // `lines` (optional, one per point: the surface the point lies on, see ScanLine) feeds
  // each end cell's line layer (Line below), accumulated with the hit point.
  // A scan with a non-finite point or sensor, or one the grid cannot grow to contain
  // (CanContain), is refused: false, nothing changes, counted in num_scans_refused() (bad
  // data, e.g. a corrupt pose far away; the caller reports it).
  bool InsertScan(const Eigen::Vector2d& sensor_world,
                  const std::vector<Eigen::Vector2d>& points_world,
                  std::vector<int>* changed_cells, const std::vector<uint8_t>* labels = nullptr,
                  const std::vector<float>* heights = nullptr, const std::vector<ScanLine>* lines = nullptr);
  static constexpr int kWallLabelBit = 3;  // PointLabel::kWall

  // One observation of the cell containing `p_world` from outside the laser model (map merging,
  // merger/map_merge.h: a teammate's map is one observation per cell): its log-odds change by
  // `delta_log_odds`, clamped as for scans, and it counts as observed. The grid grows to contain
  // the point (grow it once with EnsureContains first when adding many). A cell that turns free
  // forgets its hit point; no hit point is added.
  void AddCellObservation(const Eigen::Vector2d& p_world, float delta_log_odds);

  CellState State(int linear_index) const {
    return State(geometry_.FromLinearIndex(linear_index));
  }
  CellState State(const CellIndex& c) const {
    if (frozen_) return static_cast<CellState>(frozen_states_.Get(c.x, c.y));
    return StateOfLogOdds(log_odds_.Get(c.x, c.y));
  }
  // The state a cell with these log-odds (kUnobserved: never observed) is in.
  CellState StateOfLogOdds(float log_odds) const {
    if (log_odds == kUnobserved) return CellState::kUnknown;
    return log_odds > options_.occupied_threshold_log_odds ? CellState::kOccupied : CellState::kFree;
  }
  // The state of the cell holding `p_world`; unknown outside the grid.
  CellState StateAt(const Eigen::Vector2d& p_world) const {
    const CellIndex c = geometry_.WorldToCell(p_world);
    return geometry_.Contains(c) ? State(c) : CellState::kUnknown;
  }
  // Drops the tails of surfaces. Range and pose noise spread a wall's end points over the cells
  // on both sides of its surface; the cells in front are crossed by rays and cleared, those
  // behind it never are, so one stray end point there stays occupied for good and thickens the
  // wall outwards. An occupied cell is such a tail when some neighbour n (of the eight) was hit
  // more than 1 / `min_share` times as often and the cell on its far side from n was never
  // observed: it sits behind n, at the edge of what the rays reached. A weaker cell along a
  // surface (the surface goes on at its far side) or in front of it (free space there) stays.
  // Tails become unknown again (hit point, label and heights forgotten). Decided on the grid
  // before any cell is dropped (order-independent). Returns the number of cells dropped;
  // min_share <= 0 drops none. CHECK-fails on a frozen grid.
  int DropWeakOccupiedCells(double min_share);
  // Drops small pieces of structure: occupied cells are grouped into pieces (two cells within
  // `link_cells` of each other, Chebyshev, are in one piece, bridging gaps a sparse scan leaves),
  // and every cell of a piece whose bounding box has a diagonal shorter than `min_extent_meters`
  // (cells counted whole) becomes unknown again. The walls layer uses it: a wall is a surface,
  // not a post (a table leg is hit at several heights too). Returns the number of cells dropped;
  // min_extent_meters <= 0 drops none. CHECK-fails on a frozen grid or a negative link_cells.
  int DropSmallOccupiedPieces(double min_extent_meters, int link_cells);
  // Makes the given cells unknown again, as the two above do (hit point, label and heights
  // forgotten); cells outside the grid or unknown already are skipped. Returns how many were
  // observed. CHECK-fails on a frozen grid.
  int ForgetCells(const std::vector<CellIndex>& cells);
  // Not kept by a frozen grid (CHECK-fails there): a finished submap is read by state.
  float LogOdds(int linear_index) const;
  bool IsOccupied(int linear_index) const { return State(linear_index) == CellState::kOccupied; }
  // The log-odds of a grid that is not frozen, in 8 × 8 tiles that exist only where some cell
  // was observed; a cell never observed holds kUnobserved (below every log-odds, so not
  // occupied; not free either: see StateOfLogOdds). For readers that walk rows tile by tile.
  // Empty once frozen; read State or FrozenStatesTileRowBits then.
  static constexpr float kUnobserved = -std::numeric_limits<float>::max();
  const TiledGrid<float>& log_odds() const { return log_odds_; }
  // A frozen grid's cell states (CellState values) of row y of the 8 × 8 tile holding (x, y),
  // as stored, two bits a cell (SparseTiles2Bit::TileRowBits: the state of cell x' of the tile
  // in bits 2x' and 2x' + 1) into `row`; false when the tile is not stored (all unknown).
  bool FrozenStatesTileRowBits(int x, int y, uint16_t* row) const { return frozen_states_.TileRowBits(x, y, row); }
  float occupied_threshold_log_odds() const { return options_.occupied_threshold_log_odds; }
  // Mean hit point (world frame) of an occupied cell; the cell centre if it has no hits.
  Eigen::Vector2d HitPoint(int linear_index) const;
  int HitCount(int linear_index) const {
    if (frozen_) return 0;
    const int32_t hit = hit_index_.GetLinear(linear_index);
    return hit < 0 ? 0 : static_cast<int>(hits_[hit].count);
  }
  // The surface through an occupied cell's hit point: its hits' lines averaged (directions as
  // axes, doubled angles, weighted by half length), with half_length 0 when the cell has no
  // line evidence or its lines disagree (their mean axis is shorter than kMinLineCoherence of
  // their mean length: a corner, clutter). half_length is the mean over all the cell's hits,
  // those without a line counting 0: a cell seen as a point as often as on a line stands for
  // a shorter piece.
  ScanLine Line(int linear_index) const;
  bool has_lines() const { return has_lines_; }
  static constexpr float kMinLineCoherence = 0.8f;

  // The highest hit of a cell, in metres above the floor (InsertScan's `heights`, to its 2 cm
  // steps): false when the cell has no hit with a height (no heights inserted, a 2D scan, the
  // grid frozen, or a cell added by AddCellObservation).
  bool HighestHit(const CellIndex& c, double* height_meters) const {
    if (frozen_ || height_min_.width() == 0 || !geometry_.Contains(c) || height_min_.Get(c.x, c.y) == 255) return false;
    *height_meters = 0.02 * height_max_.Get(c.x, c.y);
    return true;
  }

  // Bounding box (cells) of all observed cells; empty (max < min) before any insertion.
  CellIndex observed_min() const { return observed_min_; }
  CellIndex observed_max() const { return observed_max_; }

  // Label layer: the bits (1 << label) of every label that hit the cell; 0 for cells never hit
  // by a labelled point (and everywhere before the first labelled insertion: no memory).
  uint8_t LabelMask(int linear_index) const {
    if (frozen_) {
      if (frozen_labels_.width() == 0) return 0;  // frozen without a label layer
      const CellIndex c = geometry_.FromLinearIndex(linear_index);
      return frozen_labels_.Get(c.x, c.y);
    }
    return has_label_layer_ ? labels_.GetLinear(linear_index) : 0;
  }
  bool has_labels() const { return frozen_ ? frozen_labels_.num_stored_tiles() > 0 : has_label_layer_; }
  // Occupancy probability in [0, 1], 0.5 for unknown. CHECK-fails on a frozen grid.
  float Probability(int linear_index) const;

  // For finished submaps that are only matched against: keeps the cell states and the label
  // layer, over the observed box grown by `margin_cells` (clipped to the grid) instead of the
  // grid, whose growth slack and border margin hold only unknown cells, in 8 × 8 tiles (states
  // in two bits a cell, labels in a byte) where a tile that is all unknown (labels: all 0) is
  // not stored (core/sparse_tiles.h; instead of log-odds, per-scan mark, heights and the tiled
  // hit index). The geometry becomes that box (same lattice, origin moved by whole cells), so
  // linear indices change; world positions, states and labels do not (every cell left out was
  // unknown, and StateAt still says so). Idempotent. Afterwards State, StateAt, IsOccupied and
  // LabelMask work; InsertScan, EnsureContains, AddCellObservation, HitPoint, Line, LogOdds
  // and Probability CHECK-fail.
  void Freeze(int margin_cells = 0);
  bool frozen() const { return frozen_; }
  // Bytes held by the cell arrays (capacity, not size: what the process holds).
  size_t MemoryBytes() const;
  int num_scans_refused() const { return num_scans_refused_; }

 private:
  void Resize(const GridGeometry& new_geometry);
  // The bounds EnsureContains grows to; false when the box is inside already.
  bool GrownBounds(const Eigen::Vector2d& min_world, const Eigen::Vector2d& max_world, Eigen::Vector2d* new_min,
                   Eigen::Vector2d* new_max) const;
  // Makes an occupied or free cell unknown again: log-odds, hit point, label and heights (the
  // observed box is not shrunk: it may hold unknown cells at its edge).
  void ForgetCell(const CellIndex& c);
  // Cell c, linear index i (the same cell).
  void UpdateCell(const CellIndex& c, int i, float delta_log_odds, std::vector<int>* changed_cells);

  OccupancyGridOptions options_;
  GridGeometry geometry_;
  // Log-odds per cell, kUnobserved where never observed, tiled: a submap's box is mostly
  // unknown space (core/tiled_index.h).
  TiledGrid<float> log_odds_{0, 0, kUnobserved};
  // What an occupied cell accumulates from its hits. Only occupied cells accumulate (a cell
  // turning free forgets), a few percent of the cells: they are kept in a pool, indexed per
  // cell in tiles that exist only where some cell has one (core/tiled_index.h).
  struct HitAccumulator {
    // Hit point sum relative to the cell's minimum corner (metres); relative storage keeps
    // float precision and survives growth unchanged.
    Eigen::Vector2f sum = Eigen::Vector2f::Zero();
    uint32_t count = 0;
    // Summed over the counted hits: half_length · (cos 2θ, sin 2θ, 1) of each hit's line (θ its
    // direction), nothing for a hit without one.
    Eigen::Vector3f line_sum = Eigen::Vector3f::Zero();
  };
  TiledIndex hit_index_;                // per cell: index into hits_, -1 for none
  std::vector<HitAccumulator> hits_;
  std::vector<int32_t> free_hits_;      // released entries of hits_, reused first
  bool has_lines_ = false;              // an insertion with lines happened
  // One bit a cell (linear index): rays pass over the cell. Between scans it is set where the
  // log-odds are min_log_odds, free space that another miss leaves as it is (observed, free
  // before and after, not a changed cell); within a scan also on every cell the scan updated,
  // which is updated once per scan (InsertScan: end points first, so that a ray never clears a
  // cell the same scan hits). Rays read this bit instead of the log-odds' tiles (ray casting is
  // bound by those reads: a fifth of FR079's run), and it takes the place of the per-scan marks
  // it replaced, so it costs no memory. Kept by every write of the log-odds: InsertScan (its
  // updated cells, updated_cells_, set back to the rule when it is done), AddCellObservation,
  // ForgetCell; rebuilt by Resize, freed by Freeze.
  bool PassOver(int i) const { return (pass_over_[static_cast<size_t>(i) >> 6] >> (i & 63)) & 1u; }
  void SetPassOver(int i, bool pass_over) {
    uint64_t& word = pass_over_[static_cast<size_t>(i) >> 6];
    const uint64_t bit = uint64_t{1} << (i & 63);
    word = pass_over ? (word | bit) : (word & ~bit);
  }
  // The rule between scans for cell i (c).
  bool AtLowest(const CellIndex& c) const {
    return log_odds_.Get(c.x, c.y) == static_cast<float>(options_.min_log_odds);
  }
  std::vector<uint64_t> pass_over_;
  std::vector<int> updated_cells_;  // the cells InsertScan updated, this scan
  // Label layer (0: no label); sized at the first labelled insertion. Only hit cells carry
  // labels and heights, so their tiles follow the surfaces.
  TiledGrid<uint8_t> labels_{0, 0, 0};
  bool has_label_layer_ = false;
  // Lowest and highest hit height per cell in 2 cm steps (0..5.1 m; 255 = none yet); sized at
  // the first insertion with heights.
  TiledGrid<uint8_t> height_min_{0, 0, 255}, height_max_{0, 0, 0};
  // Once frozen, the only per-cell data (CellState values; label masks, none at all, not even a
  // tile index, without a label layer), in tiles that leave out all-unknown (all-0) 8 × 8
  // blocks; every array above is then empty.
  SparseTiles2Bit frozen_states_;
  SparseTiles<uint8_t> frozen_labels_;
  bool frozen_ = false;
  int num_scans_refused_ = 0;  // see InsertScan
  CellIndex observed_min_{1, 1};
  CellIndex observed_max_{0, 0};
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_OCCUPANCY_GRID_H_
