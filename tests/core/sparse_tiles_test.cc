#include "core/sparse_tiles.h"

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

// A seeded random grid whose sizes are not multiples of the tile size, with a few non-empty
// blobs: every lookup (Get, Get2x2, GetRow at every start and length) answers as the dense array.
TEST(SparseTilesTest, AnswersLikeTheDenseArray) {
  std::mt19937 rng(7);
  for (const auto& [width, height] : {std::pair{1, 1}, std::pair{8, 8}, std::pair{37, 21}, std::pair{64, 3}}) {
    std::vector<uint16_t> dense(static_cast<size_t>(width) * height, 0);
    std::uniform_int_distribution<int> x_of(0, width - 1), y_of(0, height - 1), value(1, 65535);
    for (int blob = 0; blob < 3; ++blob) {
      const int cx = x_of(rng), cy = y_of(rng);
      for (int y = std::max(0, cy - 2); y <= std::min(height - 1, cy + 2); ++y) {
        for (int x = std::max(0, cx - 2); x <= std::min(width - 1, cx + 2); ++x) {
          dense[static_cast<size_t>(y) * width + x] = static_cast<uint16_t>(value(rng));
        }
      }
    }
    const SparseTiles<uint16_t> tiles(dense, width, height, 0);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        ASSERT_EQ(dense[static_cast<size_t>(y) * width + x], tiles.Get(x, y)) << x << ", " << y;
        if (x + 1 < width && y + 1 < height) {
          uint16_t block[4];
          tiles.Get2x2(x, y, block);
          ASSERT_EQ(dense[static_cast<size_t>(y) * width + x], block[0]);
          ASSERT_EQ(dense[static_cast<size_t>(y) * width + x + 1], block[1]);
          ASSERT_EQ(dense[static_cast<size_t>(y + 1) * width + x], block[2]);
          ASSERT_EQ(dense[static_cast<size_t>(y + 1) * width + x + 1], block[3]);
        }
      }
      for (int x0 = 0; x0 < width; ++x0) {
        for (int n = 1; x0 + n <= width; n += 5) {
          std::vector<uint16_t> row(n, 1);
          tiles.GetRow(x0, y, n, row.data());
          for (int k = 0; k < n; ++k) ASSERT_EQ(dense[static_cast<size_t>(y) * width + x0 + k], row[k]);
        }
      }
    }
  }
}

// Empty tiles cost only their index entry: a 256 x 256 grid with one non-empty cell keeps one tile.
TEST(SparseTilesTest, EmptyTilesAreNotStored) {
  std::vector<uint8_t> dense(256 * 256, 3);
  dense[100 * 256 + 100] = 1;
  const SparseTiles<uint8_t> tiles(dense, 256, 256, 3);
  EXPECT_EQ(1, tiles.num_stored_tiles());
  EXPECT_EQ(32 * 32, tiles.num_tiles());
  EXPECT_EQ(1, tiles.Get(100, 100));
  EXPECT_EQ(3, tiles.Get(101, 100));
  EXPECT_LT(tiles.MemoryBytes(), dense.size() / 10);
}

// The two-bit tiles (a finished submap's cell states) against the dense array on odd sizes:
// every cell through Get and through TileRow from every start, unstored tiles as the empty
// value, and a quarter of the byte tiles' memory.
TEST(SparseTiles2BitTest, AnswersLikeTheDenseArrayInAQuarterOfTheBytes) {
  std::mt19937 rng(11);
  for (const auto& [width, height] : {std::pair{1, 1}, std::pair{8, 8}, std::pair{37, 21}, std::pair{64, 3}}) {
    for (const uint8_t empty : {uint8_t{0}, uint8_t{2}}) {
      std::vector<uint8_t> dense(static_cast<size_t>(width) * height, empty);
      std::uniform_int_distribution<int> x_of(0, width - 1), y_of(0, height - 1), value(0, 3);
      // A block of random states, the rest empty.
      const int cx = x_of(rng), cy = y_of(rng);
      for (int y = cy; y < std::min(height, cy + 6); ++y) {
        for (int x = cx; x < std::min(width, cx + 9); ++x) dense[static_cast<size_t>(y) * width + x] = value(rng);
      }
      const SparseTiles2Bit tiles(dense, width, height, empty);
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
          ASSERT_EQ(dense[static_cast<size_t>(y) * width + x], tiles.Get(x, y)) << x << ", " << y;
          uint8_t buffer[SparseTiles2Bit::kTileSize];
          const uint8_t* row = tiles.TileRow(x, y, buffer);
          const int end = std::min(width, (x | (SparseTiles2Bit::kTileSize - 1)) + 1);
          for (int k = 0; k < end - x; ++k) {
            ASSERT_EQ(dense[static_cast<size_t>(y) * width + x + k], row == nullptr ? empty : row[k])
                << x << ", " << y << " + " << k;
          }
          // The undecoded row: stored exactly where TileRow decodes one; cell x' of the tile
          // in bits 2x' and 2x' + 1.
          uint16_t bits = 0;
          ASSERT_EQ(row != nullptr, tiles.TileRowBits(x, y, &bits)) << x << ", " << y;
          if (row != nullptr) {
            const int first = x & (SparseTiles2Bit::kTileSize - 1);
            for (int k = 0; k < end - x; ++k) {
              ASSERT_EQ(row[k], (bits >> (2 * (first + k))) & 3u) << x << ", " << y << " + " << k;
            }
          }
        }
      }
      const SparseTiles<uint8_t> bytes(dense, width, height, empty);
      EXPECT_EQ(bytes.num_stored_tiles(), tiles.num_stored_tiles());
      if (tiles.num_stored_tiles() > 0) {
        EXPECT_EQ(static_cast<size_t>(tiles.num_stored_tiles()) * 16,
                  tiles.MemoryBytes() - (bytes.MemoryBytes() - static_cast<size_t>(bytes.num_stored_tiles()) * 64));
      }
    }
  }
}

}  // namespace
}  // namespace hetslam
