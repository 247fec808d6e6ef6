#include "core/likelihood_field.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <utility>
#include <vector>

#include "core/vector4.h"
#include "glog/logging.h"

namespace hetslam {
namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInfinity = std::numeric_limits<float>::infinity();
// Marks a squared distance as stale (no real d^2 is negative); see ApplyChanges.
constexpr float kStale = -1.f;
// Marks a value as not yet computed from its lowered squared distance (no value is negative);
// see ApplyChanges.
constexpr float kPendingValue = -1.f;
// The most queued values whose room ApplyChanges keeps between batches (64 KiB).
constexpr size_t kKeptPendingValues = 16384;

// LikelihoodField::SquaredDistance four at a time (core/vector4.h: the same floats): lane k is
// from the segment (point, direction, half_length) of occupied cell o_k to the centre of cell
// c_k, (c_k - o_k) = (dx_cells[k], dy_cells[k]).
Floats4 FourSquaredDistances(Ints4 dx_cells, Ints4 dy_cells, float r, Floats4 point_x, Floats4 point_y,
                             Floats4 direction_x, Floats4 direction_y, Floats4 half_length) {
  const Floats4 dx = (__builtin_convertvector(dx_cells, Floats4) + 0.5f) * r - point_x;
  const Floats4 dy = (__builtin_convertvector(dy_cells, Floats4) + 0.5f) * r - point_y;
  const Floats4 along = dx * direction_x + dy * direction_y;
  const Floats4 across = dy * direction_x - dx * direction_y;
  // |along| (the sign bit cleared), then max(0, |along| - half_length) as std::max(0.f, v)
  // evaluates it: 0 < v ? v : 0.
  const Floats4 excess = reinterpret_cast<Floats4>(reinterpret_cast<Ints4>(along) & 0x7fffffff) - half_length;
  const Floats4 beyond = Floats4{} < excess ? excess : Floats4{};
  return across * across + beyond * beyond;
}
}  // namespace

const LikelihoodField::Segment LikelihoodField::kUnpublished{Eigen::Vector2f(kNaN, kNaN), Eigen::Vector2f::UnitX(), 0.f};

LikelihoodField::Segment LikelihoodField::SegmentOf(const OccupancyGrid& grid, int i) const {
  const ScanLine line = grid.has_lines() ? grid.Line(i) : ScanLine();
  return {(grid.HitPoint(i) - geometry_.CellMinCorner(geometry_.FromLinearIndex(i))).cast<float>(), line.direction,
          line.half_length};
}

void LikelihoodField::SetPublished(int i, const Segment& s) {
  if (s.point.x() != s.point.x()) {  // NaN: withdraw
    const int32_t current = published_index_.GetLinear(i);
    if (current >= 0) {
      free_segments_.push_back(current);
      published_index_.RefLinear(i) = -1;
    }
    return;
  }
  int32_t& index = published_index_.RefLinear(i);
  if (index < 0) {
    if (free_segments_.empty()) {
      index = static_cast<int32_t>(segments_.size());
      segments_.push_back(s);
      return;
    }
    index = free_segments_.back();
    free_segments_.pop_back();
  }
  segments_[index] = s;
}

bool LikelihoodFieldOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  // Upper limits: the field's window is (2 max_distance / cell)^2 cells around every hit.
  if (!(sigma_meters > 0.0 && sigma_meters <= 5.0))
    msg << "sigma_meters must be in (0, 5] (got " << sigma_meters << "); ";
  if (!(max_distance_meters > 0.0 && max_distance_meters <= 5.0))
    msg << "max_distance_meters must be in (0, 5] (got " << max_distance_meters << "); ";
  if (!(republish_distance_meters >= 0.0)) msg << "republish_distance_meters must be >= 0; ";
  if (!(republish_angle_radians >= 0.0)) msg << "republish_angle_radians must be >= 0; ";
  std::string sub;
  if (!lines.IsValid(&sub)) msg << "lines: " << sub;
  if (!(lines.max_gap_meters <= 2.0 * max_distance_meters))
    msg << "lines.max_gap_meters must be at most 2 max_distance_meters (got " << lines.max_gap_meters << "); ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

