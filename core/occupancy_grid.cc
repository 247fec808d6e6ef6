#include "core/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "glog/logging.h"

namespace hetslam {

bool OccupancyGridOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  // 5 mm .. 10 m: finer cells make a laser's 30 m reach exceed the grid's kMaxCells.
  if (!(resolution_meters >= 0.005 && resolution_meters <= 10.0))
    msg << "resolution_meters must be in [0.005, 10] (got " << resolution_meters << "); ";
  if (!(hit_log_odds > 0.0)) msg << "hit_log_odds must be > 0 (got " << hit_log_odds << "); ";
  // A hit must lift a cell off min_log_odds in the grid's float log-odds (InsertScan tells a
  // cell hit this scan from one at the lowest by it).
  if (hit_log_odds > 0.0 &&
      !(static_cast<float>(min_log_odds) + static_cast<float>(hit_log_odds) > static_cast<float>(min_log_odds)))
    msg << "hit_log_odds " << hit_log_odds << " is too small to change min_log_odds " << min_log_odds
        << " in float precision; ";
  if (!(miss_log_odds < 0.0)) msg << "miss_log_odds must be < 0 (got " << miss_log_odds << "); ";
  if (!(min_log_odds < occupied_threshold_log_odds && occupied_threshold_log_odds < max_log_odds))
    msg << "need min_log_odds < occupied_threshold_log_odds < max_log_odds; ";
  if (!(border_margin_meters >= 0.0)) msg << "border_margin_meters must be >= 0; ";
  if (!(growth_step_meters >= 0.0)) msg << "growth_step_meters must be >= 0; ";
  if (!(wall_min_height_span_meters > 0.0)) msg << "wall_min_height_span_meters must be > 0; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

bool ScanLineOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(max_gap_meters >= 0.0 && max_gap_meters <= 5.0)) msg << "max_gap_meters must be in [0, 5] (got " << max_gap_meters << "); ";
  if (!(fit_radius_meters >= 0.0 && fit_radius_meters <= 5.0)) msg << "fit_radius_meters must be in [0, 5]; ";
  if (!(max_rms_meters > 0.0 && max_rms_meters <= 1.0)) msg << "max_rms_meters must be in (0, 1]; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

OccupancyGrid::OccupancyGrid(const OccupancyGridOptions& options) : options_(options) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid OccupancyGridOptions: " << error;
  geometry_ = GridGeometry(Eigen::Vector2d::Zero(), options_.resolution_meters, 0, 0);
}

bool OccupancyGrid::GrownBounds(const Eigen::Vector2d& min_world, const Eigen::Vector2d& max_world,
                                Eigen::Vector2d* new_min, Eigen::Vector2d* new_max) const {
  const double r = options_.resolution_meters;
  const double margin = options_.border_margin_meters;
  const Eigen::Vector2d need_min = min_world.array() - margin;
  const Eigen::Vector2d need_max = max_world.array() + margin;
  // In doubles (continuous cell coordinates), not through WorldToCell: a far point must not
  // overflow an int cast before the size limit is checked.
  if (geometry_.num_cells() > 0) {
    const Eigen::Vector2d lo = geometry_.WorldToContinuousCell(need_min);
    const Eigen::Vector2d hi = geometry_.WorldToContinuousCell(need_max);
    if (std::floor(lo.x()) >= 0 && std::floor(lo.y()) >= 0 && std::floor(hi.x()) < geometry_.width() &&
        std::floor(hi.y()) < geometry_.height()) {
      return false;
    }
  }
  const double step = options_.growth_step_meters;
  // New bounds in whole cells on a world-aligned lattice (origin a multiple of r), so that
  // the grid does not depend on the order in which areas were explored.
  auto align_down = [r](double v) { return r * std::floor(v / r); };
  if (geometry_.num_cells() == 0) {
    *new_min = Eigen::Vector2d(align_down(need_min.x() - step / 2), align_down(need_min.y() - step / 2));
    *new_max = need_max.array() + step / 2;
  } else {
    const Eigen::Vector2d old_min = geometry_.origin();
    const Eigen::Vector2d old_max =
        old_min + Eigen::Vector2d(geometry_.width(), geometry_.height()) * r;
    *new_min = old_min;
    *new_max = old_max;
    for (int i = 0; i < 2; ++i) {
      if (need_min[i] < old_min[i]) (*new_min)[i] = old_min[i] - r * std::ceil((old_min[i] - need_min[i] + step) / r);
      if (need_max[i] >= old_max[i]) (*new_max)[i] = old_max[i] + (need_max[i] - old_max[i] + step);
    }
  }
  return true;
}

