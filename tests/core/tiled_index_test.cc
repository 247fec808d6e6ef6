// The tiled per-cell index: -1 everywhere until set, tiles allocated only where a cell is set,
// linear and (x, y) access agreeing, every set cell visited by ForEach. The general TiledGrid
// (the likelihood field's values and the log-odds of maps being built): rows, 2 x 2
// neighbourhoods and the dense copy agree with a dense reference; writing the empty value
// allocates nothing.
#include "core/tiled_index.h"

#include <limits>
#include <map>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

TEST(TiledIndexTest, HoldsWhatWasSetAndMinusOneElsewhereOnAnOddSizedGrid) {
  TiledIndex index(37, 21);  // tiles over the right and top edges are partial
  EXPECT_EQ(-1, index.Get(0, 0));
  EXPECT_EQ(-1, index.Get(36, 20));
  const size_t empty_bytes = index.MemoryBytes();
  std::mt19937 rng(3);
  std::map<std::pair<int, int>, int32_t> expected;
  for (int k = 0; k < 200; ++k) {
    const int x = static_cast<int>(rng() % 37), y = static_cast<int>(rng() % 21);
    const int32_t value = static_cast<int32_t>(rng() % 1000);
    if (k % 2 == 0) {
      index.Ref(x, y) = value;
    } else {
      index.RefLinear(y * 37 + x) = value;
    }
    expected[{x, y}] = value;
  }
  for (int y = 0; y < 21; ++y) {
    for (int x = 0; x < 37; ++x) {
      const auto it = expected.find({x, y});
      const int32_t want = it == expected.end() ? -1 : it->second;
      ASSERT_EQ(want, index.Get(x, y)) << x << ", " << y;
      ASSERT_EQ(want, index.GetLinear(y * 37 + x));
      const int32_t* row = index.TileRow(x, y);
      if (row != nullptr) {
        ASSERT_EQ(want, row[0]);
      } else {
        ASSERT_EQ(-1, want);
      }
    }
  }
  std::map<std::pair<int, int>, int32_t> visited;
  index.ForEach([&](int x, int y, int32_t value) { visited[{x, y}] = value; });
  EXPECT_EQ(expected, visited);
  EXPECT_GT(index.MemoryBytes(), empty_bytes);
}

TEST(TiledIndexTest, OneCellAllocatesOneTileAndResetForgetsEverything) {
  TiledIndex index(1000, 1000);
  const size_t empty_bytes = index.MemoryBytes();
  EXPECT_LE(empty_bytes, 1000u * 1000u / 16u + 64u);  // 4 bytes per 64 cells
  index.Ref(500, 500) = 7;
  EXPECT_EQ(empty_bytes + TiledIndex::kTileCells * sizeof(int32_t), index.MemoryBytes());
  index.Ref(501, 501) = 8;  // same tile
  EXPECT_EQ(empty_bytes + TiledIndex::kTileCells * sizeof(int32_t), index.MemoryBytes());
  EXPECT_EQ(nullptr, index.TileRow(0, 0));
  index.Reset(10, 10);
  EXPECT_EQ(-1, index.Get(5, 5));
  int count = 0;
  index.ForEach([&](int, int, int32_t) { ++count; });
  EXPECT_EQ(0, count);
}