const LikelihoodField::FrozenCodes& LikelihoodField::SharedFrozenCodes(double sigma_meters, double window_meters,
                                                                       double cap_meters) {
  // One table per (sigma, window, cap): every field of a run shares one. Never freed.
  static std::mutex mutex;
  static std::vector<std::unique_ptr<FrozenCodes>> tables;
  const std::lock_guard<std::mutex> lock(mutex);
  for (const std::unique_ptr<FrozenCodes>& t : tables) {
    if (t->sigma_meters == sigma_meters && t->window_meters == window_meters && t->cap_meters == cap_meters) return *t;
  }
  auto t = std::make_unique<FrozenCodes>();
  t->sigma_meters = sigma_meters;
  t->window_meters = window_meters;
  t->cap_meters = cap_meters;
  t->distance_step_meters = window_meters / 254.0;
  t->squared_distance[0] = cap_meters * cap_meters;
  for (int code = 1; code < 256; ++code) {
    const double d = (255 - code) * t->distance_step_meters;
    t->value[code] = std::max(static_cast<float>(std::exp(-d / sigma_meters)), std::numeric_limits<float>::min());
    t->squared_distance[code] = std::min(d, cap_meters) * std::min(d, cap_meters);
  }
  tables.push_back(std::move(t));
  return *tables.back();
}

const LikelihoodField::FrozenCodes& LikelihoodField::frozen_codes() const {
  CHECK(frozen_) << "frozen_codes() before Freeze";
  return *codes_;
}

LikelihoodField::LikelihoodField(const LikelihoodFieldOptions& options, uint8_t surface_labels)
    : options_(options), surface_labels_(surface_labels) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid LikelihoodFieldOptions: " << error;
}

void LikelihoodField::Freeze(const GridGeometry& kept) {
  if (frozen_) return;
  const double r = geometry_.resolution_meters();
  CHECK_EQ(kept.resolution_meters(), r) << "Freeze: resolution changed";
  // Offset of the kept box in the current grid, in whole cells.
  const int x0 = static_cast<int>(std::lround((kept.origin().x() - geometry_.origin().x()) / r));
  const int y0 = static_cast<int>(std::lround((kept.origin().y() - geometry_.origin().y()) / r));
  CHECK(kept.num_cells() == 0 || (x0 >= 0 && y0 >= 0 && x0 + kept.width() <= geometry_.width() &&
                                  y0 + kept.height() <= geometry_.height()))
      << "Freeze: the kept box is not inside the field";
  // The largest distance a value within the window stands for: from a cell centre R cells
  // away along both axes to a hit point anywhere in its cell.
  const double window_meters = (radius_cells_ + 0.5) * std::sqrt(2.0) * r;
  codes_ = &SharedFrozenCodes(options_.sigma_meters, window_meters, radius_cells_ * r);
  const double inv_step = 1.0 / codes_->distance_step_meters;
  // Code 0 where the value is 0: everywhere a tile of values_ has none (most of a submap's box,
  // which reaches as far as its rays), so only the stored tiles' rows are read.
  std::vector<uint8_t> codes(kept.num_cells(), 0);
  constexpr int kTileSize = TiledGrid<float>::kTileSize;
  for (int y = 0; y < kept.height(); ++y) {
    uint8_t* to = codes.data() + static_cast<size_t>(y) * kept.width();
    for (int x = 0; x < kept.width();) {
      const int gx = x0 + x;
      const int chunk = std::min(kept.width() - x, kTileSize - (gx & (kTileSize - 1)));
      const float* values = values_.TileRow(gx, y + y0);
      if (values != nullptr) {
        // (A tile of values without one of squared distances would read +inf, their empty value.)
        const float* squared = squared_distances_.TileRow(gx, y + y0);
        for (int k = 0; k < chunk; ++k) {
          // Round the distance to the nearest step; a value that is not 0 keeps a code >= 1
          // (see Freeze in the header).
          if (!(values[k] > 0.f)) continue;
          const float squared_distance = squared != nullptr ? squared[k] : kInfinity;
          const double steps = std::round(std::sqrt(static_cast<double>(squared_distance)) * inv_step);
          to[x + k] = static_cast<uint8_t>(255 - static_cast<int>(std::clamp(steps, 0.0, 254.0)));
        }
      }
      x += chunk;
    }
  }
  frozen_codes_ = SparseTiles<uint8_t>(codes, kept.width(), kept.height(), 0);
  // Chessboard distance transform over the tiles (two passes, 8-neighbourhood: exact for the
  // Chebyshev metric).
  const int tx = frozen_codes_.tiles_x(), ty = frozen_codes_.tiles_y();
  tile_distances_.assign(static_cast<size_t>(tx) * ty, 255);
  auto at = [&](int x, int y) -> uint8_t& { return tile_distances_[static_cast<size_t>(y) * tx + x]; };
  for (int y = 0; y < ty; ++y) {
    for (int x = 0; x < tx; ++x) {
      if (frozen_codes_.TileStored(x, y)) {
        at(x, y) = 0;
        continue;
      }
      int d = at(x, y);
      if (x > 0) d = std::min(d, at(x - 1, y) + 1);
      if (y > 0) {
        for (int nx = std::max(0, x - 1); nx <= std::min(tx - 1, x + 1); ++nx) d = std::min(d, at(nx, y - 1) + 1);
      }
      at(x, y) = static_cast<uint8_t>(std::min(d, 255));
    }
  }
  for (int y = ty - 1; y >= 0; --y) {
    for (int x = tx - 1; x >= 0; --x) {
      int d = at(x, y);
      if (x + 1 < tx) d = std::min(d, at(x + 1, y) + 1);
      if (y + 1 < ty) {
        for (int nx = std::max(0, x - 1); nx <= std::min(tx - 1, x + 1); ++nx) d = std::min(d, at(nx, y + 1) + 1);
      }
      at(x, y) = static_cast<uint8_t>(std::min(d, 255));
    }
  }
  tile_distances_.shrink_to_fit();
  values_ = TiledGrid<float>();
  geometry_ = kept;
  frozen_ = true;
  published_index_ = TiledIndex();
  std::vector<Segment>().swap(segments_);
  std::vector<int32_t>().swap(free_segments_);
  squared_distances_ = TiledGrid<float>();
  std::vector<int>().swap(stale_cells_);
  std::vector<int>().swap(pending_values_);
}