bool OccupancyGrid::CanContain(const Eigen::Vector2d& min_world, const Eigen::Vector2d& max_world) const {
  if (!(min_world.allFinite() && max_world.allFinite())) return false;
  Eigen::Vector2d new_min, new_max;
  if (!GrownBounds(min_world, max_world, &new_min, &new_max)) return true;
  const double r = options_.resolution_meters;
  const double width = std::ceil((new_max.x() - new_min.x()) / r - 1e-9);
  const double height = std::ceil((new_max.y() - new_min.y()) / r - 1e-9);
  return width * height < kMaxCells;
}

bool OccupancyGrid::EnsureContains(const Eigen::Vector2d& min_world,
                                   const Eigen::Vector2d& max_world) {
  CHECK(!frozen_) << "EnsureContains on a frozen grid";
  CHECK(min_world.allFinite() && max_world.allFinite()) << "non-finite box";
  CHECK(CanContain(min_world, max_world))
      << "occupancy grid would exceed " << kMaxCells << " cells to contain (" << min_world.transpose() << ") .. ("
      << max_world.transpose() << "): the caller must check CanContain first";
  Eigen::Vector2d new_min, new_max;
  if (!GrownBounds(min_world, max_world, &new_min, &new_max)) return false;
  const double r = options_.resolution_meters;
  const int width = static_cast<int>(std::ceil((new_max.x() - new_min.x()) / r - 1e-9));
  const int height = static_cast<int>(std::ceil((new_max.y() - new_min.y()) / r - 1e-9));
  Resize(GridGeometry(new_min, r, width, height));
  return true;
}

void OccupancyGrid::Resize(const GridGeometry& g) {
  const int n = g.num_cells();
  // Offset of the old grid inside the new one, in cells. Only the cells that differ from the
  // default move (the tiled layers hold nothing else).
  const int dx = static_cast<int>(std::lround((geometry_.origin().x() - g.origin().x()) / g.resolution_meters()));
  const int dy = static_cast<int>(std::lround((geometry_.origin().y() - g.origin().y()) / g.resolution_meters()));
  auto moved = [&](auto& old_layer) {
    std::decay_t<decltype(old_layer)> layer(g.width(), g.height(), old_layer.empty());
    old_layer.MoveTilesInto(dx, dy, &layer);
    return layer;
  };
  TiledGrid<float> log_odds = moved(log_odds_);
  TiledGrid<uint8_t> labels = moved(labels_);
  TiledGrid<uint8_t> height_min = moved(height_min_), height_max = moved(height_max_);
  TiledIndex hit_index(g.width(), g.height());
  hit_index_.MoveTilesInto(dx, dy, &hit_index);
  if (observed_max_.x >= observed_min_.x) {
    observed_min_ = {observed_min_.x + dx, observed_min_.y + dy};
    observed_max_ = {observed_max_.x + dx, observed_max_.y + dy};
  }
  geometry_ = g;
  log_odds_ = std::move(log_odds);
  hit_index_ = std::move(hit_index);
  // Between scans: rays pass over the cells at the lowest log-odds (see pass_over_).
  std::vector<uint64_t>((static_cast<size_t>(n) + 63) / 64, 0).swap(pass_over_);
  const float lowest = static_cast<float>(options_.min_log_odds);
  log_odds_.ForEach([&](int x, int y, float value) {
    if (value == lowest) SetPassOver(geometry_.LinearIndex({x, y}), true);
  });
  labels_ = std::move(labels);
  height_min_ = std::move(height_min);
  height_max_ = std::move(height_max);
}

