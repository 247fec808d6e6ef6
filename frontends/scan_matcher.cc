#include "frontends/scan_matcher.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif
#ifdef __unix__
#include <sys/mman.h>  // madvise
#include <unistd.h>    // sysconf
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <tuple>
#include <type_traits>

#include "ceres/ceres.h"
#include "core/process_memory.h"
#include "core/vector4.h"
#include "factors/compressed_cost.h"
#include "factors/scan_cost.h"
#include "factors/se2_manifold.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

// One discrete candidate: yaw index and cell offset of its block's minimum corner.
struct Candidate {
  int yaw_index;
  int dx;
  int dy;
  float score;
};

// The scan rotated by every yaw of the search, as absolute cells of the field at zero
// translation offset, and the box of cells any candidate can touch. Points that no candidate
// can bring near the map's non-zero cells (observed cells plus the likelihood window) are
// left out: they would score 0 everywhere. They still count in the mean (inv_weight_sum is
// over all points), so scores are unchanged while the region shrinks to the map's extent.
struct DiscretizedSearch {
  std::vector<double> yaws;
  std::vector<double> yaw_offsets;  // yaw - predicted yaw
  // The kept points' cells as linear indices into the region's tables (row-major,
  // region_width wide), every yaw's after the previous one's: yaw k's are
  // [begin[k], begin[k + 1]). A candidate offset (dx, dy) adds dy * region_width + dx.
  std::vector<int32_t> offsets;
  std::vector<float> cell_weights;  // one per offset; empty without weights
  std::vector<int> begin;           // yaws.size() + 1 entries
  int window_cells = 0;
  CellIndex region_min{0, 0};
  int region_width = 0;
  int region_height = 0;
};

// Hot loops compiled twice, for AVX2 (twice the lanes) and for any x86-64 CPU, the loader
// picking one when the program starts. Integer loops give the same integers either way, and
// floating-point ones the same doubles (no -ffast-math; AVX2 does not bring FMA contraction).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__ELF__)
#define HETSLAM_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define HETSLAM_CLONES
#endif

// floor(v) for |v| < 2^31, without a libm call (std::floor is one unless the target has
// SSE4.1): truncation, one less for a negative non-integer. The same integer as
// static_cast<int>(std::floor(v)).
inline int FloorToInt(double v) {
  const int i = static_cast<int>(v);
  return i - (v < i);
}

// The cells of n points placed by the rotation (cos_yaw, sin_yaw) and translation (tx, ty) in
// a grid of cells r wide from (ox, oy): world_T_robot * p with the cosine and sine taken once,
// and GridGeometry::WorldToCell inline (the same arithmetic: the same cells).
HETSLAM_CLONES void CellsOfPoints(const Eigen::Vector2f* points, size_t n, double cos_yaw, double sin_yaw, double tx,
                                  double ty, double ox, double oy, double r, CellIndex* cells) {
  for (size_t i = 0; i < n; ++i) {
    const double px = points[i].x(), py = points[i].y();
    cells[i] = {FloorToInt((tx + cos_yaw * px - sin_yaw * py - ox) / r),
                FloorToInt((ty + sin_yaw * px + cos_yaw * py - oy) / r)};
  }
}

// Empties `v` with room for n elements; one too small is freed before the larger one is
// allocated (never both at once, as reserve() would hold them).
template <typename T>
void ClearWithRoomFor(size_t n, std::vector<T>* v) {
  v->clear();
  if (v->capacity() >= n) return;
  *v = std::vector<T>();
  v->reserve(n);
}

// Into `search` and the scratch `cells`, whose buffers are kept (the thread's: see Pyramid).
void Discretize(const ScanMatcherOptions& options, const LaserMap& map, const Pose2& predicted,
                const std::vector<Eigen::Vector2f>& points, const std::vector<float>& weights, int block_cells,
                DiscretizedSearch* search_ptr, std::vector<CellIndex>* cells_ptr) {
  DiscretizedSearch& search = *search_ptr;
  search.yaws.clear();
  search.yaw_offsets.clear();
  search.begin.clear();
  const GridGeometry& geometry = map.field().geometry();
  const double r = geometry.resolution_meters();
  double step = options.angular_step_radians;
  if (step <= 0.0) {
    std::vector<float> ranges;
    for (const auto& p : points) ranges.push_back(p.norm());
    std::nth_element(ranges.begin(), ranges.begin() + ranges.size() * 9 / 10, ranges.end());
    const double d = std::max<double>(ranges[ranges.size() * 9 / 10], r);
    // A yaw step that moves a point at range d by one cell (law of cosines).
    step = std::acos(std::clamp(1.0 - r * r / (2.0 * d * d), -1.0, 1.0));
    step = std::clamp(step, options.min_angular_step_radians, options.max_angular_step_radians);
  }
  const int num_steps = static_cast<int>(std::ceil(options.angular_search_window_radians / step));
  search.window_cells = static_cast<int>(std::ceil(options.linear_search_window_meters / r));
  const int w = search.window_cells;
  // Box of cells that can hold a non-zero table value, grown by the window.
  const int reach = map.field().window_radius_cells() + w + 1;
  CellIndex keep_min = map.grid().observed_min(), keep_max = map.grid().observed_max();
  keep_min = {keep_min.x - reach, keep_min.y - reach};
  keep_max = {keep_max.x + reach, keep_max.y + reach};
  CellIndex lo{INT32_MAX, INT32_MAX}, hi{INT32_MIN, INT32_MIN};
  // One pass over yaws and points collects the kept cells (and the region's box); then they
  // become linear indices into the region.
  const size_t num_yaws = static_cast<size_t>(2 * num_steps + 1);
  search.yaws.reserve(num_yaws);
  search.yaw_offsets.reserve(num_yaws);
  search.begin.reserve(num_yaws + 1);
  std::vector<CellIndex>& cells = *cells_ptr;
  ClearWithRoomFor(num_yaws * points.size(), &cells);
  ClearWithRoomFor(weights.empty() ? 0 : num_yaws * points.size(), &search.cell_weights);
  const double ox = geometry.origin().x(), oy = geometry.origin().y();
  const size_t n = points.size();
  for (int k = -num_steps; k <= num_steps; ++k) {
    const double yaw = predicted.theta() + k * step;
    const Pose2 world_T_robot(predicted.translation(), yaw);
    const double cos_yaw = std::cos(world_T_robot.theta()), sin_yaw = std::sin(world_T_robot.theta());
    const double tx = world_T_robot.x(), ty = world_T_robot.y();
    search.begin.push_back(static_cast<int>(cells.size()));
    // Every point's cell after the kept ones so far (within the capacity reserved above), then
    // the kept ones moved up behind them.
    const size_t first = cells.size();
    cells.resize(first + n);
    CellsOfPoints(points.data(), n, cos_yaw, sin_yaw, tx, ty, ox, oy, r, cells.data() + first);
    // Usually every cell is kept: then the box of this yaw's cells is all the loop below would
    // find (one pass of minima and maxima, which vectorises, instead of a branch a cell).
    CellIndex yaw_lo{INT32_MAX, INT32_MAX}, yaw_hi{INT32_MIN, INT32_MIN};
    for (size_t i = first; i < first + n; ++i) {
      yaw_lo = {std::min(yaw_lo.x, cells[i].x), std::min(yaw_lo.y, cells[i].y)};
      yaw_hi = {std::max(yaw_hi.x, cells[i].x), std::max(yaw_hi.y, cells[i].y)};
    }
    if (n > 0 && yaw_lo.x >= keep_min.x && yaw_lo.y >= keep_min.y && yaw_hi.x <= keep_max.x &&
        yaw_hi.y <= keep_max.y) {
      if (!weights.empty()) search.cell_weights.insert(search.cell_weights.end(), weights.begin(), weights.end());
      lo = {std::min(lo.x, yaw_lo.x), std::min(lo.y, yaw_lo.y)};
      hi = {std::max(hi.x, yaw_hi.x), std::max(hi.y, yaw_hi.y)};
    } else {
      size_t kept = first;
      for (size_t i = 0; i < n; ++i) {
        const CellIndex c = cells[first + i];
        if (c.x < keep_min.x || c.y < keep_min.y || c.x > keep_max.x || c.y > keep_max.y) continue;
        cells[kept++] = c;
        if (!weights.empty()) search.cell_weights.push_back(weights[i]);
        lo = {std::min(lo.x, c.x), std::min(lo.y, c.y)};
        hi = {std::max(hi.x, c.x), std::max(hi.y, c.y)};
      }
      cells.resize(kept);
    }
    search.yaws.push_back(yaw);
    search.yaw_offsets.push_back(k * step);
  }
  search.begin.push_back(static_cast<int>(cells.size()));
  if (lo.x == INT32_MAX) lo = hi = keep_min;  // no point can reach the map: all scores 0
  search.region_min = {lo.x - w, lo.y - w};
  search.region_width = hi.x - lo.x + 2 * w + block_cells + 1;
  search.region_height = hi.y - lo.y + 2 * w + block_cells + 1;
  ClearWithRoomFor(cells.size(), &search.offsets);
  search.offsets.resize(cells.size());
  for (size_t i = 0; i < cells.size(); ++i) {
    search.offsets[i] = (cells[i].y - search.region_min.y) * search.region_width + (cells[i].x - search.region_min.x);
  }
}

// The branch-and-bound tables over the search region. Level 0 is the field (and the
// free-space penalty, and the wall channel) in 16-bit codes rounded to the nearest: code q
// stands for lowest + q * step over the range every such value can take (BuildPyramid: a step
// is (1 + penalty + |wall_weight - 1|) / 65535, ~2e-5 with the defaults), so a leaf's score is
// within half a step of the exact mean, summed in integers. Level
// h >= 1 holds, for each cell c, the max of level 0 over the 2^h × 2^h block whose minimum corner
// is c (cells outside the field are 0), so a block's score is an upper bound of its members'.
// Level 1 in 16 bits too; levels 2 and up in 8 bits (the 16-bit max rounded up to a multiple of
// 257 steps, ~1e-2): 8-bit codes on level 1 too made Intel's loop search 1.5x slower (the looser
// bounds pruned fewer blocks next to the best leaf), on levels >= 2 they cost no measurable
// time and save a byte a cell a level. Leaves as floats (4 bytes; until session 21) made FR079's
// front-end tables 1 MB and ACES's wide loop search's ~4 MB larger: the tables of a loop search
// (depth 5) take 2 + 2 + 4 = 8 bytes a cell of its region.
//
// A table's cells are written (NeededSpans) before a search reads them, so its buffer is never
// initialised. (The coarse levels' cells near a band's far edge may be computed from cells no
// span wrote, see NeededSpans: no search reads those. With every new buffer filled with a
// poison byte, the real logs' and scenarios' outputs were byte-identical.) A buffer that must
// grow is allocated anew (the old one freed first, its contents not copied), at least at the
// largest size it has had: the tables are released before every solve (OnlineEstimator::Solve)
// and after a wide loop search that grew them (LoopCloser::WideSearch), and the next searches'
// windows grew them back step by step, each step a new buffer faulted in again (ACES: ~160
// allocations of each level in 440 scans). Unwritten cells cost no memory: a large buffer has
// pages of its own (hetslam_run's --malloc_mmap_threshold_kib), resident only where a search has
// written; a table of w × h cells is written in its first w × h cells.
template <typename T>
class TableBuffer {
 public:
  // At least n cells, their values unspecified; the old contents are not kept when it grows.
  void Reserve(size_t n) {
    used_ = std::max(used_, n);
    recent_ = std::max(recent_, n);
    if (n <= capacity_) return;
    n = std::max({n, regrow_, capacity_ + capacity_ / 2});
    cells_.reset();          // freed before the larger one is allocated: never two at once
    cells_.reset(new T[n]);  // default-initialised: not written
    capacity_ = n;
  }
  // Gives the pages beyond the most cells asked for since the last Trim back to the system;
  // the cells before them stay resident (their values are not needed either: every search
  // writes what it reads). Without madvise: Release.
  void Trim() {
#ifdef __unix__
    if (cells_ != nullptr && used_ > recent_) {
      const uintptr_t page = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
      const uintptr_t begin = (reinterpret_cast<uintptr_t>(cells_.get() + recent_) + page - 1) / page * page;
      const uintptr_t end = reinterpret_cast<uintptr_t>(cells_.get() + capacity_) / page * page;
      // (A failure leaves the pages resident, as a kept buffer's are.)
      if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_DONTNEED);
      used_ = recent_;
    }
    recent_ = 0;
#else
    Release();
#endif
  }
  // Frees the cells; the next Reserve allocates at least as many as were ever held.
  void Release() {
    regrow_ = std::max(regrow_, capacity_);
    cells_.reset();
    capacity_ = used_ = recent_ = 0;
  }
  T* data() { return cells_.get(); }
  const T* data() const { return cells_.get(); }
  // The most cells asked for since the buffer was allocated: a bound of what searches wrote.
  size_t used() const { return used_; }

 private:
  std::unique_ptr<T[]> cells_;
  size_t capacity_ = 0;
  size_t used_ = 0;
  size_t recent_ = 0;  // the most cells asked for since the last Trim
  size_t regrow_ = 0;
};

