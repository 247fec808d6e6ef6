// A read-only grid of small values stored in 8 × 8 cell tiles, where a tile whose cells all
// hold the same `empty` value is not stored (a TiledGrid, core/tiled_index.h, made at once from
// a dense array, without the slack of growth): the compact form of a finished submap's cells
// (core/occupancy_grid.h, core/likelihood_field.h Freeze). A submap's box is mostly unknown
// space (behind walls, beyond the rooms it saw) and its likelihood field is 0 away from walls,
// so most tiles are empty.
//
// Cells follow the grid convention of core/grid_geometry.h: (x, y) = (column, row) of a
// width × height grid. Memory: 4 bytes per tile for the index plus 64 values per stored tile.
#ifndef HETSLAM_CORE_SPARSE_TILES_H_
#define HETSLAM_CORE_SPARSE_TILES_H_

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/tiled_index.h"

namespace hetslam {

template <typename T>
class SparseTiles : private TiledGrid<T> {
 public:
  using Tiles = TiledGrid<T>;
  using Tiles::kTileBits;
  using Tiles::kTileCells;
  using Tiles::kTileSize;

  SparseTiles() = default;
  // From `dense`, width × height values in row-major order (linear index y * width + x).
  SparseTiles(const std::vector<T>& dense, int width, int height, T empty) : Tiles(width, height, empty) {
    for (int ty = 0; ty < this->tiles_y(); ++ty) {
      for (int tx = 0; tx < this->tiles_x(); ++tx) {
        const int x0 = tx << kTileBits, y0 = ty << kTileBits;
        const int x1 = std::min(width, x0 + kTileSize), y1 = std::min(height, y0 + kTileSize);
        bool all_empty = true;
        for (int y = y0; y < y1 && all_empty; ++y) {
          for (int x = x0; x < x1; ++x) all_empty = all_empty && dense[static_cast<size_t>(y) * width + x] == empty;
        }
        if (all_empty) continue;
        // The tile allocated once, then its rows copied.
        this->Ref(x0, y0);
        for (int y = y0; y < y1; ++y) {
          std::copy(dense.begin() + static_cast<ptrdiff_t>(y) * width + x0,
                    dense.begin() + static_cast<ptrdiff_t>(y) * width + x1, this->MutableTileRow(x0, y));
        }
      }
    }
    this->ShrinkToFit();
  }

  // The readers of TiledGrid (core/tiled_index.h): Get, TileRow (null: every cell of the tile
  // holds empty()), Get2x2, GetRow; tiles_x, tiles_y, TileStored, num_tiles, MemoryBytes.
  using Tiles::empty;
  using Tiles::Get;
  using Tiles::Get2x2;
  using Tiles::GetRow;
  using Tiles::height;
  using Tiles::MemoryBytes;
  using Tiles::num_tiles;
  using Tiles::TileRow;
  using Tiles::TileStored;
  using Tiles::tiles_x;
  using Tiles::tiles_y;
  using Tiles::width;
  int num_stored_tiles() const { return this->num_allocated_tiles(); }
};

// The same tiling for values of two bits (0..3; a finished submap's cell states, CellState):
// a stored 8 × 8 tile takes 16 bytes, one 16-bit word a tile row, cell x of the row in bits
// 2x and 2x + 1. A quarter of SparseTiles<uint8_t>'s memory for the same tiles.
class SparseTiles2Bit {
 public:
  static constexpr int kTileBits = 3;
  static constexpr int kTileSize = 1 << kTileBits;