void OccupancyGrid::UpdateCell(const CellIndex& c, int i, float delta, std::vector<int>* changed_cells) {
  float& log_odds = log_odds_.Ref(c.x, c.y);
  const float threshold = static_cast<float>(options_.occupied_threshold_log_odds);
  const bool was_occupied = log_odds > threshold;  // kUnobserved is not
  const bool was_observed = log_odds != kUnobserved;
  log_odds = std::clamp((was_observed ? log_odds : 0.f) + delta, static_cast<float>(options_.min_log_odds),
                        static_cast<float>(options_.max_log_odds));
  if (!was_observed) {
    if (observed_max_.x < observed_min_.x) {  // first observed cell
      observed_min_ = observed_max_ = c;
    } else {
      observed_min_ = {std::min(observed_min_.x, c.x), std::min(observed_min_.y, c.y)};
      observed_max_ = {std::max(observed_max_.x, c.x), std::max(observed_max_.y, c.y)};
    }
  }
  const bool now_occupied = log_odds > threshold;
  if (was_occupied && !now_occupied) {
    // The cell turned free (paper §III-B): its hit point is forgotten.
    const int32_t hit = hit_index_.Get(c.x, c.y);
    if (hit >= 0) {
      hits_[hit] = HitAccumulator();
      free_hits_.push_back(hit);
      hit_index_.Ref(c.x, c.y) = -1;
    }
  }
  if ((was_occupied != now_occupied || (delta > 0 && now_occupied)) && changed_cells != nullptr) {
    changed_cells->push_back(i);
  }
}

