// The tiled per-cell index: -1 everywhere until set, tiles allocated only where a cell is set,
// linear and (x, y) access agreeing, every set cell visited by ForEach.
#include "core/tiled_index.h"

#include <map>
#include <random>
#include <tuple>
#include <utility>

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

}  // namespace
}  // namespace hetslam