struct Pyramid {
  static constexpr int kLevels16 = 1;  // levels 1 .. kLevels16 in 16 bits, coarser ones in 8
  TableBuffer<uint16_t> finest;
  std::vector<TableBuffer<uint16_t>> coarse;  // coarse[h - 1]: level h <= kLevels16
  std::vector<TableBuffer<uint8_t>> coarse8;  // coarse8[h - kLevels16 - 1]: level h > kLevels16
  std::vector<float> row;                     // with a wall channel: a span's summed values
  float lowest = 0.f;
  float step = 1.f;  // of the 16-bit codes; an 8-bit code q stands for lowest + q * 257 step
  // The tables are filled only where a search reads them (NeededSpans): spans[row_spans[r] ..
  // row_spans[r + 1]) are the [begin, end) column ranges of the kTile rows of band r.
  static constexpr int kTile = 8;
  std::vector<std::array<int, 2>> spans;
  std::vector<int> row_spans;
  std::vector<uint8_t> needed;  // one flag a tile; scratch of NeededSpans
  // The search's cell lists, kept like the tables: allocated anew for every search, those of
  // 256 KiB and more had pages of their own, faulted in on every scan (ACES: 17% of the run's
  // page faults were the front end's). (The top-level candidates are not kept: a wide search's
  // are MBs, and kept they raised ACES's peak by 0.5 MiB.)
  DiscretizedSearch search;
  std::vector<CellIndex> cells;  // scratch of Discretize: the cells of search.offsets, absolute
  // What the tables may hold resident (the levels' cells asked for, the scratch vectors).
  size_t Bytes() const {
    size_t bytes = finest.used() * sizeof(uint16_t) + row.capacity() * sizeof(float) +
                   spans.capacity() * sizeof(spans[0]) + row_spans.capacity() * sizeof(int) + needed.capacity() +
                   search.yaws.capacity() * sizeof(double) + search.yaw_offsets.capacity() * sizeof(double) +
                   search.offsets.capacity() * sizeof(int32_t) + search.cell_weights.capacity() * sizeof(float) +
                   search.begin.capacity() * sizeof(int) + cells.capacity() * sizeof(CellIndex);
    for (const TableBuffer<uint16_t>& level : coarse) bytes += level.used() * sizeof(uint16_t);
    for (const TableBuffer<uint8_t>& level : coarse8) bytes += level.used();
    return bytes;
  }
  // Keeps resident each table's pages up to the largest the searches since the last Trim asked
  // for (TableBuffer::Trim) and frees the rest, the scratch vectors included.
  void Trim() {
    finest.Trim();
    for (TableBuffer<uint16_t>& level : coarse) level.Trim();
    for (TableBuffer<uint8_t>& level : coarse8) level.Trim();
    ReleaseVectors();
  }
  // Frees every buffer (see TableBuffer::Release).
  void Release() {
    finest.Release();
    for (TableBuffer<uint16_t>& level : coarse) level.Release();
    for (TableBuffer<uint8_t>& level : coarse8) level.Release();
    ReleaseVectors();
  }
  void ReleaseVectors() {
    row = std::vector<float>();  // (not `= {}`: that keeps the capacity)
    spans = std::vector<std::array<int, 2>>();
    row_spans = std::vector<int>();
    needed = std::vector<uint8_t>();
    search = DiscretizedSearch();
    cells = std::vector<CellIndex>();
  }
};

// Which cells of the region a search of `s` with blocks of `block` cells reads, in tiles of
// Pyramid::kTile cells: a candidate (dx, dy), |dx|, |dy| <= window, reads a point's cell moved by
// (dx, dy) on its level, and a level-h cell is the max of level 0 over the 2^h x 2^h cells from
// it, so level 0 is read from a point's cell - window to + window + block - 1 and every level
// within that. Filling the tables only there (a band along the scan's outline, moved by the
// window) gives every value a search reads the value it has in tables of the whole region, in
// 54% (narrow front-end windows) to 92% (wide loop searches) of the region on Intel, 67% of all
// its searches' cells. A level-h cell near a band's far edge may be computed from stale cells
// of its neighbours: no search reads it.
void NeededSpans(const DiscretizedSearch& s, int block, Pyramid* pyramid) {
  constexpr int kTile = Pyramid::kTile;
  const int w = s.region_width, h = s.region_height;
  const int tiles_x = (w + kTile - 1) / kTile, tiles_y = (h + kTile - 1) / kTile;
  std::vector<uint8_t>& needed = pyramid->needed;
  needed.assign(static_cast<size_t>(tiles_x) * tiles_y, 0);
  // The points' cells (Discretize's, one per offset: a division by w per offset was 1% of an
  // Intel run).
  CHECK_EQ(pyramid->cells.size(), s.offsets.size()) << "the search's cells are not its offsets'";
  static_assert(kTile == 8, "tiles of 8 cells: a shift");
  for (const CellIndex& cell : pyramid->cells) {
    // (Inside the region: non-negative, so shifts, not the divisions' sign corrections.)
    const unsigned x = static_cast<unsigned>(cell.x - s.region_min.x), y = static_cast<unsigned>(cell.y - s.region_min.y);
    needed[static_cast<size_t>(y >> 3) * tiles_x + (x >> 3)] = 1;
  }
  // A point anywhere in tile t needs the tiles from t - before to t + after.
  const int window = s.window_cells;
  const int before = (window + kTile - 1) / kTile, after = (kTile - 1 + window + block - 1) / kTile;
  // Dilation along x, then along y (in place, with a running count of marked tiles in reach).
  std::vector<uint8_t> line(static_cast<size_t>(std::max(tiles_x, tiles_y)));
  auto dilate = [&](uint8_t* first, int count, int stride) {
    for (int i = 0; i < count; ++i) line[i] = first[static_cast<size_t>(i) * stride];
    int marked = 0;  // marked tiles in [i - after, i + before]
    for (int i = 0; i < std::min(count, before); ++i) marked += line[i];
    for (int i = 0; i < count; ++i) {
      if (i + before < count) marked += line[i + before];
      if (i - after - 1 >= 0) marked -= line[i - after - 1];
      first[static_cast<size_t>(i) * stride] = marked > 0;
    }
  };
  for (int ty = 0; ty < tiles_y; ++ty) dilate(needed.data() + static_cast<size_t>(ty) * tiles_x, tiles_x, 1);
  for (int tx = 0; tx < tiles_x; ++tx) dilate(needed.data() + tx, tiles_y, tiles_x);
  pyramid->spans.clear();
  pyramid->row_spans.clear();
  for (int ty = 0; ty < tiles_y; ++ty) {
    pyramid->row_spans.push_back(static_cast<int>(pyramid->spans.size()));
    const uint8_t* row = needed.data() + static_cast<size_t>(ty) * tiles_x;
    for (int tx = 0; tx < tiles_x;) {
      if (!row[tx]) {
        ++tx;
        continue;
      }
      const int first = tx;
      while (tx < tiles_x && row[tx]) ++tx;
      pyramid->spans.push_back({first * kTile, std::min(w, tx * kTile)});
    }
  }
  pyramid->row_spans.push_back(static_cast<int>(pyramid->spans.size()));
}

// One row of a coarser level over cells [begin, end), where x + half stays in the row:
// o[x] = max(a[x], a[x + half], b[x], b[x + half]) of rows a and b of the level below (16-bit
// codes to 16, 16 to 8 rounding up to multiples of 257, 8 to 8): a large share of a sparse
// log's run (HETSLAM_CLONES).
HETSLAM_CLONES void MaxOfFour(const uint16_t* a, const uint16_t* b, int half, int begin, int end, uint16_t* o) {
  for (int x = begin; x < end; ++x) o[x] = std::max(std::max(a[x], a[x + half]), std::max(b[x], b[x + half]));
}
// (q + 256) / 257 as a multiply and a shift (equal for every q < 65536, checked exhaustively;
// the division was 5% of an Intel run).
inline uint8_t To8Bits(uint16_t q) { return static_cast<uint8_t>(((q + 256u) * 65281u) >> 24); }
HETSLAM_CLONES void MaxOfFour(const uint16_t* a, const uint16_t* b, int half, int begin, int end, uint8_t* o) {
  for (int x = begin; x < end; ++x) o[x] = To8Bits(std::max(std::max(a[x], a[x + half]), std::max(b[x], b[x + half])));
}
HETSLAM_CLONES void MaxOfFour(const uint8_t* a, const uint8_t* b, int half, int begin, int end, uint8_t* o) {
  for (int x = begin; x < end; ++x) o[x] = std::max(std::max(a[x], a[x + half]), std::max(b[x], b[x + half]));
}
// BuildPyramid's level-0 codes of a tile row of eight cells of a field being built, with
// log-odds: the free-space penalty's code where the value is 0 and the cell observed and not
// occupied, else the value's code min(top, (value - lowest) inv_step + 0.5) truncated. Four
// cells at a time with the same float operations as BuildPyramid's to_code (core/vector4.h),
// so the same codes.
void CodeTileRow(const float* value, const float* odds, float occupied_threshold, float lowest, float inv_step,
                 float top, uint16_t penalty, uint16_t* out) {
  constexpr float kUnobserved = OccupancyGrid::kUnobserved;
  static_assert(TiledGrid<float>::kTileSize == 8, "a tile row: two vectors of four");
  for (int half = 0; half < 8; half += 4) {
    const Floats4 v = Load4<Floats4>(value + half), q = Load4<Floats4>(odds + half);
    const Ints4 free_space = (v == 0.f) & (q <= occupied_threshold) & (q != kUnobserved);
    Floats4 scaled = (v - lowest) * inv_step + 0.5f;
    scaled = scaled < top ? scaled : Splat(top);  // std::min(top, scaled)
    const Ints4 codes = free_space != 0 ? Splat(static_cast<int32_t>(penalty)) : __builtin_convertvector(scaled, Ints4);
    for (int k = 0; k < 4; ++k) out[half + k] = static_cast<uint16_t>(codes[k]);
  }
}

// The coarse levels are computed a span at a time in whole multiples of kVectorCells cells
// (32: an AVX2 register of 8-bit cells, two of 16-bit ones), past the span's end: a vector
// loop's scalar remainder on spans of a few tiles was most of MaxOfFour's instructions. So
// every table has kTableSlack cells after its last row: the last vector of a row's last span
// writes up to kVectorCells - 1 cells past it and reads up to that + half (<= 32) past it.
constexpr int kVectorCells = 32;
constexpr size_t kTableSlack = 2 * kVectorCells;