bool OccupancyGrid::InsertScan(const Eigen::Vector2d& sensor_world,
                               const std::vector<Eigen::Vector2d>& points_world,
                               std::vector<int>* changed_cells, const std::vector<uint8_t>* labels,
                               const std::vector<float>* heights, const std::vector<ScanLine>* lines) {
  CHECK(!frozen_) << "InsertScan on a frozen grid";
  CHECK(labels == nullptr || labels->size() == points_world.size())
      << "InsertScan: " << labels->size() << " labels for " << points_world.size() << " points";
  Eigen::Vector2d lo = sensor_world, hi = sensor_world;
  for (const Eigen::Vector2d& p : points_world) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // Non-finite or far points come from data (a corrupt pose, an absurd beam angle): the scan
  // is refused, not a crash. (NaN does not propagate through min/max: test every point.)
  bool finite = sensor_world.allFinite();
  for (const Eigen::Vector2d& p : points_world) finite = finite && p.allFinite();
  if (!finite || !CanContain(lo, hi)) {
    ++num_scans_refused_;
    return false;
  }
  EnsureContains(lo, hi);
  CHECK(heights == nullptr || heights->size() == points_world.size()) << "InsertScan: heights do not match points";
  CHECK(lines == nullptr || lines->size() == points_world.size()) << "InsertScan: lines do not match points";
  if (lines != nullptr) has_lines_ = true;
  if (labels != nullptr || heights != nullptr) has_label_layer_ = true;
  const int wall_span_steps = static_cast<int>(std::lround(options_.wall_min_height_span_meters / 0.02));
  const float hit = static_cast<float>(options_.hit_log_odds);
  const float miss = static_cast<float>(options_.miss_log_odds);
  // End points first, so that a ray never clears a cell this same scan hits.
  for (size_t k = 0; k < points_world.size(); ++k) {
    const Eigen::Vector2d& p = points_world[k];
    const CellIndex c = geometry_.WorldToCell(p);
    const int i = geometry_.LinearIndex(c);
    if (labels != nullptr) labels_.Ref(c.x, c.y) |= static_cast<uint8_t>(1u << ((*labels)[k] & 7u));
    if (heights != nullptr && std::isfinite((*heights)[k])) {
      const uint8_t h = static_cast<uint8_t>(std::clamp(std::lround((*heights)[k] / 0.02f), 0L, 254L));
      uint8_t& low = height_min_.Ref(c.x, c.y);
      uint8_t& high = height_max_.Ref(c.x, c.y);
      low = std::min(low, h);
      high = std::max(high, h);
      if (high - low >= wall_span_steps) labels_.Ref(c.x, c.y) |= 1u << kWallLabelBit;
    }
    // Not updated this scan yet: rays do not pass over it, or they do because it is at the
    // lowest log-odds (a hit would have raised it: hit_log_odds > 0).
    if (!PassOver(i) || log_odds_.Get(c.x, c.y) == static_cast<float>(options_.min_log_odds)) {
      UpdateCell(c, i, hit, changed_cells);
      SetPassOver(i, true);
      updated_cells_.push_back(i);
    }
    if (log_odds_.Get(c.x, c.y) > static_cast<float>(options_.occupied_threshold_log_odds)) {
      int32_t& hit_index = hit_index_.Ref(c.x, c.y);
      if (hit_index < 0) {
        if (free_hits_.empty()) {
          hit_index = static_cast<int32_t>(hits_.size());
          hits_.emplace_back();
        } else {
          hit_index = free_hits_.back();
          free_hits_.pop_back();
        }
      }
      HitAccumulator& acc = hits_[hit_index];
      acc.sum += (p - geometry_.CellMinCorner(c)).cast<float>();
      ++acc.count;
      if (lines != nullptr && (*lines)[k].half_length > 0.f) {
        const ScanLine& line = (*lines)[k];
        const float c2 = line.direction.x() * line.direction.x() - line.direction.y() * line.direction.y();
        const float s2 = 2.f * line.direction.x() * line.direction.y();
        acc.line_sum += line.half_length * Eigen::Vector3f(c2, s2, 1.f);
      }
    }
  }

  // Free space: traverse every cell a ray crosses (Amanatides–Woo), end cell excluded; cells
  // at the lowest log-odds and those this scan updated are passed over (pass_over_).
  const int width = geometry_.width();
  const Eigen::Vector2d start = geometry_.WorldToContinuousCell(sensor_world);
  const CellIndex start_cell = geometry_.WorldToCell(sensor_world);
  for (const Eigen::Vector2d& p : points_world) {
    const Eigen::Vector2d end = geometry_.WorldToContinuousCell(p);
    const CellIndex end_cell = geometry_.WorldToCell(p);
    const Eigen::Vector2d d = end - start;
    CellIndex c = start_cell;
    const int step_x = d.x() > 0 ? 1 : -1;
    const int step_y = d.y() > 0 ? 1 : -1;
    const double inf = std::numeric_limits<double>::infinity();
    const double t_delta_x = d.x() != 0 ? std::abs(1.0 / d.x()) : inf;
    const double t_delta_y = d.y() != 0 ? std::abs(1.0 / d.y()) : inf;
    double t_max_x = d.x() != 0 ? ((step_x > 0 ? (c.x + 1 - start.x()) : (start.x() - c.x)) * t_delta_x) : inf;
    double t_max_y = d.y() != 0 ? ((step_y > 0 ? (c.y + 1 - start.y()) : (start.y() - c.y)) * t_delta_y) : inf;
    // Each step moves one cell along x or y, so the end cell is max_steps steps away at least:
    // the traversal stops before it (or, rounding having taken it astray, after as many cells).
    const int max_steps = std::abs(end_cell.x - start_cell.x) + std::abs(end_cell.y - start_cell.y);
    int i = geometry_.LinearIndex(c);  // c's, kept along
    for (int n = 0; n < max_steps; ++n) {
      if (!PassOver(i)) {
        UpdateCell(c, i, miss, changed_cells);
        SetPassOver(i, true);
        updated_cells_.push_back(i);
      }
      if (t_max_x < t_max_y) {
        t_max_x += t_delta_x;
        c.x += step_x;
        i += step_x;
      } else {
        t_max_y += t_delta_y;
        c.y += step_y;
        i += step_y * width;
      }
    }
  }
  for (const int i : updated_cells_) SetPassOver(i, AtLowest(geometry_.FromLinearIndex(i)));
  updated_cells_.clear();
  return true;
}