bool LikelihoodField::MayBeNonZeroNear(const CellIndex& c, int radius_cells) const {
  if (!frozen_) return true;
  if (tile_distances_.empty()) return false;  // an empty grid holds only zeros
  // Clamp c into the grid; the cells within the radius that lie in the grid are within the
  // same radius of the clamped cell.
  const int w = geometry_.width(), h = geometry_.height();
  const int outside = std::max({-c.x, c.x - (w - 1), -c.y, c.y - (h - 1), 0});
  if (outside > radius_cells) return false;
  const int x = std::clamp(c.x, 0, w - 1), y = std::clamp(c.y, 0, h - 1);
  constexpr int kBits = SparseTiles<uint8_t>::kTileBits;
  // A cell within r of (x, y) lies in a tile at most (r + size - 1) / size tiles away.
  const int reach_tiles = (radius_cells + SparseTiles<uint8_t>::kTileSize - 1) >> kBits;
  const int d = tile_distances_[static_cast<size_t>(y >> kBits) * frozen_codes_.tiles_x() + (x >> kBits)];
  return d <= reach_tiles;
}

size_t LikelihoodField::MemoryBytes() const {
  return values_.MemoryBytes() + frozen_codes_.MemoryBytes() + tile_distances_.capacity() +
         squared_distances_.MemoryBytes() +
         (stale_cells_.capacity() + pending_values_.capacity()) * sizeof(int) + published_index_.MemoryBytes() +
         segments_.capacity() * sizeof(Segment) + free_segments_.capacity() * sizeof(int32_t);
}

void LikelihoodField::Resize(const GridGeometry& g) {
  CHECK(!frozen_) << "Resize on a frozen likelihood field";
  const double r = g.resolution_meters();
  radius_cells_ = static_cast<int>(std::ceil(options_.max_distance_meters / r - 1e-9));
  TiledGrid<float> values(g.width(), g.height(), 0.f);
  TiledGrid<float> squared_distances(g.width(), g.height(), kInfinity);
  TiledIndex published_index(g.width(), g.height());
  if (geometry_.num_cells() > 0) {
    CHECK_EQ(g.resolution_meters(), geometry_.resolution_meters()) << "resolution changed";
    const int dx = static_cast<int>(std::lround((geometry_.origin().x() - g.origin().x()) / r));
    const int dy = static_cast<int>(std::lround((geometry_.origin().y() - g.origin().y()) / r));
    // Only the cells that differ from the default move (the grids hold nothing else).
    values_.MoveTilesInto(dx, dy, &values);
    squared_distances_.MoveTilesInto(dx, dy, &squared_distances);
    published_index_.MoveTilesInto(dx, dy, &published_index);
  }
  geometry_ = g;
  values_ = std::move(values);
  squared_distances_ = std::move(squared_distances);
  published_index_ = std::move(published_index);
}