// Builds `pyramid` where a search of `s` reads it (NeededSpans; its buffers are reused between
// calls and keep their capacity).
void BuildPyramid(const LaserMap& map, const DiscretizedSearch& s, int depth, float free_space_penalty,
                  const LikelihoodField* wall_field, float wall_weight, Pyramid* pyramid) {
  const int w = s.region_width, h = s.region_height;
  const size_t size = static_cast<size_t>(w) * h;
  // Every level is written over the needed spans below before a search reads it: a buffer only
  // grows, uninitialised, its old contents not copied (see TableBuffer).
  // (kTableSlack: see next_level's whole vectors.)
  pyramid->finest.Reserve(size + kTableSlack);
  if (wall_field != nullptr && pyramid->row.size() < static_cast<size_t>(w)) pyramid->row.resize(w);
  pyramid->coarse.resize(std::min(depth, Pyramid::kLevels16));
  for (TableBuffer<uint16_t>& level : pyramid->coarse) level.Reserve(size + kTableSlack);
  pyramid->coarse8.resize(std::max(0, depth - Pyramid::kLevels16));
  for (TableBuffer<uint8_t>& level : pyramid->coarse8) level.Reserve(size + kTableSlack);
  NeededSpans(s, 1 << depth, pyramid);
  // Calls f(y, begin, end) for every needed span [begin, end) of every row y.
  auto for_each_span = [pyramid, h](auto f) {
    for (int y = 0; y < h; ++y) {
      const int band = y / Pyramid::kTile;
      for (int i = pyramid->row_spans[band]; i < pyramid->row_spans[band + 1]; ++i) {
        f(y, pyramid->spans[i][0], pyramid->spans[i][1]);
      }
    }
  };
  const LikelihoodField& field = map.field();
  const OccupancyGrid& grid = map.grid();
  const GridGeometry& g = field.geometry();
  // The region's columns inside the field.
  const int x_inside_begin = std::max(0, -s.region_min.x), x_inside_end = std::min(w, g.width() - s.region_min.x);
  // A frozen field (a finished submap) holds distance codes, each standing for a value
  // (LikelihoodField::FrozenCodes).
  const bool frozen_field = field.frozen();
  const TiledGrid<float>& values = field.values();
  const float* code_value = frozen_field ? field.frozen_codes().value : nullptr;
  // A frozen grid (a finished submap) keeps only cell states (tiled, like the field's values);
  // one that is being built keeps log-odds in tiles (OccupancyGrid::kUnobserved: never observed).
  CHECK_EQ(grid.frozen(), frozen_field) << "a LaserMap's grid and field freeze together";
  const TiledGrid<float>& log_odds = grid.log_odds();
  constexpr uint8_t kFree = static_cast<uint8_t>(CellState::kFree);
  const float occupied_threshold = grid.occupied_threshold_log_odds();
  if (wall_field != nullptr) {
    CHECK_EQ(wall_field->frozen(), frozen_field) << "a LaserMap's fields freeze together";
    CHECK(wall_field->geometry().num_cells() == g.num_cells() && wall_field->geometry().origin() == g.origin())
        << "the wall field's geometry differs from the field's";
  }
  const float* wall_value = wall_field != nullptr && frozen_field ? wall_field->frozen_codes().value : nullptr;
  // Every level-0 value lies in [lowest, highest]: a field value in [0, 1] or the penalty's
  // -free_space_penalty, plus the wall channel's (wall_weight - 1) [0, 1].
  const float wall_extra = wall_field != nullptr ? wall_weight - 1.f : 0.f;
  const float lowest = -free_space_penalty + std::min(0.f, wall_extra);
  const float highest = 1.f + std::max(0.f, wall_extra);
  constexpr float kTop = 65535.f;
  const float step = highest > lowest ? (highest - lowest) / kTop : 1.f;
  const float inv_step = 1.f / step;
  pyramid->lowest = lowest;
  pyramid->step = step;

  // The level-0 code of a value: the nearest, + 0.5 truncated (the values are >= lowest; the min
  // guards rounding).
  auto to_code = [&](float v) { return static_cast<uint16_t>(static_cast<int>(std::min(kTop, (v - lowest) * inv_step + 0.5f))); };
  auto to_value = [](float v) { return v; };
  // A frozen field's distance codes as values and as level-0 codes (the same arithmetic as
  // coding each cell's value: the same codes).
  std::array<uint16_t, 256> frozen_code{};
  if (frozen_field) {
    for (int q = 0; q < 256; ++q) frozen_code[q] = to_code(code_value[q]);
  }
  // A frozen cell's entry (level-0 code, or value before the wall channel is added) from its
  // state and distance code at once: by_state_code[state << 8 | q] (the free-space penalty where
  // q is 0 and the cell free, else the code's entry), and by_state[state] where the codes' tile
  // is not stored (0 or the penalty). A tile without states is all unknown: state 0.
  static_assert(static_cast<int>(CellState::kUnknown) == 0, "an unstored state tile reads as state 0");
  struct FrozenTable {
    std::array<float, 4 * 256> by_state_code_value;
    std::array<uint16_t, 4 * 256> by_state_code;
    std::array<float, 4> by_state_value;
    std::array<uint16_t, 4> by_state;
  };
  FrozenTable frozen_table;
  if (frozen_field) {
    // (The values only with a wall channel: the tables are built for every search.)
    const bool penalised = free_space_penalty != 0.f, values = wall_field != nullptr;
    const uint16_t penalty_code = to_code(-free_space_penalty), code_of_zero = to_code(0.f);
    for (int state = 0; state < 4; ++state) {
      const bool free_cell = penalised && state == kFree;
      std::copy(frozen_code.begin(), frozen_code.end(), frozen_table.by_state_code.begin() + (state << 8));
      if (values) std::copy(code_value, code_value + 256, frozen_table.by_state_code_value.begin() + (state << 8));
      if (free_cell) {
        frozen_table.by_state_code[state << 8] = penalty_code;
        frozen_table.by_state_code_value[state << 8] = -free_space_penalty;
      }
      frozen_table.by_state[state] = free_cell ? penalty_code : code_of_zero;
      frozen_table.by_state_value[state] = free_cell ? -free_space_penalty : 0.f;
    }
  }
  // The n cells from (gx0, gy) of the field (inside it) into `out`: level-0 codes (uint16_t)
  // or values (float, to add the wall channel to), as `convert` (to_code or to_value) turns a
  // value.
  auto field_cells = [&](int gx0, int gy, int n, auto* out, auto convert) {
    using Out = std::remove_pointer_t<decltype(out)>;
    const Out zero = convert(0.f), penalty = convert(-free_space_penalty);
    if (frozen_field) {
      // Tile by tile, each cell looked up by its state (two bits a cell, read undecoded:
      // OccupancyGrid::FrozenStatesTileRowBits) and its distance code at once.
      const Out* by_state_code;
      const Out* by_state;
      if constexpr (std::is_same_v<Out, uint16_t>) {
        by_state_code = frozen_table.by_state_code.data();
        by_state = frozen_table.by_state.data();
      } else {
        by_state_code = frozen_table.by_state_code_value.data();
        by_state = frozen_table.by_state_value.data();
      }
      for (int x = 0; x < n;) {
        const int gx = gx0 + x;
        const int first = gx & (SparseTiles<uint8_t>::kTileSize - 1);
        const int chunk = std::min(n - x, SparseTiles<uint8_t>::kTileSize - first);
        const uint8_t* q = field.FrozenCodesTileRow(gx, gy);
        uint16_t bits = 0;
        const bool states = grid.FrozenStatesTileRowBits(gx, gy, &bits);
        bits = static_cast<uint16_t>(bits >> (2 * first));
        Out* o = out + x;
        if (!states) {
          // All unknown (state 0): the codes' entries, or 0 without them.
          if (q == nullptr) {
            std::fill(o, o + chunk, by_state[0]);
          } else {
            for (int k = 0; k < chunk; ++k) o[k] = by_state_code[q[k]];
          }
        } else if (q == nullptr) {
          for (int k = 0; k < chunk; ++k) o[k] = by_state[(bits >> (2 * k)) & 3u];
        } else {
          for (int k = 0; k < chunk; ++k) o[k] = by_state_code[((bits >> (2 * k)) & 3u) << 8 | q[k]];
        }
        x += chunk;
      }
      return;
    }
    // Tile by tile: a tile without values is 0 throughout, one without log-odds unknown.
    for (int x = 0; x < n;) {
      const int gx = gx0 + x;
      const int chunk = std::min(n - x, TiledGrid<float>::kTileSize - (gx & (TiledGrid<float>::kTileSize - 1)));
      const float* value = values.TileRow(gx, gy);
      Out* o = out + x;
      // A point in known free space (observed, not occupied), away from any hit, is evidence
      // against the pose. (Plain loops: the equivalent Eigen select over a mixed-type boolean
      // expression was evaluated element by element, ~1.5x slower at -O2.)
      const float* odds = free_space_penalty > 0.f ? log_odds.TileRow(gx, gy) : nullptr;
      constexpr float kUnobserved = OccupancyGrid::kUnobserved;
      if (value == nullptr && odds == nullptr) {
        std::fill(o, o + chunk, zero);
      } else if (odds == nullptr) {
        for (int k = 0; k < chunk; ++k) o[k] = convert(value[k]);
      } else if (value == nullptr) {
        for (int k = 0; k < chunk; ++k) {
          o[k] = (odds[k] <= occupied_threshold) & (odds[k] != kUnobserved) ? penalty : zero;
        }
      } else {
        // A whole tile row of codes as two vectors of four (most of the front end's level 0).
        bool coded = false;
        if constexpr (std::is_same_v<Out, uint16_t>) {
          if (chunk == TiledGrid<float>::kTileSize) {
            CodeTileRow(value, odds, occupied_threshold, lowest, inv_step, kTop, penalty, o);
            coded = true;
          }
        }
        for (int k = 0; !coded && k < chunk; ++k) {
          const bool free_space = (value[k] == 0.f) & (odds[k] <= occupied_threshold) & (odds[k] != kUnobserved);
          o[k] = free_space ? penalty : convert(value[k]);
        }
      }
      x += chunk;
    }
  };
  // Paper §III-E: T += (wall_weight - 1) L_wall, the wall channel at the same cell. Walls are
  // some of the occupied cells and the window is the same, so L_wall is 0 where L is (up to
  // the republish tolerance: each field publishes a moved hit point on its own), and the
  // free-space penalty keeps its cells.
  auto add_walls = [&](int gx0, int gy, int n, float* out) {
    for (int x = 0; x < n;) {
      const int gx = gx0 + x;
      if (frozen_field) {
        const int chunk = std::min(n - x, SparseTiles<uint8_t>::kTileSize - (gx & (SparseTiles<uint8_t>::kTileSize - 1)));
        const uint8_t* q = wall_field->FrozenCodesTileRow(gx, gy);
        if (q != nullptr) {
          for (int k = 0; k < chunk; ++k) out[x + k] += wall_extra * wall_value[q[k]];
        }
        x += chunk;
      } else {
        const int chunk = std::min(n - x, TiledGrid<float>::kTileSize - (gx & (TiledGrid<float>::kTileSize - 1)));
        const float* wall = wall_field->values().TileRow(gx, gy);
        if (wall != nullptr) {
          for (int k = 0; k < chunk; ++k) out[x + k] += wall_extra * wall[k];
        }
        x += chunk;
      }
    }
  };
  // Level 0: each span's codes (of 0 outside the field). Without a wall channel the cells are
  // coded as they are read; with it, their values are summed first.
  const uint16_t zero_code = to_code(0.f);
  for_each_span([&](int y, int span_begin, int span_end) {
    uint16_t* codes = pyramid->finest.data() + static_cast<size_t>(y) * w;
    const int gy = s.region_min.y + y;
    const int x_begin = std::max(span_begin, x_inside_begin), x_end = std::min(span_end, x_inside_end);
    if (gy < 0 || gy >= g.height() || x_begin >= x_end) {
      std::fill(codes + span_begin, codes + span_end, zero_code);
      return;
    }
    std::fill(codes + span_begin, codes + x_begin, zero_code);
    std::fill(codes + x_end, codes + span_end, zero_code);
    const int gx0 = s.region_min.x + x_begin, n = x_end - x_begin;
    if (wall_field == nullptr) {
      field_cells(gx0, gy, n, codes + x_begin, to_code);
      return;
    }
    float* values_row = pyramid->row.data();
    field_cells(gx0, gy, n, values_row, to_value);
    add_walls(gx0, gy, n, values_row);
    for (int x = 0; x < n; ++x) codes[x_begin + x] = to_code(values_row[x]);
  });
  if (depth == 0) return;
  // Coarser levels: the max of four cells of the level below. Codes are monotone, so the max of
  // codes codes the max; the first 8-bit level rounds the 16-bit maxima up to multiples of 257
  // (65535 = 255 · 257).
  auto next_level = [&](const auto* in, int half, auto* out) {
    const int x_split = std::max(0, w - half);  // x + half stays inside the row below this
    for_each_span([&](int y, int span_begin, int span_end) {
      const auto* a = in + static_cast<size_t>(y) * w;
      const auto* b = in + static_cast<size_t>(std::min(y + half, h - 1)) * w;
      auto* o = out + static_cast<size_t>(y) * w;
      // In whole vectors (kVectorCells): no scalar remainder. The cells after the span it
      // writes are needed by no search (those of a later span or of the clamped loop below
      // are written again after); the reads stay within the level's buffer (kTableSlack).
      const int stop = std::min(span_end, x_split);
      if (stop > span_begin) {
        MaxOfFour(a, b, half, span_begin, span_begin + (stop - span_begin + kVectorCells - 1) / kVectorCells * kVectorCells,
                  o);
      }
      for (int x = std::max(span_begin, x_split); x < span_end; ++x) {
        const auto q = std::max(std::max(a[x], a[w - 1]), std::max(b[x], b[w - 1]));
        if constexpr (sizeof(*o) < sizeof(q)) {
          o[x] = To8Bits(q);
        } else {
          o[x] = q;
        }
      }
    });
  };
  for (int level = 1; level <= depth; ++level) {
    const int half = 1 << (level - 1);
    const uint16_t* below16 = level == 1 ? pyramid->finest.data()
                                         : level - 1 <= Pyramid::kLevels16 ? pyramid->coarse[level - 2].data() : nullptr;
    if (level <= Pyramid::kLevels16) {
      next_level(below16, half, pyramid->coarse[level - 1].data());
    } else if (level == Pyramid::kLevels16 + 1) {
      next_level(below16, half, pyramid->coarse8[0].data());
    } else {
      next_level(pyramid->coarse8[level - Pyramid::kLevels16 - 2].data(), half,
                 pyramid->coarse8[level - Pyramid::kLevels16 - 1].data());
    }
  }
}