void OccupancyGrid::AddCellObservation(const Eigen::Vector2d& p_world, float delta_log_odds) {
  CHECK(!frozen_) << "AddCellObservation on a frozen grid";
  CHECK(p_world.allFinite()) << "AddCellObservation at a non-finite point";
  CHECK(std::isfinite(delta_log_odds)) << "AddCellObservation with a non-finite log-odds change";
  EnsureContains(p_world, p_world);
  const CellIndex c = geometry_.WorldToCell(p_world);
  const int i = geometry_.LinearIndex(c);
  UpdateCell(c, i, delta_log_odds, nullptr);
  SetPassOver(i, AtLowest(c));
}

void OccupancyGrid::Freeze(int margin_cells) {
  if (frozen_) return;
  CHECK_GE(margin_cells, 0) << "Freeze: negative margin";
  // The kept box: observed cells plus the margin, clipped to the grid (empty grid: no cells).
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  if (observed_max_.x >= observed_min_.x) {
    x0 = std::max(0, observed_min_.x - margin_cells);
    y0 = std::max(0, observed_min_.y - margin_cells);
    x1 = std::min(geometry_.width() - 1, observed_max_.x + margin_cells);
    y1 = std::min(geometry_.height() - 1, observed_max_.y + margin_cells);
  }
  const int width = x1 - x0 + 1, height = y1 - y0 + 1;
  // Unknown (state 0) and unlabelled (0) where a tile has no log-odds or labels (never
  // observed): only the stored tiles' rows are read, a tile lookup per tile row.
  static_assert(static_cast<int>(CellState::kUnknown) == 0, "a cell without log-odds is state 0");
  std::vector<uint8_t> states(static_cast<size_t>(width) * height, 0);
  std::vector<uint8_t> labels(has_label_layer_ ? states.size() : 0, 0);
  constexpr int kTileSize = TiledGrid<float>::kTileSize;
  for (int y = 0; y < height; ++y) {
    uint8_t* to = states.data() + static_cast<size_t>(y) * width;
    uint8_t* labels_to = labels.empty() ? nullptr : labels.data() + static_cast<size_t>(y) * width;
    for (int x = 0; x < width;) {
      const int gx = x0 + x;
      const int chunk = std::min(width - x, kTileSize - (gx & (kTileSize - 1)));
      if (const float* log_odds = log_odds_.TileRow(gx, y + y0)) {
        for (int k = 0; k < chunk; ++k) to[x + k] = static_cast<uint8_t>(StateOfLogOdds(log_odds[k]));
      }
      if (labels_to != nullptr) {
        if (const uint8_t* label = labels_.TileRow(gx, y + y0)) std::copy(label, label + chunk, labels_to + x);
      }
      x += chunk;
    }
  }
  frozen_states_ = SparseTiles2Bit(states, width, height, static_cast<uint8_t>(CellState::kUnknown));
  frozen_labels_ = labels.empty() ? SparseTiles<uint8_t>() : SparseTiles<uint8_t>(labels, width, height, 0);
  labels_ = TiledGrid<uint8_t>(0, 0, 0);
  has_label_layer_ = false;
  // The crop keeps the lattice: the new origin is the old grid's corner of cell (x0, y0).
  geometry_ = GridGeometry(geometry_.CellMinCorner({x0, y0}), geometry_.resolution_meters(), width, height);
  if (observed_max_.x >= observed_min_.x) {
    observed_min_ = {observed_min_.x - x0, observed_min_.y - y0};
    observed_max_ = {observed_max_.x - x0, observed_max_.y - y0};
  }
  frozen_ = true;
  log_odds_ = TiledGrid<float>(0, 0, kUnobserved);
  hit_index_ = TiledIndex();
  std::vector<HitAccumulator>().swap(hits_);
  std::vector<int32_t>().swap(free_hits_);
  std::vector<uint64_t>().swap(pass_over_);
  std::vector<int>().swap(updated_cells_);
  height_min_ = TiledGrid<uint8_t>(0, 0, 255);
  height_max_ = TiledGrid<uint8_t>(0, 0, 0);
}