// A TiledGrid<float> with +inf as its empty value against a dense reference: random writes
// (some of them the empty value) on an odd-sized grid, then every reader.
TEST(TiledGridTest, ReadersAgreeWithADenseReferenceAndEmptyWritesAllocateNothing) {
  constexpr float kEmpty = std::numeric_limits<float>::infinity();
  const int width = 29, height = 19;  // partial tiles on the right and top edges
  TiledGrid<float> grid(width, height, kEmpty);
  std::vector<float> dense(static_cast<size_t>(width) * height, kEmpty);
  grid.Set(3, 3, kEmpty);
  EXPECT_EQ(0, grid.num_allocated_tiles());
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> x_of(0, width - 1), y_of(0, height - 1);
  std::uniform_real_distribution<float> value_of(-1.f, 1.f);
  for (int k = 0; k < 60; ++k) {
    const int x = x_of(rng), y = y_of(rng);
    const float v = k % 5 == 0 ? kEmpty : value_of(rng);
    grid.Set(x, y, v);
    dense[static_cast<size_t>(y) * width + x] = v;
  }
  EXPECT_EQ(dense, grid.Dense());
  for (int y = 0; y < height; ++y) {
    std::vector<float> row(width - 2);
    grid.GetRow(1, y, width - 2, row.data());
    for (int x = 1; x + 1 < width; ++x) {
      ASSERT_EQ(dense[static_cast<size_t>(y) * width + x], row[x - 1]) << x << ", " << y;
      ASSERT_EQ(dense[static_cast<size_t>(y) * width + x], grid.GetLinear(y * width + x));
      if (y + 1 < height) {
        float v[4];
        grid.Get2x2(x, y, v);
        EXPECT_EQ(dense[static_cast<size_t>(y) * width + x], v[0]);
        EXPECT_EQ(dense[static_cast<size_t>(y) * width + x + 1], v[1]);
        EXPECT_EQ(dense[static_cast<size_t>(y + 1) * width + x], v[2]);
        EXPECT_EQ(dense[static_cast<size_t>(y + 1) * width + x + 1], v[3]);
      }
    }
  }
  int visited = 0;
  grid.ForEach([&](int x, int y, float v) {
    EXPECT_EQ(dense[static_cast<size_t>(y) * width + x], v);
    EXPECT_NE(kEmpty, v);
    ++visited;
  });
  int expected = 0;
  for (float v : dense) expected += v != kEmpty;
  EXPECT_EQ(expected, visited);
  // A tile that was never written reads as empty through every reader.
  TiledGrid<float> far(1000, 1000, kEmpty);
  far.Set(999, 999, 2.f);
  EXPECT_EQ(1, far.num_allocated_tiles());
  EXPECT_EQ(nullptr, far.TileRow(0, 0));
  EXPECT_EQ(kEmpty, far.Get(500, 500));
  EXPECT_EQ(2.f, far.Get(999, 999));
}

TEST(TiledGridTest, MoveIntoWritesWhatRefCellByCellWouldInTheSameTileOrder) {
  constexpr float kEmpty = 0.f;
  const int width = 29, height = 19;  // partial tiles on the right and top edges
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> x_of(0, width - 1), y_of(0, height - 1);
  std::uniform_real_distribution<float> value_of(0.5f, 1.f);
  TiledGrid<float> grid(width, height, kEmpty);
  for (int k = 0; k < 120; ++k) grid.Set(x_of(rng), y_of(rng), k % 7 == 0 ? kEmpty : value_of(rng));
  // Shifts within a tile, across tile edges and by whole tiles, into grids with room to spare.
  for (const auto& [dx, dy] : std::vector<std::pair<int, int>>{{0, 0}, {1, 0}, {0, 5}, {7, 3}, {8, 8}, {13, 21}, {40, 9}}) {
    TiledGrid<float> expected(width + dx + 9, height + dy + 4, kEmpty);
    std::vector<std::pair<int, int>> expected_first_writes;  // tiles in the order Ref allocates them
    grid.ForEach([&](int x, int y, float v) {
      if (!expected.TileStored((x + dx) >> 3, (y + dy) >> 3)) expected_first_writes.push_back({(x + dx) >> 3, (y + dy) >> 3});
      expected.Ref(x + dx, y + dy) = v;
    });
    TiledGrid<float> moved(width + dx + 9, height + dy + 4, kEmpty);
    grid.MoveInto(dx, dy, &moved);
    EXPECT_EQ(expected.Dense(), moved.Dense()) << dx << ", " << dy;
    ASSERT_EQ(expected.num_allocated_tiles(), moved.num_allocated_tiles()) << dx << ", " << dy;
    // The same allocation order: the k-th tile allocated holds the same cells in both (a
    // tile's row read through TileRow points into its block; blocks are in allocation order).
    const float* expected_base = expected.TileRow(expected_first_writes[0].first << 3, expected_first_writes[0].second << 3);
    const float* moved_base = moved.TileRow(expected_first_writes[0].first << 3, expected_first_writes[0].second << 3);
    for (const auto& [tx, ty] : expected_first_writes) {
      EXPECT_EQ(expected.TileRow(tx << 3, ty << 3) - expected_base, moved.TileRow(tx << 3, ty << 3) - moved_base)
          << "tile " << tx << ", " << ty << " moved by " << dx << ", " << dy;
    }
  }
}