double InverseWeightSum(const std::vector<float>& weights, size_t n) {
  if (weights.empty()) return 1.0 / n;
  double sum = 0.0;
  for (float w : weights) sum += w;
  return sum > 0.0 ? 1.0 / sum : 0.0;
}

// Everything a candidate's score depends on. Score of a block of 2^h × 2^h offsets at level h:
//   weighted mean of M_h over the points − motion penalty of the block's offset nearest to the
//   prediction, an upper bound of every member's score (paper eq. 1 with a weak motion prior).
struct SearchContext {
  const DiscretizedSearch* search;
  const Pyramid* pyramid;
  const std::vector<float>* weights;
  double inv_weight_sum;
  double resolution_meters;
  double translation_penalty_per_square_meter;
  double rotation_penalty_per_square_radian;

  // The step of level `level`'s codes.
  double Step(int level) const {
    return level <= Pyramid::kLevels16 ? static_cast<double>(pyramid->step)
                                       : static_cast<double>(pyramid->step) * 257.0;
  }
  // f(level `level`'s table).
  template <typename F>
  auto WithTable(int level, F f) const {
    if (level == 0) return f(pyramid->finest.data());
    if (level <= Pyramid::kLevels16) return f(pyramid->coarse[level - 1].data());
    return f(pyramid->coarse8[level - Pyramid::kLevels16 - 1].data());
  }
  // The score of the block of `level` at (yaw_index, dx, dy) whose points' values sum to `sum`.
  float FromSum(double sum, int level, int yaw_index, int dx, int dy) const {
    const int size = 1 << level;
    auto nearest_to_zero = [size](int begin) { return begin > 0 ? begin : (begin + size - 1 < 0 ? begin + size - 1 : 0); };
    const double tx = nearest_to_zero(dx) * resolution_meters, ty = nearest_to_zero(dy) * resolution_meters;
    const double dyaw = search->yaw_offsets[yaw_index];
    return static_cast<float>(sum * inv_weight_sum - translation_penalty_per_square_meter * (tx * tx + ty * ty) -
                              rotation_penalty_per_square_radian * dyaw * dyaw);
  }

  float Score(int level, int yaw_index, int dx, int dy) const {
    const DiscretizedSearch& s = *search;
    const int32_t* const offsets = s.offsets.data() + s.begin[yaw_index];
    const int count = s.begin[yaw_index + 1] - s.begin[yaw_index];
    const float* const cell_weights = s.cell_weights.empty() ? nullptr : s.cell_weights.data() + s.begin[yaw_index];
    const ptrdiff_t base = static_cast<ptrdiff_t>(dy) * s.region_width + dx;
    const double step = Step(level);
    // sum of w_i (lowest + q_i step) = lowest sum w_i + step sum w_i q_i.
    const double sum = WithTable(level, [&](const auto* table) {
      const auto* data = table + base;
      if (weights->empty()) {
        // Four running sums (integers: the order does not change the total).
        int64_t codes[4] = {0, 0, 0, 0};
        int i = 0;
        for (; i + 4 <= count; i += 4) {
          codes[0] += data[offsets[i]];
          codes[1] += data[offsets[i + 1]];
          codes[2] += data[offsets[i + 2]];
          codes[3] += data[offsets[i + 3]];
        }
        for (; i < count; ++i) codes[0] += data[offsets[i]];
        return static_cast<double>(pyramid->lowest) * count + step * ((codes[0] + codes[1]) + (codes[2] + codes[3]));
      }
      double weight_sum = 0.0, weighted_codes = 0.0;
      for (int i = 0; i < count; ++i) {
        weight_sum += cell_weights[i];
        weighted_codes += cell_weights[i] * data[offsets[i]];
      }
      return pyramid->lowest * weight_sum + step * weighted_codes;
    });
    return FromSum(sum, level, yaw_index, dx, dy);
  }

  // The four blocks of `level` at (dx[c], dy[c]), into `scores`: Score's value of each, with
  // the points' offsets read once (the same sums: integers, or each block's weighted sum in the
  // points' order). Used for a block's four children (four Score calls a block were 7% of an
  // Intel run) and for four neighbours along a row of the top level (8% of MIT CSAIL's run).
  void ScoreFour(int level, int yaw_index, const int dx[4], const int dy[4], float scores[4]) const {
    const DiscretizedSearch& s = *search;
    const int32_t* const offsets = s.offsets.data() + s.begin[yaw_index];
    const int count = s.begin[yaw_index + 1] - s.begin[yaw_index];
    const float* const cell_weights = s.cell_weights.empty() ? nullptr : s.cell_weights.data() + s.begin[yaw_index];
    const ptrdiff_t base = static_cast<ptrdiff_t>(dy[0]) * s.region_width + dx[0];
    ptrdiff_t shift[4];  // of block c from block 0
    for (int c = 0; c < 4; ++c) shift[c] = static_cast<ptrdiff_t>(dy[c] - dy[0]) * s.region_width + (dx[c] - dx[0]);
    const double step = Step(level);
    double sums[4];
    WithTable(level, [&](const auto* table) {
      const auto* data = table + base;
      if (weights->empty()) {
        int64_t codes[4] = {0, 0, 0, 0};
        for (int i = 0; i < count; ++i) {
          const auto* cell = data + offsets[i];
          codes[0] += cell[0];
          codes[1] += cell[shift[1]];
          codes[2] += cell[shift[2]];
          codes[3] += cell[shift[3]];
        }
        for (int c = 0; c < 4; ++c) sums[c] = static_cast<double>(pyramid->lowest) * count + step * codes[c];
        return 0;
      }
      double weight_sum = 0.0, weighted_codes[4] = {0.0, 0.0, 0.0, 0.0};
      for (int i = 0; i < count; ++i) {
        const auto* cell = data + offsets[i];
        weight_sum += cell_weights[i];
        weighted_codes[0] += cell_weights[i] * cell[0];
        weighted_codes[1] += cell_weights[i] * cell[shift[1]];
        weighted_codes[2] += cell_weights[i] * cell[shift[2]];
        weighted_codes[3] += cell_weights[i] * cell[shift[3]];
      }
      for (int c = 0; c < 4; ++c) sums[c] = pyramid->lowest * weight_sum + step * weighted_codes[c];
      return 0;
    });
    for (int c = 0; c < 4; ++c) scores[c] = FromSum(sums[c], level, yaw_index, dx[c], dy[c]);
  }
};

// Leaves a branch-and-bound search passes over (the neighbourhood of a mode already found).
struct Exclusion {
  const Candidate* around = nullptr;  // none: nothing excluded
  int cells = 0;
  double radians = 0.0;
  bool Excludes(const DiscretizedSearch& s, const Candidate& c) const {
    return around != nullptr && std::abs(c.dx - around->dx) <= cells && std::abs(c.dy - around->dy) <= cells &&
           std::abs(WrapAngle(s.yaws[c.yaw_index] - s.yaws[around->yaw_index])) <= radians;
  }
  // Every leaf of the block of `size` x `size` offsets from c (those inside the window) is
  // excluded: its offsets' range lies within the exclusion's on both axes, and its yaw does.
  bool ExcludesBlock(const DiscretizedSearch& s, const Candidate& c, int size) const {
    if (around == nullptr) return false;
    const int last_dx = std::min(c.dx + size - 1, s.window_cells), last_dy = std::min(c.dy + size - 1, s.window_cells);
    return c.dx >= around->dx - cells && last_dx <= around->dx + cells && c.dy >= around->dy - cells &&
           last_dy <= around->dy + cells && std::abs(WrapAngle(s.yaws[c.yaw_index] - s.yaws[around->yaw_index])) <= radians;
  }
};