size_t OccupancyGrid::MemoryBytes() const {
  return log_odds_.MemoryBytes() + hit_index_.MemoryBytes() +
         hits_.capacity() * sizeof(HitAccumulator) + free_hits_.capacity() * sizeof(int32_t) +
         pass_over_.capacity() * sizeof(uint64_t) + updated_cells_.capacity() * sizeof(int) +
         labels_.MemoryBytes() + height_min_.MemoryBytes() + height_max_.MemoryBytes() + frozen_states_.MemoryBytes() +
         frozen_labels_.MemoryBytes();
}

float OccupancyGrid::LogOdds(int i) const {
  CHECK(!frozen_) << "LogOdds on a frozen grid";
  const float log_odds = log_odds_.GetLinear(i);
  return log_odds == kUnobserved ? 0.f : log_odds;
}

int OccupancyGrid::DropWeakOccupiedCells(double min_share) {
  CHECK(!frozen_) << "DropWeakOccupiedCells on a frozen grid";
  if (min_share <= 0.0 || observed_max_.x < observed_min_.x) return 0;
  auto occupied_at = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < geometry_.width() && y < geometry_.height() &&
           StateOfLogOdds(log_odds_.Get(x, y)) == CellState::kOccupied;
  };
  auto unknown_at = [&](int x, int y) {
    return x < 0 || y < 0 || x >= geometry_.width() || y >= geometry_.height() ||
           log_odds_.Get(x, y) == kUnobserved;
  };
  auto count_at = [&](int x, int y) -> uint32_t {
    if (!occupied_at(x, y)) return 0;
    const int32_t hit = hit_index_.Get(x, y);
    return hit < 0 ? 0 : hits_[hit].count;
  };
  std::vector<CellIndex> weak;
  for (int y = observed_min_.y; y <= observed_max_.y; ++y) {
    for (int x = observed_min_.x; x <= observed_max_.x; ++x) {
      if (hit_index_.Get(x, y) < 0 || !occupied_at(x, y)) continue;
      // Behind a stronger neighbour: the cell on the far side, away from it, was never observed
      // (beyond the surface lies what no ray reached). A weaker cell along a surface has the
      // surface going on at its far side, one in front of it free space: both stay.
      const double count = count_at(x, y);
      bool behind = false;
      for (int dy = -1; dy <= 1 && !behind; ++dy) {
        for (int dx = -1; dx <= 1 && !behind; ++dx) {
          if (dx == 0 && dy == 0) continue;
          behind = count < min_share * count_at(x + dx, y + dy) && unknown_at(x - dx, y - dy);
        }
      }
      if (behind) weak.push_back({x, y});
    }
  }
  for (const CellIndex& c : weak) ForgetCell(c);
  return static_cast<int>(weak.size());
}

int OccupancyGrid::DropSmallOccupiedPieces(double min_extent_meters, int link_cells) {
  CHECK(!frozen_) << "DropSmallOccupiedPieces on a frozen grid";
  CHECK_GE(link_cells, 0) << "DropSmallOccupiedPieces: negative link_cells";
  if (min_extent_meters <= 0.0 || observed_max_.x < observed_min_.x) return 0;
  const int x0 = observed_min_.x, y0 = observed_min_.y;
  const int width = observed_max_.x - x0 + 1, height = observed_max_.y - y0 + 1;
  auto occupied = [&](int x, int y) {
    return x >= x0 && y >= y0 && x < x0 + width && y < y0 + height &&
           StateOfLogOdds(log_odds_.Get(x, y)) == CellState::kOccupied;
  };
  std::vector<uint8_t> seen(static_cast<size_t>(width) * height, 0);
  auto seen_at = [&](int x, int y) -> uint8_t& { return seen[static_cast<size_t>(y - y0) * width + (x - x0)]; };
  std::vector<CellIndex> piece, small;
  for (int y = y0; y < y0 + height; ++y) {
    for (int x = x0; x < x0 + width; ++x) {
      if (seen_at(x, y) || !occupied(x, y)) continue;
      // One piece, breadth first.
      piece.assign(1, CellIndex{x, y});
      seen_at(x, y) = 1;
      CellIndex lo{x, y}, hi{x, y};
      for (size_t k = 0; k < piece.size(); ++k) {
        const CellIndex c = piece[k];
        lo = {std::min(lo.x, c.x), std::min(lo.y, c.y)};
        hi = {std::max(hi.x, c.x), std::max(hi.y, c.y)};
        for (int dy = -link_cells; dy <= link_cells; ++dy) {
          for (int dx = -link_cells; dx <= link_cells; ++dx) {
            const int nx = c.x + dx, ny = c.y + dy;
            if (!occupied(nx, ny) || seen_at(nx, ny)) continue;
            seen_at(nx, ny) = 1;
            piece.push_back({nx, ny});
          }
        }
      }
      const double extent = std::hypot(hi.x - lo.x + 1, hi.y - lo.y + 1) * geometry_.resolution_meters();
      if (extent < min_extent_meters) small.insert(small.end(), piece.begin(), piece.end());
    }
  }
  for (const CellIndex& c : small) ForgetCell(c);
  return static_cast<int>(small.size());
}