  SparseTiles2Bit() = default;
  // From `dense`, width × height values in 0..3 in row-major order; a tile whose cells all hold
  // `empty` is not stored.
  SparseTiles2Bit(const std::vector<uint8_t>& dense, int width, int height, uint8_t empty)
      : width_(width), height_(height), tiles_x_((width + kTileSize - 1) >> kTileBits), empty_(empty & 3) {
    const int tiles_y = (height + kTileSize - 1) >> kTileBits;
    index_.assign(static_cast<size_t>(tiles_x_) * tiles_y, -1);
    // Cells beyond the grid's edge hold `empty`.
    uint16_t empty_row = 0;
    for (int x = 0; x < kTileSize; ++x) empty_row |= static_cast<uint16_t>(empty_ << (2 * x));
    for (int ty = 0; ty < tiles_y; ++ty) {
      for (int tx = 0; tx < tiles_x_; ++tx) {
        const int x0 = tx << kTileBits, y0 = ty << kTileBits;
        const int x1 = std::min(width, x0 + kTileSize), y1 = std::min(height, y0 + kTileSize);
        uint16_t rows[kTileSize];
        bool all_empty = true;
        for (int y = y0; y < y0 + kTileSize; ++y) {
          uint16_t row = empty_row;
          for (int x = x0; y < y1 && x < x1; ++x) {
            const uint8_t v = dense[static_cast<size_t>(y) * width + x] & 3;
            row = static_cast<uint16_t>((row & ~(3u << (2 * (x - x0)))) | (v << (2 * (x - x0))));
          }
          rows[y - y0] = row;
          all_empty = all_empty && row == empty_row;
        }
        if (all_empty) continue;
        index_[static_cast<size_t>(ty) * tiles_x_ + tx] = static_cast<int32_t>(rows_.size() / kTileSize);
        rows_.insert(rows_.end(), rows, rows + kTileSize);
      }
    }
    rows_.shrink_to_fit();
  }

  int width() const { return width_; }
  int height() const { return height_; }
  // The value of cell (x, y), which must be inside the grid.
  uint8_t Get(int x, int y) const {
    const int32_t tile = index_[static_cast<size_t>(y >> kTileBits) * tiles_x_ + (x >> kTileBits)];
    if (tile < 0) return empty_;
    const uint16_t row = rows_[static_cast<size_t>(tile) * kTileSize + (y & (kTileSize - 1))];
    return static_cast<uint8_t>((row >> (2 * (x & (kTileSize - 1)))) & 3u);
  }
  // The cells of row y of the tile holding (x, y), from (x, y) to the tile's right edge
  // (kTileSize - x % kTileSize of them), decoded into `buffer` (room for kTileSize), which is
  // returned; null when the tile is not stored (every cell holds the empty value).
  const uint8_t* TileRow(int x, int y, uint8_t* buffer) const {
    const int32_t tile = index_[static_cast<size_t>(y >> kTileBits) * tiles_x_ + (x >> kTileBits)];
    if (tile < 0) return nullptr;
    const uint16_t row = rows_[static_cast<size_t>(tile) * kTileSize + (y & (kTileSize - 1))];
    for (int k = x & (kTileSize - 1), i = 0; k < kTileSize; ++k, ++i) {
      buffer[i] = static_cast<uint8_t>((row >> (2 * k)) & 3u);
    }
    return buffer;
  }
  // Row y of the tile holding (x, y) as stored (cell x' of the tile in bits 2x' and 2x' + 1,
  // x' = x % kTileSize for (x, y) itself) into `row`; false when the tile is not stored (every
  // cell holds the empty value). TileRow without decoding: for readers that decode as they go.
  bool TileRowBits(int x, int y, uint16_t* row) const {
    const int32_t tile = index_[static_cast<size_t>(y >> kTileBits) * tiles_x_ + (x >> kTileBits)];
    if (tile < 0) return false;
    *row = rows_[static_cast<size_t>(tile) * kTileSize + (y & (kTileSize - 1))];
    return true;
  }
  int num_stored_tiles() const { return static_cast<int>(rows_.size() / kTileSize); }
  // Bytes held (capacity).
  size_t MemoryBytes() const { return index_.capacity() * sizeof(int32_t) + rows_.capacity() * sizeof(uint16_t); }

 private:
  int width_ = 0;
  int height_ = 0;
  int tiles_x_ = 0;
  uint8_t empty_ = 0;
  std::vector<int32_t> index_;  // per tile, row-major: its number among the stored tiles, -1: empty
  std::vector<uint16_t> rows_;  // stored tiles, kTileSize row words each
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_SPARSE_TILES_H_