// Depth-first branch and bound (children visited best-bound first); `best` holds the best
// leaf so far and prunes every block whose bound cannot beat it. Leaves `exclusion` names are
// passed over (a block's bound still covers them: it stays an upper bound of the rest).
// `candidates` [begin, end) are reordered; ties are visited in (yaw, dy, dx) order, the order
// in which MatchOnce generates the top level (and children are generated).
void BranchAndBound(const SearchContext& context, Candidate* begin, Candidate* end, int level, Candidate* best,
                    int* scored, const Exclusion& exclusion = Exclusion()) {
  const int window = context.search->window_cells;
  // Visits one candidate; false once no later one can beat `best` (they come best first).
  auto visit = [&](const Candidate& candidate) {
    if (candidate.score <= best->score) return false;
    if (level == 0) {
      if (!exclusion.Excludes(*context.search, candidate)) *best = candidate;
      return true;
    }
    // A block whose leaves are all passed over holds nothing to find (its bound is the first
    // mode's, the highest: the second-mode search descended there first).
    if (exclusion.ExcludesBlock(*context.search, candidate, 1 << level)) return true;
    const int half = 1 << (level - 1);
    Candidate children[4];
    int num_children = 0;
    if (candidate.dx + half <= window && candidate.dy + half <= window) {
      // (dx, dy), (dx + half, dy), (dx, dy + half), (dx + half, dy + half): generation order.
      const int dx[4] = {candidate.dx, candidate.dx + half, candidate.dx, candidate.dx + half};
      const int dy[4] = {candidate.dy, candidate.dy, candidate.dy + half, candidate.dy + half};
      float scores[4];
      context.ScoreFour(level - 1, candidate.yaw_index, dx, dy, scores);
      for (int c = 0; c < 4; ++c) children[c] = {candidate.yaw_index, dx[c], dy[c], scores[c]};
      num_children = 4;
      *scored += 4;
    } else {
      // A block on the window's far side: only its children inside the window.
      for (int oy : {0, half}) {
        for (int ox : {0, half}) {
          const int dx = candidate.dx + ox, dy = candidate.dy + oy;
          if (dx > window || dy > window) continue;
          children[num_children++] = {candidate.yaw_index, dx, dy,
                                       context.Score(level - 1, candidate.yaw_index, dx, dy)};
          ++*scored;
        }
      }
    }
    BranchAndBound(context, children, children + num_children, level - 1, best, scored, exclusion);
    return true;
  };
  // Best bound first, ties in generation order: the order of a stable sort by bound.
  auto worse = [](const Candidate& a, const Candidate& b) {
    if (a.score != b.score) return a.score < b.score;
    return std::tie(a.yaw_index, a.dy, a.dx) > std::tie(b.yaw_index, b.dy, b.dx);
  };
  if (end - begin <= 8) {
    // At most four children below the top (on the stack): insertion sort, no allocation.
    for (Candidate* i = begin + 1; i < end; ++i) {
      for (Candidate* j = i; j > begin && worse(*(j - 1), *j); --j) std::swap(*j, *(j - 1));
    }
    for (const Candidate* candidate = begin; candidate < end; ++candidate) {
      if (!visit(*candidate)) break;
    }
    return;
  }
  // The top level (thousands of blocks), best bound first, without sorting the blocks after the
  // search stops (a full stable sort was 4% of an Intel run, a heap's operations 6% of it). The
  // first block in that order is searched at once: the leaf it leads to is usually near the best,
  // and every block whose bound is not above it would end the search when reached (best only
  // grows), so only the rest are ordered (Intel: ~1900 blocks a search, of which ~230 were
  // visited). The order is total (ties in generation order), whatever the blocks' arrangement.
  Candidate* const top_block = std::max_element(begin, end, worse);
  std::iter_swap(top_block, end - 1);
  if (!visit(*(end - 1))) return;
  Candidate* const rest_end =
      std::partition(begin, end - 1, [best](const Candidate& candidate) { return candidate.score > best->score; });
  if (rest_end == begin) return;
  // The rest, best first, by a counting sort on their bounds into buckets of equal shares of the
  // bounds' range, in place (a copy of the blocks was 0.25 MiB more at ACES's peak, a wide
  // search), each bucket sorted when the search reaches it: a bucket's index does not decrease
  // with the bound, so a lower bucket holds only lower bounds, and the order is the heap's (a
  // heap's sift operations were 4% of a MIT CSAIL run, whose wide and fallback searches heap tens
  // of thousands of blocks).
  const size_t n = static_cast<size_t>(rest_end - begin);
  float lowest = begin->score, highest = begin->score;
  for (const Candidate* c = begin; c < rest_end; ++c) {
    lowest = std::min(lowest, c->score);
    highest = std::max(highest, c->score);
  }
  const int num_buckets = static_cast<int>(std::clamp<size_t>(n / 16, 1, size_t{1} << 14));
  const double scale = highest > lowest ? (num_buckets - 1) / (static_cast<double>(highest) - lowest) : 0.0;
  auto bucket_of = [&](const Candidate& c) {
    return std::clamp(static_cast<int>((static_cast<double>(c.score) - lowest) * scale), 0, num_buckets - 1);
  };
  std::vector<int> starts(static_cast<size_t>(num_buckets) + 1, 0);
  for (const Candidate* c = begin; c < rest_end; ++c) ++starts[bucket_of(*c) + 1];
  for (int b = 0; b < num_buckets; ++b) starts[b + 1] += starts[b];
  {
    // Each block swapped to the next free place of its bucket until every bucket is full.
    std::vector<int> next(starts.begin(), starts.end() - 1);
    for (int b = 0; b < num_buckets; ++b) {
      while (next[b] < starts[b + 1]) {
        const int home = bucket_of(begin[next[b]]);
        if (home == b) {
          ++next[b];
        } else {
          std::swap(begin[next[b]], begin[next[home]++]);
        }
      }
    }
  }
  auto better = [&worse](const Candidate& a, const Candidate& b) { return worse(b, a); };
  for (int b = num_buckets - 1; b >= 0; --b) {
    Candidate* const first = begin + starts[b];
    Candidate* const last = begin + starts[b + 1];
    std::sort(first, last, better);
    for (const Candidate* candidate = first; candidate < last; ++candidate) {
      if (!visit(*candidate)) return;
    }
  }
}

// A scan's points rotated by one yaw, as the four products pose * p is made of: world x =
// (x + c px) - s py, world y = (y + s px) + c py, the same arithmetic as Pose2's operator*
// with the cosine and sine taken once. The score profile scores one rotation at many
// translations. Each product in an array of its own (the cells' coordinates are computed for
// all points at once, CellCoordinates), with room for those coordinates.
struct RotatedPoints {
  RotatedPoints() = default;
  RotatedPoints(double theta, const std::vector<Eigen::Vector2f>& points) {
    const double c = std::cos(theta), s = std::sin(theta);
    const size_t n = points.size();
    c_px.resize(n);
    s_py.resize(n);
    s_px.resize(n);
    c_py.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const double px = points[i].x(), py = points[i].y();
      c_px[i] = c * px;
      s_py[i] = s * py;
      s_px[i] = s * px;
      c_py[i] = c * py;
    }
    cell_x.resize(n);
    cell_y.resize(n);
    fraction_x.resize(n);
    fraction_y.resize(n);
  }
  size_t size() const { return c_px.size(); }
  std::vector<double> c_px, s_py, s_px, c_py;
  // Scratch of BilinearScoreAt (so one RotatedPoints serves one thread): each point's lower-left
  // cell centre and its fractions.
  mutable std::vector<int32_t> cell_x, cell_y;
  mutable std::vector<double> fraction_x, fraction_y;
};

// CellCoordinates' arithmetic for one point (its products c_px, s_py, s_px, c_py) placed at
// each of m positions (xs[s], ys[s]): the same doubles, vectorised over the positions.
HETSLAM_CLONES void CellCoordinatesOfPositions(int m, const double* __restrict xs, const double* __restrict ys,
                                               double c_px, double s_py, double s_px, double c_py, double ox,
                                               double oy, double r, int32_t* __restrict cell_x,
                                               int32_t* __restrict cell_y, double* __restrict fraction_x,
                                               double* __restrict fraction_y) {
  for (int s = 0; s < m; ++s) {
    const double qx = (xs[s] + c_px - s_py - ox) / r - 0.5, qy = (ys[s] + s_px + c_py - oy) / r - 0.5;
    const int x0 = FloorToInt(qx), y0 = FloorToInt(qy);
    cell_x[s] = x0;
    cell_y[s] = y0;
    fraction_x[s] = qx - x0;
    fraction_y[s] = qy - y0;
  }
}

// For n points placed at (x, y) (products as in RotatedPoints): each point's position in
// cells less half a cell (GridGeometry::WorldToContinuousCell's arithmetic, inline), its floor
// and the fraction above it. Vectorised (HETSLAM_CLONES): the two divisions a point were a
// third of the score profile's time; the same operations in the same order, so the same
// doubles.
HETSLAM_CLONES void CellCoordinates(size_t n, double x, double y, const double* __restrict c_px,
                                    const double* __restrict s_py, const double* __restrict s_px,
                                    const double* __restrict c_py, double ox, double oy, double r,
                                    int32_t* __restrict cell_x, int32_t* __restrict cell_y,
                                    double* __restrict fraction_x, double* __restrict fraction_y) {
  for (size_t i = 0; i < n; ++i) {
    const double qx = (x + c_px[i] - s_py[i] - ox) / r - 0.5, qy = (y + s_px[i] + c_py[i] - oy) / r - 0.5;
    const int x0 = FloorToInt(qx), y0 = FloorToInt(qy);
    cell_x[i] = x0;
    cell_y[i] = y0;
    fraction_x[i] = qx - x0;
    fraction_y[i] = qy - y0;
  }
}

// Bilinear interpolation of the cells (x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)
// holding c00, c10, c01, c11 at the fractions (fx, fy) above (x0, y0): one expression for every
// scorer, so that they give the same doubles.
inline double Bilinear(double fx, double fy, float c00, float c10, float c01, float c11) {
  return (1 - fx) * (1 - fy) * c00 + fx * (1 - fy) * c10 + (1 - fx) * fy * c01 + fx * fy * c11;
}

// The weighted mean over the points, placed at (x, y) with the rotation of `rotated`, of L
// (bilinear); with a wall field, of L + (wall_weight - 1) L_wall, both read at the same
// position (paper §III-E).
double BilinearScoreAt(const LikelihoodField& field, double x, double y, const RotatedPoints& rotated,
                       const std::vector<float>& weights, const LikelihoodField* wall_field, double wall_weight) {
  const GridGeometry& g = field.geometry();
  const size_t n = rotated.size();
  CellCoordinates(n, x, y, rotated.c_px.data(), rotated.s_py.data(), rotated.s_px.data(), rotated.c_py.data(),
                  g.origin().x(), g.origin().y(), g.resolution_meters(), rotated.cell_x.data(), rotated.cell_y.data(),
                  rotated.fraction_x.data(), rotated.fraction_y.data());
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const int x0 = rotated.cell_x[i], y0 = rotated.cell_y[i];
    const double fx = rotated.fraction_x[i], fy = rotated.fraction_y[i];
    float c[4];
    field.Values2x2(x0, y0, c);
    double v = Bilinear(fx, fy, c[0], c[1], c[2], c[3]);
    if (wall_field != nullptr) {
      wall_field->Values2x2(x0, y0, c);
      v += (wall_weight - 1.0) * Bilinear(fx, fy, c[0], c[1], c[2], c[3]);
    }
    sum += (weights.empty() ? 1.0 : weights[i]) * v;
  }
  return sum * InverseWeightSum(weights, n);
}

// BilinearScoreAt at each of the m positions (xs[s], ys[s]), into scores[s]: the same sums
// (each position's over the points in order, the same arithmetic as CellCoordinates and
// BilinearScoreAt), but each point's field values read once, as the block of cells its m
// positions touch (LikelihoodField::ValuesBlock), instead of a lookup a position: the score
// profile's 96 positions lie within 0.3 m of one another.
void BilinearScoresAt(const LikelihoodField& field, const double* xs, const double* ys, int m,
                      const RotatedPoints& rotated, const std::vector<float>& weights,
                      const LikelihoodField* wall_field, double wall_weight, double* scores) {
  const GridGeometry& g = field.geometry();
  const double ox = g.origin().x(), oy = g.origin().y(), r = g.resolution_meters();
  if (m == 0) return;
  const size_t n = rotated.size();
  std::vector<double> sums(m, 0.0), fraction_x(m), fraction_y(m);
  std::vector<int32_t> cell_x(m), cell_y(m);
  // A point's block is at most the positions' extent in cells plus 3 on each axis (the cells
  // of two positions d apart differ by at most ceil(d / r), and a bilinear read takes one
  // more): allocated once.
  const auto [xs_min, xs_max] = std::minmax_element(xs, xs + m);
  const auto [ys_min, ys_max] = std::minmax_element(ys, ys + m);
  const size_t most = static_cast<size_t>(std::ceil((*xs_max - *xs_min) / r) + 3) *
                      static_cast<size_t>(std::ceil((*ys_max - *ys_min) / r) + 3);
  std::vector<float> block(most), wall_block(wall_field != nullptr ? most : 0);
  for (size_t i = 0; i < n; ++i) {
    CellCoordinatesOfPositions(m, xs, ys, rotated.c_px[i], rotated.s_py[i], rotated.s_px[i], rotated.c_py[i], ox, oy, r,
                               cell_x.data(), cell_y.data(), fraction_x.data(), fraction_y.data());
    const auto [x_min_it, x_max_it] = std::minmax_element(cell_x.begin(), cell_x.end());
    const auto [y_min_it, y_max_it] = std::minmax_element(cell_y.begin(), cell_y.end());
    const int x_min = *x_min_it, x_max = *x_max_it, y_min = *y_min_it, y_max = *y_max_it;
    const int w = x_max - x_min + 2, h = y_max - y_min + 2;
    CHECK_LE(static_cast<size_t>(w) * h, block.size()) << "a point's block exceeds its bound";
    field.ValuesBlock(x_min, y_min, w, h, block.data());
    if (wall_field != nullptr) wall_field->ValuesBlock(x_min, y_min, w, h, wall_block.data());
    const double weight = weights.empty() ? 1.0 : weights[i];
    for (int s = 0; s < m; ++s) {
      const size_t at = static_cast<size_t>(cell_y[s] - y_min) * w + (cell_x[s] - x_min);
      const double fx = fraction_x[s], fy = fraction_y[s];
      const float* c = block.data() + at;
      double v = Bilinear(fx, fy, c[0], c[1], c[w], c[w + 1]);
      if (wall_field != nullptr) {
        const float* cw = wall_block.data() + at;
        v += (wall_weight - 1.0) * Bilinear(fx, fy, cw[0], cw[1], cw[w], cw[w + 1]);
      }
      sums[s] += weight * v;
    }
  }
  const double inverse = InverseWeightSum(weights, n);
  for (int s = 0; s < m; ++s) scores[s] = sums[s] * inverse;
}