float LikelihoodField::ValueFromSquaredDistance(float squared_distance) const {
  return std::exp(-std::sqrt(squared_distance) / static_cast<float>(options_.sigma_meters));
}

float LikelihoodField::RecomputeSquaredDistance(const CellIndex& c) const {
  float best = kInfinity;
  const int x0 = std::max(0, c.x - radius_cells_), x1 = std::min(geometry_.width() - 1, c.x + radius_cells_);
  const int y0 = std::max(0, c.y - radius_cells_), y1 = std::min(geometry_.height() - 1, c.y + radius_cells_);
  ForEachPublished(x0, x1, y0, y1, [&](const CellIndex& o, int32_t index) {
    best = std::min(best, SquaredDistance(c, o, segments_[index]));
  });
  return best;
}

void LikelihoodField::ApplyChanges(const OccupancyGrid& grid, const std::vector<int>& changed_cells) {
  CHECK(!frozen_) << "ApplyChanges on a frozen likelihood field";
  if (geometry_.num_cells() != grid.geometry().num_cells() ||
      geometry_.origin() != grid.geometry().origin()) {
    Resize(grid.geometry());
  }
  const float republish_sq = static_cast<float>(options_.republish_distance_meters * options_.republish_distance_meters);
  const float republish_length = static_cast<float>(options_.republish_distance_meters);
  const float republish_cos = static_cast<float>(std::cos(options_.republish_angle_radians));
  const float resolution = static_cast<float>(geometry_.resolution_meters());
  // Cells that may have lost their nearest point are recomputed once, after every change of
  // this batch is published: neighbouring hit points along a wall often republish together,
  // and would otherwise recompute the same cells several times. Until then they are marked
  // kStale and skipped (the final recompute reads the final published points, so the result
  // is the same as recomputing at once). Likewise a cell's value is computed once, from its
  // last squared distance, not at every lowering (Intel: 2.1 lowerings a lowered cell): until
  // then it is kPendingValue and the cell queued (values are read only after the batch).
  stale_cells_.clear();
  pending_values_.clear();
  for (int i : changed_cells) {
    const CellIndex o = geometry_.FromLinearIndex(i);
    const Segment old_s = Published(i);
    const bool had = HasPublished(i);
    const bool has = IsSurface(grid, i);
    Segment new_s = kUnpublished;
    if (has) {
      new_s = SegmentOf(grid, i);
      // Not worth republishing (directions are axes: either sign is the same line; a point's
      // direction does not matter).
      if (had && (new_s.point - old_s.point).squaredNorm() <= republish_sq &&
          std::abs(new_s.half_length - old_s.half_length) <= republish_length &&
          (new_s.half_length == 0.f || std::abs(new_s.direction.dot(old_s.direction)) >= republish_cos)) {
        continue;
      }
    } else if (!had) {
      continue;
    }
    SetPublished(i, new_s);
    const int x0 = std::max(0, o.x - radius_cells_), x1 = std::min(geometry_.width() - 1, o.x + radius_cells_);
    const int y0 = std::max(0, o.y - radius_cells_), y1 = std::min(geometry_.height() - 1, o.y + radius_cells_);
    for (int y = y0; y <= y1; ++y) {
      // Tile by tile. A tile without squared distances holds +inf everywhere: a withdrawn
      // point changes nothing there, a published one lowers every cell of it.
      for (int x = x0; x <= x1;) {
        const int end = std::min(x1 + 1, (x | (TiledGrid<float>::kTileSize - 1)) + 1);
        float* squared_distance = squared_distances_.MutableTileRow(x, y);
        if (squared_distance == nullptr) {
          if (!has) {
            x = end;
            continue;
          }
          squared_distance = &squared_distances_.Ref(x, y);
        }
        float* value = nullptr;  // values_'s row of the same tile, on the first write
        // The new point's d^2 for the tile row's cells first, all eight at once (cells past
        // `end` are not used).
        static_assert(TiledGrid<float>::kTileSize == 8, "a tile row of eight cells: two FourSquaredDistances");
        std::array<float, TiledGrid<float>::kTileSize> new_squared_distances;
        if (has) {
          for (int half = 0; half < 8; half += 4) {
            const Floats4 squared = FourSquaredDistances(
                Ints4{0, 1, 2, 3} + (x + half - o.x), Splat(y - o.y), resolution, Splat(new_s.point.x()),
                Splat(new_s.point.y()), Splat(new_s.direction.x()), Splat(new_s.direction.y()), Splat(new_s.half_length));
            std::memcpy(new_squared_distances.data() + half, &squared, sizeof(squared));
          }
        }
        auto lower = [&](int k) {
          squared_distance[k] = new_squared_distances[k];
          if (value == nullptr) value = &values_.Ref(x, y);
          if (value[k] != kPendingValue) {
            value[k] = kPendingValue;
            pending_values_.push_back(y * geometry_.width() + x + k);
          }
        };
        if (!had) {
          // A new point (has): it only lowers. The cells it lowers as bits, then each of them
          // (a stale cell's kStale is below every d^2: never lowered).
          unsigned lowered = 0;
          for (int k = 0; k < end - x; ++k) {
            lowered |= static_cast<unsigned>(new_squared_distances[k] < squared_distance[k]) << k;
          }
          for (; lowered != 0; lowered &= lowered - 1) lower(__builtin_ctz(lowered));
          x = end;
          continue;
        }
        for (int k = 0; k < end - x; ++k) {
          const CellIndex c{x + k, y};
          if (squared_distance[k] == kStale) continue;
          const float new_squared_distance = has ? new_squared_distances[k] : kInfinity;
          if (new_squared_distance < squared_distance[k]) {
            lower(k);
          } else if (had && new_squared_distance > squared_distance[k] &&
                     SquaredDistance(c, o, old_s) <= squared_distance[k]) {
            // c's nearest point may have been o's old point, which is gone: recompute it
            // (below). A new d^2 equal to the old minimum leaves the minimum as it is.
            squared_distance[k] = kStale;
            stale_cells_.push_back(y * geometry_.width() + x + k);
          }
        }
        x = end;
      }
    }
  }
  // The stale cells get their values with their squared distances; a lowered cell that went
  // stale after is no longer pending.
  RecomputeStaleCells();
  for (const int i : pending_values_) {
    const CellIndex c = geometry_.FromLinearIndex(i);
    float& value = values_.Ref(c.x, c.y);
    if (value == kPendingValue) value = ValueFromSquaredDistance(squared_distances_.Get(c.x, c.y));
  }
  // A large batch (a submap's field catching up on many scans at once) keeps no list behind it
  // until the next: kept, the lists raised FR079's peak RSS by about 0.5 MiB (three runs each).
  if (pending_values_.capacity() > kKeptPendingValues) std::vector<int>().swap(pending_values_);
}

