// A per-cell index (into a pool of per-cell records) for a grid where few cells have a record:
// the cells of a growing grid that hold a hit accumulator (core/occupancy_grid.h: only occupied
// cells) or a published segment (core/likelihood_field.h). Stored in 8 × 8 cell tiles allocated
// on a tile's first write, so the grid pays 4 bytes per 64 cells plus 256 bytes per tile holding
// any record (walls touch few tiles), instead of 4 bytes per cell. A tile once allocated stays.
//
// Cells follow the grid convention of core/grid_geometry.h: (x, y) = (column, row) of a
// width × height grid; linear index y * width + x. Every cell holds -1 (no record) until set.
#ifndef HETSLAM_CORE_TILED_INDEX_H_
#define HETSLAM_CORE_TILED_INDEX_H_

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <type_traits>
#include <vector>

#include "glog/logging.h"

namespace hetslam {

// The storage of TiledGrid's tiles: an array of a trivially copyable T that grows at its end,
// by realloc. A large block (one with pages of its own: glibc's mmap threshold, hetslam_run's
// --malloc_mmap_threshold_kib) then has its pages moved to the larger block (mremap), not
// copied into fresh ones: a std::vector's growth copied them and faulted in the new block's
// pages, ~22% of an Intel run's page faults (a growing submap's grids, their tiles moved
// whenever a grid grows). Grows as a std::vector's resize does (to twice the size at least).
template <typename T>
class TileStorage {
  static_assert(std::is_trivially_copyable_v<T>, "moved by realloc");

 public:
  TileStorage() = default;
  TileStorage(const TileStorage& other) { CopyFrom(other); }
  TileStorage(TileStorage&& other) noexcept : data_(other.data_), size_(other.size_), capacity_(other.capacity_) {
    other.data_ = nullptr;
    other.size_ = other.capacity_ = 0;
  }
  TileStorage& operator=(const TileStorage& other) {
    if (this != &other) {
      Free();
      CopyFrom(other);
    }
    return *this;
  }
  TileStorage& operator=(TileStorage&& other) noexcept {
    if (this != &other) {
      Free();
      std::swap(data_, other.data_);
      std::swap(size_, other.size_);
      std::swap(capacity_, other.capacity_);
    }
    return *this;
  }
  ~TileStorage() { std::free(data_); }

  size_t size() const { return size_; }
  size_t capacity() const { return capacity_; }
  T* data() { return data_; }
  const T* data() const { return data_; }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }
  // Appends n copies of `value`.
  void Append(size_t n, T value) {
    if (size_ + n > capacity_) Reallocate(size_ + std::max(size_, n));
    std::fill(data_ + size_, data_ + size_ + n, value);
    size_ += n;
  }
  void ShrinkToFit() {
    if (capacity_ > size_) Reallocate(size_);
  }
  // Empty, the memory released.
  void Free() {
    std::free(data_);
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

 private:
  void CopyFrom(const TileStorage& other) {
    if (other.size_ == 0) return;
    Reallocate(other.size_);
    std::copy(other.data_, other.data_ + other.size_, data_);
    size_ = other.size_;
  }
  void Reallocate(size_t n) {
    if (n == 0) {
      Free();
      return;
    }
    void* p = std::realloc(data_, n * sizeof(T));
    CHECK(p != nullptr) << "out of memory: a grid's tiles of " << n * sizeof(T) << " bytes";
    data_ = static_cast<T*>(p);
    capacity_ = n;
  }

  T* data_ = nullptr;
  size_t size_ = 0;
  size_t capacity_ = 0;
};

// The general form: a width × height grid of T where every cell holds `empty` until written,
// stored in 8 × 8 cell tiles allocated on a tile's first write of a value other than `empty`.
// A tile once allocated stays (until Reset). The likelihood field that is being built keeps
// its values and squared distances so (core/likelihood_field.h: only the cells within the
// window radius of a surface differ from empty, a band along the walls of a box that is
// mostly free or unknown space).
template <typename T>
class TiledGrid {
 public:
  static constexpr int kTileBits = 3;
  static constexpr int kTileSize = 1 << kTileBits;
  static constexpr int kTileCells = kTileSize * kTileSize;

  TiledGrid() = default;
  TiledGrid(int width, int height, T empty) { Reset(width, height, empty); }

  // Every cell of a width × height grid to `empty`; the memory of the old tiles is released.
  void Reset(int width, int height, T empty) {
    CHECK(width >= 0 && height >= 0) << width << " x " << height;
    width_ = width;
    height_ = height;
    empty_ = empty;
    tiles_x_ = (width + kTileSize - 1) >> kTileBits;
    const int tiles_y = (height + kTileSize - 1) >> kTileBits;
    std::vector<int32_t>(static_cast<size_t>(tiles_x_) * tiles_y, -1).swap(tile_of_);
    cells_.Free();
  }

  int width() const { return width_; }
  int height() const { return height_; }
  T empty() const { return empty_; }