// The same at `pose`.
double BilinearScore(const LikelihoodField& field, const Pose2& pose, const std::vector<Eigen::Vector2f>& points,
                     const std::vector<float>& weights, const LikelihoodField* wall_field = nullptr,
                     double wall_weight = 1.0) {
  return BilinearScoreAt(field, pose.x(), pose.y(), RotatedPoints(pose.theta(), points), weights, wall_field,
                         wall_weight);
}

// The score profile's points (ScanMatchResult::weak_direction) from refinement points that
// outnumber the searched ones (LocalSlamOptions::refine_on_all_points): every k-th of them, k
// the smallest stride that leaves at most `searched` points, starting half a stride in; empty
// when there are no more refinement points than searched ones (the profile then takes them
// all). The profile scores 96 shifted poses: on all of a dense scan's points it made FR079 with
// every point refined 21% slower than with the searched points alone, 5-8% with this (README, "The score profile
// on every k-th point").
// A stride takes points in beam order without choosing within a surface, so the profile keeps
// every point's balance (each voxel's first point turned matches one way: see
// LocalSlamOptions::refine_on_all_points).
std::vector<Eigen::Vector2f> ProfilePoints(const std::vector<Eigen::Vector2f>& refinement, size_t searched) {
  std::vector<Eigen::Vector2f> thinned;
  if (searched == 0 || refinement.size() <= searched) return thinned;
  const size_t stride = (refinement.size() + searched - 1) / searched;
  thinned.reserve(refinement.size() / stride + 1);
  for (size_t i = stride / 2; i < refinement.size(); i += stride) thinned.push_back(refinement[i]);
  return thinned;
}

// The axis of a scan's surfaces (robot frame, unit), when it has one: the length-weighted mean
// of the doubled angles of the segments between each point and the next one at least 0.1 m
// on in beam order, segments over 0.5 m (a gap, another surface) left out. In a corridor,
// along a single wall, every segment runs along the walls. Empty without segments.
std::optional<Eigen::Vector2d> WallAxis(const std::vector<Eigen::Vector2f>& points) {
  double c = 0.0, s = 0.0;
  size_t j = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    j = std::max(j, i + 1);
    while (j < points.size() && (points[j] - points[i]).norm() < 0.1f) ++j;
    if (j >= points.size()) break;
    const Eigen::Vector2d d = (points[j] - points[i]).cast<double>();
    const double length = d.norm();
    if (length > 0.5) continue;
    const double phi = std::atan2(d.y(), d.x());
    c += length * std::cos(2 * phi);
    s += length * std::sin(2 * phi);
  }
  if (c == 0.0 && s == 0.0) return std::nullopt;
  const double axis = 0.5 * std::atan2(s, c);
  return Eigen::Vector2d(std::cos(axis), std::sin(axis));
}

// The weights of the wall channel's residuals: sqrt(wall_weight - 1) times each point's weight.
std::vector<float> WallResidualWeights(const std::vector<float>& weights, size_t num_points, double wall_weight) {
  const float root = static_cast<float>(std::sqrt(wall_weight - 1.0));
  std::vector<float> scaled(num_points, root);
  for (size_t i = 0; i < weights.size(); ++i) scaled[i] *= weights[i];
  return scaled;
}

// The refinements' solver: a 3-parameter dense problem, one thread, silent.
ceres::Solver::Options RefinementSolverOptions(const ScanMatcherOptions& options) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_ceres_iterations;
  solver_options.function_tolerance = options.refine_function_tolerance;
  solver_options.num_threads = 1;
  solver_options.minimizer_progress_to_stdout = false;
  solver_options.logging_type = ceres::SILENT;
  return solver_options;
}

// The map's wall field when `options` weigh walls and the map has one, else null.
const LikelihoodField* WallFieldFor(const ScanMatcherOptions& options, const LaserMap& map) {
  return options.wall_weight != 1.0 ? map.wall_field() : nullptr;
}

SearchContext MakeContext(const ScanMatcherOptions& options, const LaserMap& map, const DiscretizedSearch& s,
                          const Pyramid& pyramid, const std::vector<float>& weights, size_t num_points) {
  return SearchContext{&s, &pyramid, &weights, InverseWeightSum(weights, num_points),
                       map.field().geometry().resolution_meters(),
                       options.translation_penalty_per_square_meter, options.rotation_penalty_per_square_radian};
}

}  // namespace

double ScoreAt(const LaserMap& map, const Pose2& pose, const std::vector<Eigen::Vector2f>& points_robot,
               const std::vector<float>& weights) {
  return BilinearScore(map.field(), pose, points_robot, weights);
}

double ReachableScoreBound(const LaserMap& map, const Pose2& pose, const std::vector<Eigen::Vector2f>& points_robot,
                           const std::vector<float>& weights, double max_translation_meters,
                           double max_rotation_radians, double enough) {
  const LikelihoodField& field = map.field();
  if (!field.frozen()) return 1.0;
  const GridGeometry& g = field.geometry();
  const double cell = g.resolution_meters();
  const double inverse_weight_sum = InverseWeightSum(weights, points_robot.size());
  // The rotations, split into sectors of half-width at most kSectorRadians: in the sector
  // around yaw a, a rotation b moves a point at range r by at most r |b - a| from where a puts
  // it (chord <= arc), and a translation t by |t|. The bound is the best sector's.
  constexpr double kSectorRadians = 0.02;
  const double rotation = std::min(std::abs(max_rotation_radians), M_PI);
  const int sectors = std::max(1, static_cast<int>(std::ceil(rotation / kSectorRadians)));
  const double half_width = rotation / sectors;
  double best = 0.0;
  for (int k = 0; k < sectors; ++k) {
    const double yaw = -rotation + (2 * k + 1) * half_width;
    const Pose2::PointTransform sector_pose(pose * Pose2(0.0, 0.0, yaw));
    double reachable = 0.0;
    for (size_t i = 0; i < points_robot.size(); ++i) {
      const Eigen::Vector2d p = points_robot[i].cast<double>();
      const double reach_meters = max_translation_meters + p.norm() * half_width;
      // The bilinear lookup reads the cells within one of the point's cell; one more for rounding.
      const double reach_cells = std::ceil(reach_meters / cell) + 2.0;
      if (!(reach_cells < 1e6) ||
          field.MayBeNonZeroNear(g.WorldToCell(sector_pose(p)), static_cast<int>(reach_cells))) {
        reachable += weights.empty() ? 1.0 : weights[i];
      }
    }
    best = std::max(best, reachable * inverse_weight_sum);
    if (best >= enough) break;
  }
  return best;
}

bool ScanMatcherOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  // Windows up to 50 m: the search visits (2 window / cell)^2 offsets per angle (hostile-input rule).
  if (!(linear_search_window_meters >= 0 && linear_search_window_meters <= 50 &&
        fallback_linear_search_window_meters <= 50 && narrow_linear_search_window_meters <= 50))
    msg << "linear search windows must be in [0, 50] m (got " << linear_search_window_meters << "); ";
  if (!(angular_search_window_radians >= 0 && angular_search_window_radians <= M_PI))
    msg << "angular_search_window_radians must be in [0, pi] (got " << angular_search_window_radians << "); ";
  if (!(angular_step_radians >= 0)) msg << "angular_step_radians must be >= 0; ";
  if (!(profile_step_meters > 0 && profile_step_meters <= 1)) msg << "profile_step_meters must be in (0, 1]; ";
  if (!(weak_direction_snap_radians >= 0 && weak_direction_snap_radians <= 0.5 * M_PI)) {
    msg << "weak_direction_snap_radians must be in [0, pi/2]; ";
  }
  if (!(min_angular_step_radians > 0 && min_angular_step_radians <= max_angular_step_radians))
    msg << "need 0 < min_angular_step_radians <= max_angular_step_radians; ";
  if (branch_and_bound_depth < 0 || branch_and_bound_depth > 10)
    msg << "branch_and_bound_depth must be in [0, 10] (got " << branch_and_bound_depth << "); ";
  if (!(min_correlative_score >= 0 && min_correlative_score < 1)) msg << "min_correlative_score must be in [0, 1); ";
  if (max_ceres_iterations < 0 || max_ceres_iterations > 1000) msg << "max_ceres_iterations must be in [0, 1000]; ";
  if (!(refine_function_tolerance > 0 && refine_function_tolerance < 1))
    msg << "refine_function_tolerance must be in (0, 1) (got " << refine_function_tolerance << "); ";
  if (!(free_space_penalty >= 0)) msg << "free_space_penalty must be >= 0; ";
  if (!(fallback_below_score >= 0 && fallback_linear_search_window_meters >= 0 &&
        fallback_angular_search_window_radians >= 0 && fallback_angular_search_window_radians <= M_PI))
    msg << "fallback score and windows must be >= 0 (angular <= pi); ";
  if (!(narrow_linear_search_window_meters >= 0 && narrow_angular_search_window_radians >= 0 &&
        narrow_angular_search_window_radians <= M_PI && narrow_accept_score >= 0))
    msg << "narrow windows and narrow_accept_score must be >= 0 (angular <= pi); ";
  if (!(translation_penalty_per_square_meter >= 0 && rotation_penalty_per_square_radian >= 0))
    msg << "motion penalties must be >= 0; ";
  if (!(second_mode_exclusion_meters >= 0 && second_mode_exclusion_meters <= 50 && second_mode_exclusion_radians >= 0))
    msg << "second-mode exclusions must be >= 0 (metres <= 50); ";
  if (!(wide_second_mode_exclusion_meters >= 0 && wide_second_mode_exclusion_meters <= 50 &&
        wide_second_mode_exclusion_radians >= 0))
    msg << "wide second-mode exclusions must be >= 0 (metres <= 50); ";
  if (!(wide_second_mode_min_score_ratio >= 0 && wide_second_mode_min_score_ratio <= 1))
    msg << "wide_second_mode_min_score_ratio must be in [0, 1]; ";
  if (!(wall_weight >= 1 && wall_weight <= 100)) msg << "wall_weight must be in [1, 100] (got " << wall_weight << "); ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

namespace {

// The branch-and-bound tables of every ScanMatcher of a thread (see ReleaseScratch).
Pyramid& ThreadScratch() {
  thread_local Pyramid pyramid;
  return pyramid;
}

}  // namespace