int OccupancyGrid::ForgetCells(const std::vector<CellIndex>& cells) {
  CHECK(!frozen_) << "ForgetCells on a frozen grid";
  int forgotten = 0;
  for (const CellIndex& c : cells) {
    if (!geometry_.Contains(c) || State(c) == CellState::kUnknown) continue;
    ForgetCell(c);
    ++forgotten;
  }
  return forgotten;
}

void OccupancyGrid::ForgetCell(const CellIndex& c) {
  const int32_t hit = hit_index_.Get(c.x, c.y);
  if (hit >= 0) {
    hits_[hit] = HitAccumulator();
    free_hits_.push_back(hit);
    hit_index_.Ref(c.x, c.y) = -1;
  }
  log_odds_.Set(c.x, c.y, kUnobserved);
  if (!frozen_) SetPassOver(geometry_.LinearIndex(c), false);  // unobserved: not at the lowest
  if (has_label_layer_) labels_.Set(c.x, c.y, 0);
  if (height_min_.width() > 0) height_min_.Set(c.x, c.y, 255);
  if (height_max_.width() > 0) height_max_.Set(c.x, c.y, 0);
}

Eigen::Vector2d OccupancyGrid::HitPoint(int i) const {
  CHECK(!frozen_) << "HitPoint on a frozen grid";
  const CellIndex c = geometry_.FromLinearIndex(i);
  const int32_t hit = hit_index_.Get(c.x, c.y);
  if (hit < 0 || hits_[hit].count == 0) return geometry_.CellCenter(c);
  const HitAccumulator& acc = hits_[hit];
  return geometry_.CellMinCorner(c) + (acc.sum / static_cast<float>(acc.count)).cast<double>();
}

ScanLine OccupancyGrid::Line(int i) const {
  CHECK(!frozen_) << "Line on a frozen grid";
  ScanLine line;
  if (!has_lines_) return line;
  const int32_t hit = hit_index_.GetLinear(i);
  if (hit < 0 || hits_[hit].count == 0) return line;
  const Eigen::Vector3f& sum = hits_[hit].line_sum;
  if (!(sum.z() > 0.f) || sum.head<2>().norm() < kMinLineCoherence * sum.z()) return line;
  const float theta = 0.5f * std::atan2(sum.y(), sum.x());  // in (-π/2, π/2]: direction.x >= 0
  line.direction = Eigen::Vector2f(std::cos(theta), std::sin(theta));
  line.half_length = sum.z() / static_cast<float>(hits_[hit].count);
  return line;
}

float OccupancyGrid::Probability(int i) const {
  CHECK(!frozen_) << "Probability on a frozen grid";
  const float log_odds = log_odds_.GetLinear(i);
  if (log_odds == kUnobserved) return 0.5f;
  return 1.f - 1.f / (1.f + std::exp(log_odds));
}

}  // namespace hetslam