// A grid replaced by the moved one: whole-tile shifts hand the tile storage over (no cell is
// written again), any other shift falls back to MoveInto; either way every cell holds what
// MoveInto writes, and the source is left empty.
TEST(TiledGridTest, MoveTilesIntoHoldsWhatMoveIntoWritesAndEmptiesTheSource) {
  constexpr float kEmpty = -1.f;
  const int width = 29, height = 19;
  std::mt19937 rng(12);
  std::uniform_int_distribution<int> x_of(0, width - 1), y_of(0, height - 1);
  std::uniform_real_distribution<float> value_of(0.5f, 1.f);
  TiledGrid<float> grid(width, height, kEmpty);
  for (int k = 0; k < 120; ++k) grid.Set(x_of(rng), y_of(rng), value_of(rng));
  for (const auto& [dx, dy] : std::vector<std::pair<int, int>>{{0, 0}, {8, 0}, {0, 16}, {24, 8}, {1, 0}, {7, 3}, {13, 21}}) {
    TiledGrid<float> expected(width + dx + 9, height + dy + 4, kEmpty);
    grid.MoveInto(dx, dy, &expected);
    TiledGrid<float> source = grid;
    const float* storage = source.TileRow(0, 0) != nullptr ? source.TileRow(0, 0) : nullptr;
    TiledGrid<float> moved(width + dx + 9, height + dy + 4, kEmpty);
    source.MoveTilesInto(dx, dy, &moved);
    EXPECT_EQ(expected.Dense(), moved.Dense()) << dx << ", " << dy;
    EXPECT_EQ(0, source.num_allocated_tiles());
    EXPECT_EQ(0u, source.MemoryBytes());
    const bool whole_tiles = dx % 8 == 0 && dy % 8 == 0;
    if (whole_tiles && storage != nullptr) {
      EXPECT_EQ(storage, moved.TileRow(dx, dy)) << "whole tiles: the storage handed over, " << dx << ", " << dy;
    }
    if (whole_tiles) EXPECT_EQ(grid.num_allocated_tiles(), moved.num_allocated_tiles());
    // The moved grid grows on as any other.
    moved.Set(width + dx + 8, height + dy + 3, 0.25f);
    EXPECT_EQ(0.25f, moved.Get(width + dx + 8, height + dy + 3));
    EXPECT_EQ(expected.Get(dx, dy), moved.Get(dx, dy));
  }
}

// The tile storage grows by realloc: the values written stay, copies are deep.
TEST(TileStorageTest, AppendsKeepsWhatWasWrittenAndCopiesDeeply) {
  TileStorage<int32_t> storage;
  EXPECT_EQ(0u, storage.size());
  for (int i = 0; i < 1000; ++i) {
    storage.Append(64, -1);
    storage[static_cast<size_t>(i) * 64] = i;
  }
  ASSERT_EQ(64000u, storage.size());
  EXPECT_GE(storage.capacity(), storage.size());
  TileStorage<int32_t> copy = storage;
  storage[0] = 77;
  for (int i = 0; i < 1000; ++i) {
    EXPECT_EQ(i, copy[static_cast<size_t>(i) * 64]);
    EXPECT_EQ(-1, copy[static_cast<size_t>(i) * 64 + 63]);
  }
  EXPECT_EQ(77, storage[0]);
  copy.ShrinkToFit();
  EXPECT_EQ(copy.size(), copy.capacity());
  TileStorage<int32_t> moved = std::move(copy);
  EXPECT_EQ(0u, copy.size());  // NOLINT(bugprone-use-after-move): the moved-from state is empty
  EXPECT_EQ(999, moved[999 * 64]);
  moved.Free();
  EXPECT_EQ(0u, moved.capacity());
}

}  // namespace
}  // namespace hetslam