void ScanMatcher::ReleaseScratch() {
  Pyramid& pyramid = ThreadScratch();
  const size_t bytes = pyramid.Bytes();
  pyramid.Release();
#ifdef __GLIBC__
  // Freed memory inside the heap stays resident until the allocator hands it out again: a wide
  // search's tables (ACES: ~20 MB, the process's peak) are given back to the system at once.
  // Not the smaller ones freed before every solve: their pages would be faulted in again by
  // the next search (ACES, MIT CSAIL: 4% slower when trimming from 1 MiB).
  constexpr size_t kTrimAboveBytes = size_t{8} << 20;
  if (bytes >= kTrimAboveBytes) malloc_trim(0);
#endif
}

size_t ScanMatcher::TrimScratch() {
  Pyramid& pyramid = ThreadScratch();
  pyramid.Trim();
  return pyramid.Bytes();
}

bool ScanMatcher::ShrinkScratchForSolve(bool keep_recent_pages) {
  if (keep_recent_pages) {
    const size_t kept = TrimScratch();
    const std::optional<ResidentMemory> memory = ReadResidentMemory();
    if (memory.has_value() && memory->resident_bytes + kept <= memory->peak_bytes) return true;
  }
  ReleaseScratch();
  return false;
}

size_t ScanMatcher::ScratchBytes() const { return ThreadScratch().Bytes(); }

ScanMatcher::ScanMatcher(const ScanMatcherOptions& options) : options_(options) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid ScanMatcherOptions: " << error;
}

Pose2 ScanMatcher::RefineHoldingDirection(const LaserMap& map, const Pose2& start, const Eigen::Vector2d& held_direction,
                                          const std::vector<Eigen::Vector2f>& points_robot,
                                          const std::vector<float>& weights) const {
  CHECK(weights.empty() || weights.size() == points_robot.size())
      << weights.size() << " weights for " << points_robot.size() << " points";
  if (points_robot.empty() || !(held_direction.squaredNorm() > 0)) return start;
  const LikelihoodField& field = map.field();
  double pose[3] = {start.x(), start.y(), start.theta()};
  ceres::Problem problem;
  problem.AddResidualBlock(
      CreateCompressedCost(CreateScanToLikelihoodFieldCost(field, points_robot, weights, options_.refine_interpolation)),
      nullptr, pose);
  problem.SetManifold(pose, new Se2HeldDirectionManifold(held_direction));
  ceres::Solver::Summary summary;
  ceres::Solve(RefinementSolverOptions(options_), &problem, &summary);
  const Pose2 refined(pose[0], pose[1], pose[2]);
  const double r = field.geometry().resolution_meters();
  if (!summary.IsSolutionUsable() || !((refined.translation() - start.translation()).norm() < 4 * r)) return start;
  return BilinearScore(field, refined, points_robot, weights) >= BilinearScore(field, start, points_robot, weights)
             ? refined
             : start;
}

std::optional<Pose2> ScanMatcher::Refine(const LaserMap& map, const Pose2& start,
                                         const std::vector<Eigen::Vector2f>& points_robot,
                                         const std::vector<float>& weights, double max_rotation_radians) const {
  CHECK(weights.empty() || weights.size() == points_robot.size())
      << weights.size() << " weights for " << points_robot.size() << " points";
  const LikelihoodField& field = map.field();
  if (points_robot.empty() || field.geometry().num_cells() == 0) return std::nullopt;
  double pose[3] = {start.x(), start.y(), start.theta()};
  ceres::Problem problem;
  problem.AddResidualBlock(
      CreateCompressedCost(CreateScanToLikelihoodFieldCost(field, points_robot, weights, options_.refine_interpolation)),
      nullptr, pose);
  ceres::Solver::Summary summary;
  ceres::Solve(RefinementSolverOptions(options_), &problem, &summary);
  const Pose2 refined(pose[0], pose[1], pose[2]);
  const double r = field.geometry().resolution_meters();
  if (!summary.IsSolutionUsable() || !((refined.translation() - start.translation()).norm() < 4 * r) ||
      !(std::abs(Between(start, refined).theta()) < max_rotation_radians)) {
    return std::nullopt;
  }
  return refined;
}

ScanMatchResult ScanMatcher::BruteForceSearch(const LaserMap& map, const Pose2& predicted,
                                              const std::vector<Eigen::Vector2f>& points_robot,
                                              const std::vector<float>& weights) const {
  ScanMatchResult result;
  result.pose = predicted;
  const LikelihoodField& field = map.field();
  if (points_robot.empty() || field.geometry().num_cells() == 0) return result;
  Pyramid pyramid;
  Discretize(options_, map, predicted, points_robot, weights, 1, &pyramid.search, &pyramid.cells);
  const DiscretizedSearch& s = pyramid.search;
  BuildPyramid(map, s, 0, options_.free_space_penalty, WallFieldFor(options_, map),
               static_cast<float>(options_.wall_weight), &pyramid);
  const SearchContext context = MakeContext(options_, map, s, pyramid, weights, points_robot.size());
  Candidate best{0, 0, 0, -std::numeric_limits<float>::infinity()};
  for (int k = 0; k < static_cast<int>(s.yaws.size()); ++k) {
    for (int dy = -s.window_cells; dy <= s.window_cells; ++dy) {
      for (int dx = -s.window_cells; dx <= s.window_cells; ++dx) {
        const float score = context.Score(0, k, dx, dy);
        ++result.candidates_scored;
        if (score > best.score) best = {k, dx, dy, score};
      }
    }
  }
  const double r = field.geometry().resolution_meters();
  result.pose = Pose2(predicted.translation() + Eigen::Vector2d(best.dx, best.dy) * r, s.yaws[best.yaw_index]);
  result.correlative_score = best.score;
  result.converged = best.score >= options_.min_correlative_score;
  return result;
}

bool ScanMatcher::OnWindowBorder(const Pose2& predicted, const Pose2& pose, double linear_window_meters,
                                 double angular_window_radians) const {
  const Pose2 offset = Between(predicted, pose);
  return std::abs(offset.theta()) >= angular_window_radians - 2 * options_.max_angular_step_radians ||
         std::abs(pose.x() - predicted.x()) >= linear_window_meters - 0.1 ||
         std::abs(pose.y() - predicted.y()) >= linear_window_meters - 0.1;
}

ScanMatchResult ScanMatcher::Match(const LaserMap& map, const Pose2& predicted,
                                   const std::vector<Eigen::Vector2f>& points_robot,
                                   const std::vector<float>& weights, bool try_narrow_first,
                                   const std::vector<Eigen::Vector2f>* refinement_points) const {
  int narrow_candidates = 0;
  if (try_narrow_first && options_.narrow_linear_search_window_meters > 0.0 &&
      options_.narrow_angular_search_window_radians > 0.0) {
    ScanMatchResult narrow = MatchOnce(map, predicted, points_robot, weights, refinement_points,
                                       options_.narrow_linear_search_window_meters,
                                       options_.narrow_angular_search_window_radians,
                                       options_.second_mode_exclusion_meters, options_.second_mode_exclusion_radians);
    if (narrow.converged && narrow.score >= options_.narrow_accept_score &&
        !OnWindowBorder(predicted, narrow.pose, options_.narrow_linear_search_window_meters,
                        options_.narrow_angular_search_window_radians)) {
      return narrow;
    }
    narrow_candidates = narrow.candidates_scored;
  }
  const bool wide_modes =
      options_.wide_second_mode_exclusion_meters > 0 || options_.wide_second_mode_exclusion_radians > 0;
  const double exclusion_meters =
      wide_modes ? options_.wide_second_mode_exclusion_meters : options_.second_mode_exclusion_meters;
  const double exclusion_radians =
      wide_modes ? options_.wide_second_mode_exclusion_radians : options_.second_mode_exclusion_radians;
  const double min_ratio = wide_modes ? options_.wide_second_mode_min_score_ratio : 0.0;
  ScanMatchResult result = MatchOnce(map, predicted, points_robot, weights, refinement_points,
                                     options_.linear_search_window_meters,
                                     options_.angular_search_window_radians, exclusion_meters, exclusion_radians,
                                     min_ratio);
  result.wide_search = true;
  result.candidates_scored += narrow_candidates;
  const bool wider = options_.fallback_linear_search_window_meters > options_.linear_search_window_meters ||
                     options_.fallback_angular_search_window_radians > options_.angular_search_window_radians;
  // A best pose on the border of the window may be the clipped side of a peak outside it.
  const bool on_border = OnWindowBorder(predicted, result.pose, options_.linear_search_window_meters,
                                        options_.angular_search_window_radians);
  if (wider && !points_robot.empty() &&
      (!result.converged || result.score < options_.fallback_below_score || on_border)) {
    // Its windows hold the full search's, on the same lattice of poses: its discrete best scores
    // at least what it scores the full search's best pose, which is the full search's score up
    // to the points only the wider window keeps (Discretize), each on a cell of value 0 at that
    // pose, whose code stands for 0 to within half a code step (BuildPyramid). So its branch and
    // bound starts at the full search's best less one code step: the blocks that cannot score
    // above that are pruned (MIT CSAIL: 95 fallbacks were 12% of the run), and its best is the
    // one it finds without.
    ScanMatchResult fallback =
        MatchOnce(map, predicted, points_robot, weights, refinement_points,
                  std::max(options_.linear_search_window_meters, options_.fallback_linear_search_window_meters),
                  std::max(options_.angular_search_window_radians, options_.fallback_angular_search_window_radians),
                  exclusion_meters, exclusion_radians, min_ratio, 0.0,
                  result.converged ? result.correlative_score : -std::numeric_limits<double>::infinity());
    fallback.candidates_scored += result.candidates_scored;
    fallback.wide_search = true;
    if (fallback.converged && (!result.converged || fallback.score > result.score)) return fallback;
  }
  return result;
}

ScanMatchResult ScanMatcher::MatchWithinWindow(const LaserMap& map, const Pose2& predicted,
                                               const std::vector<Eigen::Vector2f>& points_robot,
                                               double linear_window_meters, double angular_window_radians,
                                               const std::vector<float>& weights, double min_score,
                                               const std::vector<Eigen::Vector2f>* refinement_points) const {
  CHECK(linear_window_meters >= 0 && angular_window_radians >= 0 && angular_window_radians <= M_PI)
      << "bad window " << linear_window_meters << " m, " << angular_window_radians << " rad";
  return MatchOnce(map, predicted, points_robot, weights, refinement_points, linear_window_meters, angular_window_radians,
                   options_.second_mode_exclusion_meters, options_.second_mode_exclusion_radians, 0.0, min_score);
}

