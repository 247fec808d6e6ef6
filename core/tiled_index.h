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

#include <cstddef>
#include <cstdint>
#include <vector>

#include "glog/logging.h"

namespace hetslam {

class TiledIndex {
 public:
  static constexpr int kTileBits = 3;
  static constexpr int kTileSize = 1 << kTileBits;
  static constexpr int kTileCells = kTileSize * kTileSize;

  TiledIndex() = default;
  TiledIndex(int width, int height) { Reset(width, height); }

  // Every cell of a width × height grid to -1; the memory of the old tiles is released.
  void Reset(int width, int height) {
    CHECK(width >= 0 && height >= 0) << width << " x " << height;
    width_ = width;
    height_ = height;
    tiles_x_ = (width + kTileSize - 1) >> kTileBits;
    const int tiles_y = (height + kTileSize - 1) >> kTileBits;
    std::vector<int32_t>(static_cast<size_t>(tiles_x_) * tiles_y, -1).swap(tile_of_);
    std::vector<int32_t>().swap(cells_);
  }

  int width() const { return width_; }
  int height() const { return height_; }

  int32_t Get(int x, int y) const {
    const int32_t tile = tile_of_[TileIndex(x, y)];
    return tile < 0 ? -1 : cells_[Offset(tile, x, y)];
  }
  int32_t GetLinear(int i) const { return Get(i % width_, i / width_); }
  // The cell's entry, its tile allocated (all -1) if it had none.
  int32_t& Ref(int x, int y) {
    int32_t& tile = tile_of_[TileIndex(x, y)];
    if (tile < 0) {
      tile = static_cast<int32_t>(cells_.size() / kTileCells);
      cells_.resize(cells_.size() + kTileCells, -1);
    }
    return cells_[Offset(tile, x, y)];
  }
  int32_t& RefLinear(int i) { return Ref(i % width_, i / width_); }
  // The entries of row y of the tile holding (x, y), from x to the tile's right edge (some
  // possibly beyond the grid's); null when that tile has none (all -1).
  const int32_t* TileRow(int x, int y) const {
    const int32_t tile = tile_of_[TileIndex(x, y)];
    return tile < 0 ? nullptr : cells_.data() + Offset(tile, x, y);
  }
  // Calls f(x, y, value) for every cell holding a value >= 0 (tile by tile).
  template <typename F>
  void ForEach(F f) const {
    const int tiles_y = (height_ + kTileSize - 1) >> kTileBits;
    for (int ty = 0; ty < tiles_y; ++ty) {
      for (int tx = 0; tx < tiles_x_; ++tx) {
        const int32_t tile = tile_of_[static_cast<size_t>(ty) * tiles_x_ + tx];
        if (tile < 0) continue;
        for (int k = 0; k < kTileCells; ++k) {
          const int32_t value = cells_[static_cast<size_t>(tile) * kTileCells + k];
          if (value < 0) continue;
          const int x = (tx << kTileBits) + (k & (kTileSize - 1)), y = (ty << kTileBits) + (k >> kTileBits);
          if (x < width_ && y < height_) f(x, y, value);
        }
      }
    }
  }
  // Bytes held (capacity).
  size_t MemoryBytes() const { return (tile_of_.capacity() + cells_.capacity()) * sizeof(int32_t); }

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
  std::vector<int32_t> tile_of_;  // per tile: its block in cells_, or -1
  std::vector<int32_t> cells_;    // kTileCells entries per allocated tile
};

}  // namespace hetslam

#endif  // HETSLAM_CORE_TILED_INDEX_H_