  T Get(int x, int y) const {
    const int32_t tile = tile_of_[TileIndex(x, y)];
    return tile < 0 ? empty_ : cells_[Offset(tile, x, y)];
  }
  T GetLinear(int i) const { return Get(i % width_, i / width_); }
  // The cell's entry, its tile allocated (all empty) if it had none.
  T& Ref(int x, int y) {
    int32_t& tile = tile_of_[TileIndex(x, y)];
    if (tile < 0) {
      tile = static_cast<int32_t>(cells_.size() / kTileCells);
      cells_.Append(kTileCells, empty_);
    }
    return cells_[Offset(tile, x, y)];
  }
  T& RefLinear(int i) { return Ref(i % width_, i / width_); }
  // Writes `value`; writing empty() into a tile that has none allocates nothing.
  void Set(int x, int y, T value) {
    if (value == empty_ && tile_of_[TileIndex(x, y)] < 0) return;
    Ref(x, y) = value;
  }
  // The entries of row y of the tile holding (x, y), from x to the tile's right edge (some
  // possibly beyond the grid's); null when that tile has none (all empty).
  const T* TileRow(int x, int y) const {
    const int32_t tile = tile_of_[TileIndex(x, y)];
    return tile < 0 ? nullptr : cells_.data() + Offset(tile, x, y);
  }
  T* MutableTileRow(int x, int y) {
    const int32_t tile = tile_of_[TileIndex(x, y)];
    return tile < 0 ? nullptr : cells_.data() + Offset(tile, x, y);
  }
  // Cells (x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1), all inside the grid, into out[0..3]
  // (one tile lookup when they share a tile: bilinear interpolation's neighbourhood).
  void Get2x2(int x, int y, T* out) const {
    constexpr int kLast = kTileSize - 1;
    if ((x & kLast) == kLast || (y & kLast) == kLast) {
      out[0] = Get(x, y);
      out[1] = Get(x + 1, y);
      out[2] = Get(x, y + 1);
      out[3] = Get(x + 1, y + 1);
      return;
    }
    const int32_t tile = tile_of_[TileIndex(x, y)];
    if (tile < 0) {
      std::fill(out, out + 4, empty_);
      return;
    }
    const T* src = cells_.data() + Offset(tile, x, y);
    out[0] = src[0];
    out[1] = src[1];
    out[2] = src[kTileSize];
    out[3] = src[kTileSize + 1];
  }
  // Cells x0 .. x0 + n - 1 of row y (all inside the grid) into out[0 .. n - 1].
  void GetRow(int x0, int y, int n, T* out) const {
    for (int x = x0; x < x0 + n;) {
      const int end = std::min(x0 + n, (x | (kTileSize - 1)) + 1);
      const T* row = TileRow(x, y);
      if (row == nullptr) {
        std::fill(out + (x - x0), out + (end - x0), empty_);
      } else {
        std::copy(row, row + (end - x), out + (x - x0));
      }
      x = end;
    }
  }
  // Calls f(x, y, value) for every cell holding a value other than empty() (tile by tile).
  template <typename F>
  void ForEach(F f) const {
    const int tiles_y = (height_ + kTileSize - 1) >> kTileBits;
    for (int ty = 0; ty < tiles_y; ++ty) {
      for (int tx = 0; tx < tiles_x_; ++tx) {
        const int32_t tile = tile_of_[static_cast<size_t>(ty) * tiles_x_ + tx];
        if (tile < 0) continue;
        for (int k = 0; k < kTileCells; ++k) {
          const T value = cells_[static_cast<size_t>(tile) * kTileCells + k];
          if (value == empty_) continue;
          const int x = (tx << kTileBits) + (k & (kTileSize - 1)), y = (ty << kTileBits) + (k >> kTileBits);
          if (x < width_ && y < height_) f(x, y, value);
        }
      }
    }
  }
  // Writes every cell holding a value other than empty() into `out`, moved by (dx, dy) (each
  // must land inside `out`): the writes of ForEach with out->Ref(x + dx, y + dy) = value, in
  // the same order, so `out` allocates its tiles in the same order. A tile row's cells are
  // taken a run at a time, each run the cells that land in one destination tile row: one
  // destination lookup and one pass of comparisons and copies a run, not a lookup and a call a
  // cell (the two Resizes of a grid's growth, OccupancyGrid's and LikelihoodField's, were ~6%
  // of an Intel run's first 300 scans, callgrind, with a lookup a cell; ~4.5% with the
  // destination looked up a run of cells at a time through ForEach).
  void MoveInto(int dx, int dy, TiledGrid* out) const {
    constexpr int kLast = kTileSize - 1;
    const int tiles_y = (height_ + kTileSize - 1) >> kTileBits;
    for (int ty = 0; ty < tiles_y; ++ty) {
      for (int tx = 0; tx < tiles_x_; ++tx) {
        const int32_t tile = tile_of_[static_cast<size_t>(ty) * tiles_x_ + tx];
        if (tile < 0) continue;
        const int x0 = tx << kTileBits, y0 = ty << kTileBits;
        // The tile's cells inside the grid (an edge tile's others hold empty(): never written).
        const int columns = std::min(kTileSize, width_ - x0), rows = std::min(kTileSize, height_ - y0);
        for (int k = 0; k < rows; ++k) {
          const T* row = cells_.data() + static_cast<size_t>(tile) * kTileCells + (k << kTileBits);
          const int ny = y0 + k + dy;
          for (int i = 0; i < columns;) {
            const int nx = x0 + i + dx;
            const int run = std::min(columns - i, kTileSize - (nx & kLast));
            // The destination tile is allocated (Ref) at the run's first value other than
            // empty(), as ForEach's writes would; a run of empty() values writes nothing.
            int first = i;
            while (first < i + run && row[first] == empty_) ++first;
            if (first < i + run) {
              T* destination = &out->Ref(nx + (first - i), ny) - (first - i);
              for (int j = first; j < i + run; ++j) {
                if (row[j] != empty_) destination[j - i] = row[j];
              }
            }
            i += run;
          }
        }
      }
    }
  }
  // MoveInto for a grid that is replaced by `out` (this one is left empty, its memory released
  // or handed over): when (dx, dy) moves whole tiles (multiples of kTileSize; (0, 0) when a grid
  // grows at its far sides only) and `out` has no tile yet, `out` takes this grid's tile storage
  // as it is and only the tile index is rebuilt. Every cell then holds what MoveInto would have
  // written (the tiles' order in the storage differs, and an allocated tile that holds only
  // empty() stays allocated). A grid's growth wrote every tile again into new pages, ~13% of an
  // Intel run's page faults (session 37).
  void MoveTilesInto(int dx, int dy, TiledGrid* out) {
    constexpr int kLast = kTileSize - 1;
    if ((dx & kLast) != 0 || (dy & kLast) != 0 || out->cells_.size() != 0 || empty_ != out->empty_) {
      MoveInto(dx, dy, out);
      Reset(0, 0, empty_);
      return;
    }
    const int tiles_y = (height_ + kTileSize - 1) >> kTileBits;
    const int tdx = dx >> kTileBits, tdy = dy >> kTileBits;  // arithmetic shifts: exact for multiples of 8
    for (int ty = 0; ty < tiles_y; ++ty) {
      for (int tx = 0; tx < tiles_x_; ++tx) {
        const int32_t tile = tile_of_[static_cast<size_t>(ty) * tiles_x_ + tx];
        if (tile < 0) continue;
        const int ntx = tx + tdx, nty = ty + tdy;
        CHECK(ntx >= 0 && nty >= 0 && ntx < out->tiles_x_ && static_cast<size_t>(nty) * out->tiles_x_ + ntx < out->tile_of_.size())
            << "tile (" << tx << ", " << ty << ") moved by (" << dx << ", " << dy << ") cells leaves the grid";
        out->tile_of_[static_cast<size_t>(nty) * out->tiles_x_ + ntx] = tile;
      }
    }
    out->cells_ = std::move(cells_);
    Reset(0, 0, empty_);
  }
  // Every cell, row-major (linear index y * width + x): for tests and comparisons.
  std::vector<T> Dense() const {
    std::vector<T> dense(static_cast<size_t>(width_) * height_);
    for (int y = 0; y < height_; ++y) GetRow(0, y, width_, dense.data() + static_cast<size_t>(y) * width_);
    return dense;
  }
  int num_allocated_tiles() const { return static_cast<int>(cells_.size() / kTileCells); }
  // Tiles per row and column; whether tile (tx, ty) is allocated.
  int tiles_x() const { return tiles_x_; }
  int tiles_y() const { return tiles_x_ > 0 ? static_cast<int>(tile_of_.size()) / tiles_x_ : 0; }
  int num_tiles() const { return static_cast<int>(tile_of_.size()); }
  bool TileStored(int tx, int ty) const { return tile_of_[static_cast<size_t>(ty) * tiles_x_ + tx] >= 0; }
  // Drops the slack of the tiles' growth (for a grid that is written no more).
  void ShrinkToFit() { cells_.ShrinkToFit(); }
  // Bytes held (capacity).
  size_t MemoryBytes() const { return tile_of_.capacity() * sizeof(int32_t) + cells_.capacity() * sizeof(T); }

 private:
  size_t TileIndex(int x, int y) const {
    return static_cast<size_t>(y >> kTileBits) * tiles_x_ + (x >> kTileBits);
  }
  static size_t Offset(int32_t tile, int x, int y) {
    return static_cast<size_t>(tile) * kTileCells + ((y & (kTileSize - 1)) << kTileBits) + (x & (kTileSize - 1));
  }

  int width_ = 0;
  int height_ = 0;
  int tiles_x_ = 0;
  T empty_{};
  std::vector<int32_t> tile_of_;  // per tile: its block in cells_, or -1
  TileStorage<T> cells_;          // kTileCells entries per allocated tile
};

// The per-cell index of the header comment: -1 (no record) until set.
class TiledIndex : public TiledGrid<int32_t> {
 public:
  TiledIndex() = default;
  TiledIndex(int width, int height) : TiledGrid<int32_t>(width, height, -1) {}
  void Reset(int width, int height) { TiledGrid<int32_t>::Reset(width, height, -1); }
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_TILED_INDEX_H_