ScanMatchResult ScanMatcher::MatchOnce(const LaserMap& map, const Pose2& predicted,
                                       const std::vector<Eigen::Vector2f>& points_robot,
                                       const std::vector<float>& weights,
                                       const std::vector<Eigen::Vector2f>* refinement_points, double linear_window_meters,
                                       double angular_window_radians, double second_mode_exclusion_meters,
                                       double second_mode_exclusion_radians, double second_mode_min_score_ratio,
                                       double min_score, double to_beat) const {
  CHECK(weights.empty() || weights.size() == points_robot.size())
      << weights.size() << " weights for " << points_robot.size() << " points";
  CHECK(refinement_points == nullptr || (weights.empty() && !refinement_points->empty()))
      << "refinement points need empty weights and at least one point";
  const LikelihoodField& field = map.field();
  ScanMatchResult result;
  result.pose = predicted;
  if (points_robot.empty()) {
    result.message = "scan has no valid points";
    return result;
  }
  if (field.geometry().num_cells() == 0) {
    result.message = "map is empty";
    return result;
  }
  const int depth = options_.branch_and_bound_depth;
  const int block = 1 << depth;
  ScanMatcherOptions windows = options_;
  windows.linear_search_window_meters = linear_window_meters;
  windows.angular_search_window_radians = angular_window_radians;
  Pyramid& pyramid = ThreadScratch();
  Discretize(windows, map, predicted, points_robot, weights, block, &pyramid.search, &pyramid.cells);
  const DiscretizedSearch& s = pyramid.search;
  // The search weighs walls; the refinement (cost, acceptance, information, profile) only with
  // wall_weight_in_refinement (see the option).
  const LikelihoodField* search_wall_field = WallFieldFor(options_, map);
  const LikelihoodField* wall_field = options_.wall_weight_in_refinement ? search_wall_field : nullptr;
  const double wall_weight = options_.wall_weight;
  BuildPyramid(map, s, depth, options_.free_space_penalty, search_wall_field, static_cast<float>(wall_weight),
               &pyramid);
  const SearchContext context = MakeContext(options_, map, s, pyramid, weights, points_robot.size());

  std::vector<Candidate> top;
  const size_t blocks_per_side = static_cast<size_t>(2 * s.window_cells / block + 1);
  top.reserve(s.yaws.size() * blocks_per_side * blocks_per_side);  // one allocation, no regrowth
  for (int k = 0; k < static_cast<int>(s.yaws.size()); ++k) {
    for (int dy = -s.window_cells; dy <= s.window_cells; dy += block) {
      // Four neighbours along the row at a time, then the rest one by one.
      int dx = -s.window_cells;
      for (; dx + 3 * block <= s.window_cells; dx += 4 * block) {
        const int dxs[4] = {dx, dx + block, dx + 2 * block, dx + 3 * block};
        const int dys[4] = {dy, dy, dy, dy};
        float scores[4];
        context.ScoreFour(depth, k, dxs, dys, scores);
        for (int c = 0; c < 4; ++c) top.push_back({k, dxs[c], dy, scores[c]});
      }
      for (; dx <= s.window_cells; dx += block) top.push_back({k, dx, dy, context.Score(depth, k, dx, dy)});
    }
  }
  result.candidates_scored = static_cast<int>(top.size());
  const bool second_mode = second_mode_exclusion_meters > 0 || second_mode_exclusion_radians > 0;
  std::vector<Candidate> top_copy;
  if (second_mode) top_copy = top;
  // (to_beat less a code step: see Match's fallback.)
  const bool beating = to_beat - pyramid.step > options_.min_correlative_score;
  Candidate best{-1, 0, 0, static_cast<float>(beating ? to_beat - pyramid.step : options_.min_correlative_score)};
  BranchAndBound(context, top.data(), top.data() + top.size(), depth, &best, &result.candidates_scored);
  if (best.yaw_index < 0) {
    std::ostringstream msg;
    msg << "no candidate within ±" << linear_window_meters << " m, ±" << angular_window_radians << " rad scores ";
    if (beating) {
      msg << "above " << best.score << " (the full search's best less a code step)";
    } else {
      msg << ">= " << options_.min_correlative_score;
    }
    result.message = msg.str();
    return result;
  }
  const double r = field.geometry().resolution_meters();
  result.pose = Pose2(predicted.translation() + Eigen::Vector2d(best.dx, best.dy) * r, s.yaws[best.yaw_index]);
  result.correlative_score = best.score;
  result.converged = true;
  result.second_mode_pose = predicted;
  if (second_mode) {
    Exclusion exclusion;
    exclusion.around = &best;
    exclusion.cells = static_cast<int>(std::floor(second_mode_exclusion_meters / r));
    exclusion.radians = second_mode_exclusion_radians;
    // Blocks that cannot reach the least score asked for are pruned (the bound is an upper one).
    Candidate second{-1, 0, 0,
                     static_cast<float>(std::max(options_.min_correlative_score, second_mode_min_score_ratio * best.score))};
    BranchAndBound(context, top_copy.data(), top_copy.data() + top_copy.size(), depth, &second,
                   &result.candidates_scored, exclusion);
    if (second.yaw_index >= 0) {
      result.second_mode_correlative_score = second.score;
      result.second_mode_pose =
          Pose2(predicted.translation() + Eigen::Vector2d(second.dx, second.dy) * r, s.yaws[second.yaw_index]);
    }
  }

  // The refinement, and the information and score profile at its pose, on the refinement
  // points when given (see LocalSlamOptions::refine_on_middle_beams); the score on the
  // searched points, as the thresholds on it were set.
  const std::vector<Eigen::Vector2f>& refinement = refinement_points != nullptr ? *refinement_points : points_robot;
  if (options_.refine_with_ceres) {
    double pose[3] = {result.pose.x(), result.pose.y(), result.pose.theta()};
    ceres::Problem::Options problem_options;
    ceres::Problem problem(problem_options);
    std::vector<ceres::CostFunction*> refinement_costs;  // owned by `problem` (through their compressed costs)
    refinement_costs.push_back(
        CreateScanToLikelihoodFieldCost(field, refinement, weights, options_.refine_interpolation));
    problem.AddResidualBlock(CreateCompressedCost(refinement_costs.back()), nullptr, pose);
    // Paper §III-E: the wall channel as a second cost over the same points, each residual
    // weighted sqrt(wall_weight - 1): summed, (1 - L)^2 + (wall_weight - 1)(1 - L_wall)^2 per
    // point, wall_weight (1 - L)^2 on a wall (where L_wall = L), (1 - L)^2 away from walls
    // (where L_wall = 0 and its term is constant).
    std::vector<float> wall_weights;
    if (wall_field != nullptr) {
      wall_weights = WallResidualWeights(weights, refinement.size(), wall_weight);
      refinement_costs.push_back(
          CreateScanToLikelihoodFieldCost(*wall_field, refinement, wall_weights, options_.refine_interpolation));
      problem.AddResidualBlock(CreateCompressedCost(refinement_costs.back()), nullptr, pose);
    }
    ceres::Solver::Summary summary;
    ceres::Solve(RefinementSolverOptions(options_), &problem, &summary);
    const Pose2 refined(pose[0], pose[1], pose[2]);
    result.iterations = static_cast<int>(summary.iterations.size()) - 1;
    result.final_cost = summary.final_cost;
    // Keep the refinement only if it stayed near the discrete optimum and did not lower the
    // score (bilinear values, also when the refinement interpolated distances: measured, the
    // cost's own decrease as the test lets a sparse log's refinements wander, ACES 0.11 -> 4.1 m
    // against GMapping); otherwise the discrete pose is the better answer.
    const bool better = BilinearScore(map.field(), refined, refinement, weights, wall_field, wall_weight) >=
                        BilinearScore(map.field(), result.pose, refinement, weights, wall_field, wall_weight);
    if (summary.IsSolutionUsable() && better && (refined.translation() - result.pose.translation()).norm() < 4 * r) {
      result.pose = refined;
    }
    if (min_score > 0.0) {
      // The caller rejects this result: the information and the profile below would be unused.
      result.score = BilinearScore(map.field(), result.pose, points_robot, weights);
      if (result.score < min_score) return result;
    }
    // The information is J^T J of the values' cost in either case: its scale is what the
    // degeneracy tests and closure weights downstream are calibrated on.
    double p[3] = {result.pose.x(), result.pose.y(), result.pose.theta()};
    std::copy(p, p + 3, pose);
    // Each cost evaluated once at the pose, its rows in order: the Jacobian a ceres::Problem of
    // them would give (Problem::Evaluate), without building one.
    std::vector<std::unique_ptr<ceres::CostFunction>> values_costs;  // only when the refinement's cost is another
    std::vector<ceres::CostFunction*> information_costs = refinement_costs;
    if (options_.refine_interpolation != ScanCostInterpolation::kValues) {
      values_costs.emplace_back(
          CreateScanToLikelihoodFieldCost(field, refinement, weights, ScanCostInterpolation::kValues));
      if (wall_field != nullptr) {
        values_costs.emplace_back(
            CreateScanToLikelihoodFieldCost(*wall_field, refinement, wall_weights, ScanCostInterpolation::kValues));
      }
      information_costs.clear();
      for (const auto& cost : values_costs) information_costs.push_back(cost.get());
    }
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    std::vector<double> residuals, jacobian;
    for (ceres::CostFunction* cost : information_costs) {
      const int rows = cost->num_residuals();
      residuals.resize(rows);
      jacobian.resize(3 * static_cast<size_t>(rows));
      const double* parameters[1] = {pose};
      double* jacobians[1] = {jacobian.data()};
      if (!cost->Evaluate(parameters, residuals.data(), jacobians)) continue;  // (a scan cost does not fail)
      for (int row = 0; row < rows; ++row) {
        const Eigen::Vector3d j(jacobian[3 * row], jacobian[3 * row + 1], jacobian[3 * row + 2]);
        jtj += j * j.transpose();
      }
    }
    result.information = jtj;
    // The score's profile in kDirections directions over a half turn: the flattest is the weak
    // one, its angle refined by a parabola through its neighbours' drops.
    constexpr int kDirections = 16;
    const std::vector<Eigen::Vector2f> thinned = ProfilePoints(refinement, points_robot.size());
    const std::vector<Eigen::Vector2f>& profile = thinned.empty() ? refinement : thinned;
    const RotatedPoints rotated(result.pose.theta(), profile);
    const double at_match =
        BilinearScoreAt(map.field(), result.pose.x(), result.pose.y(), rotated, weights, wall_field, wall_weight);
    // The shifted poses' yaw, as a Pose2 of it would wrap it (WrapAngle can move a wrapped
    // angle by an ulp).
    const double shifted_yaw = WrapAngle(result.pose.theta());
    const bool same_yaw = shifted_yaw == result.pose.theta();
    const RotatedPoints rotated_wrapped = same_yaw ? RotatedPoints() : RotatedPoints(shifted_yaw, profile);
    const RotatedPoints& shifted_rotated = same_yaw ? rotated : rotated_wrapped;
    // The six shifted positions of each direction (±1, ±2, ±3 steps), all scored at once.
    constexpr int kShifts = 6;
    std::array<double, kDirections * kShifts> xs, ys, shifted_scores;
    for (int d = 0; d < kDirections; ++d) {
      const Eigen::Vector2d direction(std::cos(d * M_PI / kDirections), std::sin(d * M_PI / kDirections));
      int s = d * kShifts;
      for (int k = 1; k <= 3; ++k) {
        for (const double side : {-1.0, 1.0}) {
          const Eigen::Vector2d shifted =
              result.pose.translation() + side * k * options_.profile_step_meters * direction;
          xs[s] = shifted.x();
          ys[s] = shifted.y();
          ++s;
        }
      }
    }
    BilinearScoresAt(map.field(), xs.data(), ys.data(), kDirections * kShifts, shifted_rotated, weights, wall_field,
                     wall_weight, shifted_scores.data());
    std::array<double, kDirections> drops;
    for (int d = 0; d < kDirections; ++d) {
      double best_shifted = -std::numeric_limits<double>::infinity();
      for (int s = d * kShifts; s < (d + 1) * kShifts; ++s) best_shifted = std::max(best_shifted, shifted_scores[s]);
      drops[d] = at_match - best_shifted;
    }
    const int weakest = static_cast<int>(std::min_element(drops.begin(), drops.end()) - drops.begin());
    const double before = drops[(weakest + kDirections - 1) % kDirections];
    const double after = drops[(weakest + 1) % kDirections];
    const double curvature = before - 2 * drops[weakest] + after;
    const double offset = curvature > 0 ? std::clamp(0.5 * (before - after) / curvature, -0.5, 0.5) : 0.0;
    const double angle = (weakest + offset) * M_PI / kDirections;
    result.weak_direction = Eigen::Vector2d(std::cos(angle), std::sin(angle));
    if (options_.weak_direction_snap_radians > 0) {
      if (const std::optional<Eigen::Vector2d> axis = WallAxis(profile)) {
        Eigen::Vector2d along = Eigen::Rotation2Dd(result.pose.theta()) * *axis;
        if (along.dot(result.weak_direction) < 0) along = -along;
        if (std::acos(std::min(1.0, along.dot(result.weak_direction))) <= options_.weak_direction_snap_radians) {
          result.weak_direction = along;
        }
      }
    }
    result.weak_direction_score_drop = drops[weakest];
    result.strong_direction_score_drop = *std::max_element(drops.begin(), drops.end());
  }
  result.score = BilinearScore(map.field(), result.pose, points_robot, weights);
  return result;
}

}  // namespace hetslam