void LikelihoodField::RecomputeStaleCells() {
  const size_t n = stale_cells_.size();
  if (n == 0) return;
  // Each stale cell's RecomputeSquaredDistance (the minimum over the same published points:
  // a minimum does not depend on the order they are visited in), computed tile by tile of the
  // stale cells: the published points of the tiles a tile's windows reach are listed once for
  // all its stale cells (Intel: ~640 stale cells a scan, ~8 points in each 13 x 13 window,
  // every window's 169 cells read cell by cell before). Written in the order the cells went
  // stale, as before.
  constexpr int kBits = TiledIndex::kTileBits, kSize = TiledIndex::kTileSize;
  const int w = geometry_.width(), h = geometry_.height(), radius = radius_cells_;
  const float resolution = static_cast<float>(geometry_.resolution_meters());
  std::vector<std::pair<int64_t, int>> by_tile(n);  // (tile key, position in stale_cells_)
  for (size_t j = 0; j < n; ++j) {
    const int x = stale_cells_[j] % w, y = stale_cells_[j] / w;
    by_tile[j] = {(static_cast<int64_t>(y >> kBits) << 32) | (x >> kBits), static_cast<int>(j)};
  }
  std::sort(by_tile.begin(), by_tile.end());
  // The published points near a tile, by field (FourSquaredDistances' lanes), padded to a
  // multiple of 4 with points out of every cell's reach.
  struct Nearby {
    std::vector<int32_t> x, y;
    std::vector<float> point_x, point_y, direction_x, direction_y, half_length;
    void Clear() {
      for (auto* v : {&x, &y}) v->clear();
      for (auto* v : {&point_x, &point_y, &direction_x, &direction_y, &half_length}) v->clear();
    }
    void Add(const CellIndex& cell, const Segment& s) {
      x.push_back(cell.x);
      y.push_back(cell.y);
      point_x.push_back(s.point.x());
      point_y.push_back(s.point.y());
      direction_x.push_back(s.direction.x());
      direction_y.push_back(s.direction.y());
      half_length.push_back(s.half_length);
    }
    size_t size() const { return x.size(); }
  } nearby;
  // A padding point's cell: farther than `radius` from every cell of the grid (whose
  // coordinates are below 2^30), and c - kFar does not overflow.
  constexpr int32_t kFar = -(1 << 30);
  const Segment far_segment{Eigen::Vector2f::Zero(), Eigen::Vector2f::UnitX(), 0.f};
  std::vector<float> recomputed(n);
  for (size_t first = 0; first < n;) {
    size_t last = first;
    while (last < n && by_tile[last].first == by_tile[first].first) ++last;
    const int tile_x = static_cast<int>(by_tile[first].first & 0xffffffff);
    const int tile_y = static_cast<int>(by_tile[first].first >> 32);
    // The cells within `radius` of the tile's cells, inside the grid.
    const int x0 = std::max(0, (tile_x << kBits) - radius), x1 = std::min(w - 1, (tile_x << kBits) + kSize - 1 + radius);
    const int y0 = std::max(0, (tile_y << kBits) - radius), y1 = std::min(h - 1, (tile_y << kBits) + kSize - 1 + radius);
    nearby.Clear();
    ForEachPublished(x0, x1, y0, y1, [&](const CellIndex& o, int32_t index) { nearby.Add(o, segments_[index]); });
    while (nearby.size() % 4 != 0) nearby.Add({kFar, kFar}, far_segment);
    for (size_t j = first; j < last; ++j) {
      const int stale = stale_cells_[by_tile[j].second];
      const CellIndex c{stale % w, stale / w};
      // The least d^2 over the points within `radius` on both axes (a minimum: the same
      // whatever the order, and no d^2 is NaN).
      Floats4 best = Splat(kInfinity);
      for (size_t i = 0; i < nearby.size(); i += 4) {
        const Ints4 dx_cells = c.x - Load4<Ints4>(&nearby.x[i]), dy_cells = c.y - Load4<Ints4>(&nearby.y[i]);
        const Ints4 within = (dx_cells <= radius) & (dx_cells >= -radius) & (dy_cells <= radius) & (dy_cells >= -radius);
        const Floats4 squared = FourSquaredDistances(
            dx_cells, dy_cells, resolution, Load4<Floats4>(&nearby.point_x[i]), Load4<Floats4>(&nearby.point_y[i]),
            Load4<Floats4>(&nearby.direction_x[i]), Load4<Floats4>(&nearby.direction_y[i]),
            Load4<Floats4>(&nearby.half_length[i]));
        best = within != 0 && squared < best ? squared : best;
      }
      float least = kInfinity;
      for (int k = 0; k < 4; ++k) least = std::min(least, best[k]);
      recomputed[by_tile[j].second] = least;
    }
    first = last;
  }
  for (size_t j = 0; j < n; ++j) {
    const CellIndex c = geometry_.FromLinearIndex(stale_cells_[j]);
    squared_distances_.Ref(c.x, c.y) = recomputed[j];
    values_.Set(c.x, c.y, ValueFromSquaredDistance(recomputed[j]));
  }
}

void LikelihoodField::RebuildAll() {
  CHECK(!frozen_) << "RebuildAll on a frozen likelihood field";
  for (int y = 0; y < geometry_.height(); ++y) {
    for (int x = 0; x < geometry_.width(); ++x) {
      const float squared_distance = RecomputeSquaredDistance({x, y});
      squared_distances_.Set(x, y, squared_distance);
      values_.Set(x, y, ValueFromSquaredDistance(squared_distance));
    }
  }
}

void LikelihoodField::RebuildFrom(const OccupancyGrid& grid) {
  Resize(grid.geometry());
  for (int i = 0; i < geometry_.num_cells(); ++i) SetPublished(i, IsSurface(grid, i) ? SegmentOf(grid, i) : kUnpublished);
  RebuildAll();
}

}  // namespace hetslam
