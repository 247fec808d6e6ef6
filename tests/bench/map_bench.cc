// Map and scan-matching costs of the walking skeleton, on seeded synthetic rooms.
//
// World: a W × H m room ([0, W] × [0, H]) with seeded rotated square pillars in its interior;
// the robot drives a loop 1.5 m inside the walls. Every scan is 360 beams at 1° over the full
// circle, ray-cast against the wall segments, 30 m maximum range, 1 cm seeded Gaussian range
// noise. Scans are inserted at their true poses; grid and field use the default options
// (5 cm cells, sigma 0.10 m, window 0.30 m).
//
//   BM_LaserMapInsertScan/N        LaserMap::InsertScan of one 360-beam scan (ray casting,
//                                  log-odds and hit-point update, incremental likelihood
//                                  field update) into a map already holding N scans of the
//                                  20 × 12 m room; items/s = beams/s. Copying the map back to
//                                  its N-scan state between iterations is not timed.
//   BM_LikelihoodFieldIncrementalUpdate/W/H
//                                  LikelihoodField::ApplyChanges for the change set of one
//                                  scan inserted into a W × H room mapped by one loop
//                                  (restoring the field between iterations is not timed).
//   BM_LikelihoodFieldRebuildAll/W/H
//                                  LikelihoodField::RebuildAll over the whole grid after the
//                                  same change set: what every scan would cost without the
//                                  incremental update. Compare the two at equal W/H.
//   BM_ScanMatch/<window>/<points> ScanMatcher::Match (branch and bound + Ceres refinement)
//                                  of a scan whose prediction is off by 0.3 m and 10°, in the
//                                  20 × 12 m room mapped by 60 scans. Windows: ±0.4 m / ±15°,
//                                  and ±1.2 m / ±40° (hetslam_run's --linear_window /
//                                  --angular_window_deg defaults; ScanMatcherOptions' own
//                                  defaults are the same, ±1.2 m / ±0.70 rad).
//                                  Points: all 360, or thinned to one per 0.2 m voxel as
//                                  hetslam_run matches them (--matching_voxel).
//   BM_ScanMatchNoCeres/<window>/<points>
//                                  the same with refine_with_ceres = false: branch-and-bound
//                                  search only, directly comparable with brute force.
//   BM_ScanMatchBruteForce/<window>/<points>
//                                  ScanMatcher::BruteForceSearch: every discrete candidate of
//                                  the same window scored, same discretisation and result.
//   BM_ScanCostEvaluate/<call>     the refinement's cost (factors/scan_cost.h, interpolated
//                                  distances as the matcher refines) over the voxel-thinned
//                                  scan at the truth on the same map: residuals alone at a new
//                                  pose (call 0), residuals and Jacobian at a new pose (1), or
//                                  both at one pose as Ceres' trust region evaluates an accepted
//                                  step (2: the second call reuses the first's samples). The new
//                                  pose is 0.1 mm away: every point stays in its cell and its 16
//                                  cells are not read again, as in 87–89% of the real logs'
//                                  evaluations; call 3 is call 1 at poses a cell (5 cm) apart,
//                                  every point's cells read again.
//   BM_ScanRefine/<compressed>     a Ceres refinement of all 360 points from 2 cm and 1 degree
//                                  off, over the tall scan cost (0) or its compressed form
//                                  (1, factors/compressed_cost.h): the same steps.
//   BM_DropWeakOccupiedCells/N     the rendered maps' tail rule (see its comment below).
//   BM_SubmapFreeze/N, BM_SubmapLoopMatch/<frozen>/N
//                                  the finished-submap store: freezing a submap of N scans,
//                                  and loop-closure matching against it frozen or not (see
//                                  their comments below).
//   BM_SubmapCoveredShare/N        the revisit test (issue #15): how much of a finished
//                                  submap another covers (see its comment below).
// Counters: `beams`, `grid_cells`, `changed_cells`, `points`, `candidates` (scored),
// `error_cm` / `error_deg` (matched pose minus truth; brute force and branch and bound without
// Ceres must report the same pose, since the search is exact for its discretisation).
//
// Run: build/tests/bench_map_bench --benchmark_min_time=0.2
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "Eigen/Core"
#include "benchmark/benchmark.h"
#include "ceres/ceres.h"
#include "core/laser_map.h"
#include "core/laser_scan.h"
#include "core/likelihood_field.h"
#include "core/occupancy_grid.h"
#include "core/se2.h"
#include "factors/compressed_cost.h"
#include "factors/scan_cost.h"
#include "frontends/loop_closer.h"
#include "frontends/scan_matcher.h"
#include "frontends/submap_graph.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kBeams = 360;
constexpr double kMaxRangeMeters = 30.0;
constexpr double kRangeNoiseMeters = 0.01;
constexpr double kLoopInsetMeters = 1.5;

struct Segment {
  Eigen::Vector2d a, b;
};

// A synthetic room: wall segments, the robot's poses along its loop and the scan at each.
struct SyntheticRoom {
  double width_meters = 0.0;
  double height_meters = 0.0;
  std::vector<Segment> walls;
  std::vector<Pose2> poses;                            // world_T_robot
  std::vector<std::vector<Eigen::Vector2f>> scans;     // points in the robot frame
};

// Outer walls plus one seeded rotated square pillar per ~8 m² of the interior that lies more
// than 2.5 m from the walls (so pillars keep >= 1 m from the loop at 1.5 m).
std::vector<Segment> MakeWalls(double width, double height, std::mt19937* rng) {
  std::vector<Segment> walls;
  const std::vector<Eigen::Vector2d> corners = {{0, 0}, {width, 0}, {width, height}, {0, height}};
  for (int i = 0; i < 4; ++i) walls.push_back({corners[i], corners[(i + 1) % 4]});
  const double x0 = 2.5, x1 = width - 2.5, y0 = 2.5, y1 = height - 2.5;
  if (x1 <= x0 || y1 <= y0) return walls;
  const int num_pillars = static_cast<int>((x1 - x0) * (y1 - y0) / 8.0) + 1;
  std::uniform_real_distribution<double> ux(x0, x1), uy(y0, y1), half(0.15, 0.5), yaw(0.0, M_PI / 2);
  for (int p = 0; p < num_pillars; ++p) {
    const Pose2 world_T_pillar(ux(*rng), uy(*rng), yaw(*rng));
    const double h = half(*rng);
    const std::vector<Eigen::Vector2d> local = {{-h, -h}, {h, -h}, {h, h}, {-h, h}};
    for (int i = 0; i < 4; ++i) walls.push_back({world_T_pillar * local[i], world_T_pillar * local[(i + 1) % 4]});
  }
  return walls;
}

// 360 beams at 1° from -180°, nearest wall hit, seeded range noise; beams beyond the maximum
// range are dropped (as the pipeline drops them).
std::vector<Eigen::Vector2f> CastScan(const std::vector<Segment>& walls, const Pose2& world_T_robot,
                                      std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, kRangeNoiseMeters);
  std::vector<Eigen::Vector2f> points;
  points.reserve(kBeams);
  const Eigen::Vector2d origin = world_T_robot.translation();
  for (int i = 0; i < kBeams; ++i) {
    const double angle = -M_PI + i * kDeg;
    const Eigen::Vector2d dir(std::cos(world_T_robot.theta() + angle), std::sin(world_T_robot.theta() + angle));
    double best = std::numeric_limits<double>::infinity();
    for (const Segment& s : walls) {
      const Eigen::Vector2d e = s.b - s.a;
      const double denom = dir.x() * e.y() - dir.y() * e.x();
      if (std::abs(denom) < 1e-12) continue;
      const Eigen::Vector2d w = s.a - origin;
      const double t = (w.x() * e.y() - w.y() * e.x()) / denom;
      const double u = (w.x() * dir.y() - w.y() * dir.x()) / denom;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    if (!(best <= kMaxRangeMeters)) continue;
    const double r = best + noise(*rng);
    points.emplace_back(static_cast<float>(r * std::cos(angle)), static_cast<float>(r * std::sin(angle)));
  }
  return points;
}

// Pose at arc length s along the rectangular loop inset from the walls, heading along it.
Pose2 LoopPose(double width, double height, double s) {
  const double w = width - 2 * kLoopInsetMeters, h = height - 2 * kLoopInsetMeters;
  s = std::fmod(s, 2 * (w + h));
  const double a = kLoopInsetMeters;
  if (s < w) return Pose2(a + s, a, 0.0);
  if ((s -= w) < h) return Pose2(a + w, a + s, M_PI / 2);
  if ((s -= h) < w) return Pose2(a + w - s, a + h, M_PI);
  s -= w;
  return Pose2(a, a + h - s, -M_PI / 2);
}

// `num_scans` poses `step_meters` apart along the loop, each jittered by seeded noise
// (±0.2 m lateral, 0.1 rad heading), and their scans.
SyntheticRoom MakeRoom(double width, double height, int num_scans, double step_meters, uint32_t seed) {
  std::mt19937 rng(seed);
  SyntheticRoom room;
  room.width_meters = width;
  room.height_meters = height;
  room.walls = MakeWalls(width, height, &rng);
  std::uniform_real_distribution<double> lateral(-0.2, 0.2);
  std::normal_distribution<double> heading(0.0, 0.1);
  for (int k = 0; k < num_scans; ++k) {
    const Pose2 on_loop = LoopPose(width, height, k * step_meters);
    const Pose2 pose = on_loop * Pose2(0.0, lateral(rng), heading(rng));
    room.poses.push_back(pose);
    room.scans.push_back(CastScan(room.walls, pose, &rng));
  }
  return room;
}

double LoopLength(double width, double height) {
  return 2 * (width - 2 * kLoopInsetMeters + height - 2 * kLoopInsetMeters);
}

std::vector<Eigen::Vector2d> ToWorld(const Pose2& world_T_robot, const std::vector<Eigen::Vector2f>& points) {
  std::vector<Eigen::Vector2d> world;
  world.reserve(points.size());
  for (const Eigen::Vector2f& p : points) world.push_back(world_T_robot * p.cast<double>());
  return world;
}

// ---------------------------------------------------------------------------------------
// LaserMap::InsertScan

constexpr int kMaxInsertScans = 1000;

const SyntheticRoom& InsertRoom() {
  static const SyntheticRoom* room = new SyntheticRoom(MakeRoom(20.0, 12.0, kMaxInsertScans + 1, 0.3, 7));
  return *room;
}

// The map holding the first `n` scans of InsertRoom(), built once per n.
const LaserMap& MapWithScans(int n) {
  static auto* cache = new std::map<int, std::unique_ptr<LaserMap>>;
  std::unique_ptr<LaserMap>& map = (*cache)[n];
  if (map == nullptr) {
    const SyntheticRoom& room = InsertRoom();
    map = std::make_unique<LaserMap>(OccupancyGridOptions(), LikelihoodFieldOptions());
    for (int k = 0; k < n; ++k) map->InsertScan(room.poses[k], Eigen::Vector2d::Zero(), room.scans[k]);
  }
  return *map;
}

void BM_LaserMapInsertScan(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  CHECK_LE(n, kMaxInsertScans) << "room has " << kMaxInsertScans + 1 << " scans";
  const SyntheticRoom& room = InsertRoom();
  const LaserMap& base = MapWithScans(n);
  const std::vector<Eigen::Vector2f>& scan = room.scans[n];
  LaserMap map = base;
  for (auto _ : state) {
    state.PauseTiming();
    map = base;  // same sizes: reuses the buffers, nothing allocated
    state.ResumeTiming();
    map.InsertScan(room.poses[n], Eigen::Vector2d::Zero(), scan);
    benchmark::ClobberMemory();
  }
  CHECK_EQ(map.num_scans_inserted(), n + 1);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(scan.size()));
  state.counters["beams"] = static_cast<double>(scan.size());
  state.counters["grid_cells"] = map.grid().geometry().num_cells();
}
BENCHMARK(BM_LaserMapInsertScan)->Arg(1)->Arg(10)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);

//   BM_DropWeakOccupiedCells/N    OccupancyGrid::DropWeakOccupiedCells(0.2), the noise tail
//                                 behind the walls left out of a rendered map (SubmapGraph::
//                                 RenderMap does it once per map written), on the grid of the
//                                 20 × 12 m room mapped by N scans (copying the grid back is not
//                                 timed). Counters: occupied cells before, cells dropped.
void BM_DropWeakOccupiedCells(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  CHECK_LE(n, kMaxInsertScans) << "room has " << kMaxInsertScans + 1 << " scans";
  const OccupancyGrid& base = MapWithScans(n).grid();
  OccupancyGrid grid = base;
  int dropped = 0;
  for (auto _ : state) {
    state.PauseTiming();
    grid = base;
    state.ResumeTiming();
    dropped = grid.DropWeakOccupiedCells(0.2);
    benchmark::ClobberMemory();
  }
  int occupied = 0;
  for (int i = 0; i < base.geometry().num_cells(); ++i) occupied += base.IsOccupied(i) ? 1 : 0;
  state.counters["grid_cells"] = base.geometry().num_cells();
  state.counters["occupied"] = occupied;
  state.counters["dropped"] = dropped;
}
BENCHMARK(BM_DropWeakOccupiedCells)->Arg(10)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);

// ---------------------------------------------------------------------------------------
// LikelihoodField: incremental update vs full rebuild, same change set.

// A W × H room mapped by one loop of scans 0.5 m apart (grid and field kept separately so the
// change set of the next scan can be replayed), plus that next scan's change set.
struct FieldFixture {
  OccupancyGrid grid_after{OccupancyGridOptions()};  // after the next scan
  std::unique_ptr<LikelihoodField> field_before;     // in step with the grid before it
  std::vector<int> changed_cells;
};

const FieldFixture& FieldFixtureFor(int width, int height) {
  static auto* cache = new std::map<std::pair<int, int>, std::unique_ptr<FieldFixture>>;
  std::unique_ptr<FieldFixture>& fixture = (*cache)[{width, height}];
  if (fixture != nullptr) return *fixture;
  const double step = 0.5;
  const int loop_scans = static_cast<int>(LoopLength(width, height) / step);
  const SyntheticRoom room = MakeRoom(width, height, loop_scans + 1, step, 11);
  OccupancyGrid grid{OccupancyGridOptions()};
  auto field = std::make_unique<LikelihoodField>(LikelihoodFieldOptions());
  std::vector<int> changed;
  for (int k = 0; k < loop_scans; ++k) {
    changed.clear();
    grid.InsertScan(room.poses[k].translation(), ToWorld(room.poses[k], room.scans[k]), &changed);
    field->ApplyChanges(grid, changed);
  }
  fixture = std::make_unique<FieldFixture>();
  fixture->grid_after = grid;
  fixture->grid_after.InsertScan(room.poses[loop_scans].translation(),
                                 ToWorld(room.poses[loop_scans], room.scans[loop_scans]), &fixture->changed_cells);
  CHECK(fixture->grid_after.geometry().num_cells() == grid.geometry().num_cells() &&
        fixture->grid_after.geometry().origin() == grid.geometry().origin())
      << "the change-set scan grew the grid; the two benchmarks would not compare like with like";
  fixture->field_before = std::move(field);
  return *fixture;
}

void BM_LikelihoodFieldIncrementalUpdate(benchmark::State& state) {
  const FieldFixture& fixture = FieldFixtureFor(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  LikelihoodField field = *fixture.field_before;
  for (auto _ : state) {
    state.PauseTiming();
    field = *fixture.field_before;
    state.ResumeTiming();
    field.ApplyChanges(fixture.grid_after, fixture.changed_cells);
    benchmark::ClobberMemory();
  }
  state.counters["grid_cells"] = fixture.grid_after.geometry().num_cells();
  state.counters["changed_cells"] = static_cast<double>(fixture.changed_cells.size());
}
BENCHMARK(BM_LikelihoodFieldIncrementalUpdate)
    ->Args({10, 8})->Args({20, 12})->Args({40, 30})->ArgNames({"W", "H"})->Unit(benchmark::kMicrosecond);

void BM_LikelihoodFieldRebuildAll(benchmark::State& state) {
  const FieldFixture& fixture = FieldFixtureFor(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  LikelihoodField field = *fixture.field_before;
  field.ApplyChanges(fixture.grid_after, fixture.changed_cells);
  const std::vector<float> incremental = field.values().Dense();
  for (auto _ : state) {
    field.RebuildAll();
    benchmark::ClobberMemory();
  }
  // The incremental table is exact (likelihood_field.h); a mismatch means the two
  // benchmarks did not compute the same thing.
  CHECK(field.values().Dense() == incremental) << "RebuildAll and ApplyChanges disagree";
  state.counters["grid_cells"] = fixture.grid_after.geometry().num_cells();
  state.counters["changed_cells"] = static_cast<double>(fixture.changed_cells.size());
}
BENCHMARK(BM_LikelihoodFieldRebuildAll)
    ->Args({10, 8})->Args({20, 12})->Args({40, 30})->ArgNames({"W", "H"})->Unit(benchmark::kMicrosecond);

// ---------------------------------------------------------------------------------------
// ScanMatcher

struct MatchFixture {
  std::unique_ptr<LaserMap> map;
  Pose2 truth;                                // world_T_robot of the query scan
  Pose2 predicted;                            // truth offset by 0.3 m and 10°
  std::vector<Eigen::Vector2f> points;        // all 360
  std::vector<Eigen::Vector2f> voxel_points;  // one per 0.2 m voxel
};

const MatchFixture& GetMatchFixture() {
  static const MatchFixture* fixture = [] {
    auto* f = new MatchFixture;
    const SyntheticRoom room = MakeRoom(20.0, 12.0, 60, 0.3, 23);
    f->map = std::make_unique<LaserMap>(OccupancyGridOptions(), LikelihoodFieldOptions());
    for (size_t k = 0; k < room.poses.size(); ++k) f->map->InsertScan(room.poses[k], Eigen::Vector2d::Zero(), room.scans[k]);
    // A new scan between two mapped poses, with its own noise.
    f->truth = room.poses[30] * Pose2(0.12, 0.07, 0.05);
    std::mt19937 rng(29);
    f->points = CastScan(room.walls, f->truth, &rng);
    f->voxel_points = VoxelFilter(f->points, 0.2f);
    const double d = 0.3 / std::sqrt(2.0);
    f->predicted = Pose2(f->truth.translation() + Eigen::Vector2d(d, -d), f->truth.theta() + 10 * kDeg);
    return f;
  }();
  return *fixture;
}

enum class Points { kAll, kVoxel };

ScanMatcherOptions WindowOptions(double linear_meters, double angular_degrees, bool refine) {
  ScanMatcherOptions options;
  options.linear_search_window_meters = linear_meters;
  options.angular_search_window_radians = angular_degrees * kDeg;
  options.refine_with_ceres = refine;
  return options;
}

void ReportMatch(benchmark::State& state, const MatchFixture& f, const std::vector<Eigen::Vector2f>& points,
                 const ScanMatchResult& result) {
  CHECK(result.converged) << "the benchmark scan must match: " << result.message;
  state.counters["points"] = static_cast<double>(points.size());
  state.counters["candidates"] = result.candidates_scored;
  state.counters["error_cm"] = 100.0 * (result.pose.translation() - f.truth.translation()).norm();
  state.counters["error_deg"] = std::abs(WrapAngle(result.pose.theta() - f.truth.theta())) / kDeg;
}

void RunMatch(benchmark::State& state, double linear_meters, double angular_degrees, Points which, bool refine,
              bool brute_force) {
  const MatchFixture& f = GetMatchFixture();
  const std::vector<Eigen::Vector2f>& points = which == Points::kAll ? f.points : f.voxel_points;
  const ScanMatcher matcher(WindowOptions(linear_meters, angular_degrees, refine));
  ScanMatchResult result;
  for (auto _ : state) {
    result = brute_force ? matcher.BruteForceSearch(*f.map, f.predicted, points)
                         : matcher.Match(*f.map, f.predicted, points);
    benchmark::DoNotOptimize(result.pose);
  }
  ReportMatch(state, f, points, result);
}

void BM_ScanMatch(benchmark::State& state, double linear_meters, double angular_degrees, Points which) {
  RunMatch(state, linear_meters, angular_degrees, which, /*refine=*/true, /*brute_force=*/false);
}
BENCHMARK_CAPTURE(BM_ScanMatch, window_0.4m_15deg/360_points, 0.4, 15.0, Points::kAll)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ScanMatch, window_1.2m_40deg/360_points, 1.2, 40.0, Points::kAll)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ScanMatch, window_1.2m_40deg/voxel_0.2m_points, 1.2, 40.0, Points::kVoxel)
    ->Unit(benchmark::kMillisecond);

void BM_ScanMatchNoCeres(benchmark::State& state, double linear_meters, double angular_degrees, Points which) {
  RunMatch(state, linear_meters, angular_degrees, which, /*refine=*/false, /*brute_force=*/false);
}
BENCHMARK_CAPTURE(BM_ScanMatchNoCeres, window_0.4m_15deg/360_points, 0.4, 15.0, Points::kAll)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ScanMatchNoCeres, window_1.2m_40deg/360_points, 1.2, 40.0, Points::kAll)
    ->Unit(benchmark::kMillisecond);

void BM_ScanMatchBruteForce(benchmark::State& state, double linear_meters, double angular_degrees, Points which) {
  RunMatch(state, linear_meters, angular_degrees, which, /*refine=*/false, /*brute_force=*/true);
}
BENCHMARK_CAPTURE(BM_ScanMatchBruteForce, window_0.4m_15deg/360_points, 0.4, 15.0, Points::kAll)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ScanMatchBruteForce, window_1.2m_40deg/360_points, 1.2, 40.0, Points::kAll)
    ->Unit(benchmark::kMillisecond);

void BM_ScanCostEvaluate(benchmark::State& state) {
  const MatchFixture& f = GetMatchFixture();
  const std::unique_ptr<ceres::CostFunction> cost(
      CreateScanToLikelihoodFieldCost(f.map->field(), f.voxel_points, {}, ScanCostInterpolation::kDistances));
  const int call = static_cast<int>(state.range(0));
  std::vector<double> residuals(cost->num_residuals()), jacobian(3 * residuals.size());
  double* jacobians[1] = {jacobian.data()};
  double pose[3] = {f.truth.x(), f.truth.y(), f.truth.theta()};
  const double* parameters[1] = {pose};
  double nudge = call == 3 ? f.map->field().geometry().resolution_meters() : 1e-4;
  for (auto _ : state) {
    // A new pose every iteration (its samples are not the last call's).
    pose[0] += nudge;
    nudge = -nudge;
    if (call == 0 || call == 2) CHECK(cost->Evaluate(parameters, residuals.data(), nullptr));
    if (call != 0) CHECK(cost->Evaluate(parameters, residuals.data(), jacobians));
    benchmark::DoNotOptimize(residuals.data());
    benchmark::DoNotOptimize(jacobian.data());
  }
  state.counters["points"] = static_cast<double>(f.voxel_points.size());
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(f.voxel_points.size()));
}
BENCHMARK(BM_ScanCostEvaluate)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->Unit(benchmark::kMicrosecond);

// A Ceres refinement as the matcher runs it (dense QR, interpolated distances), of all 360
// points from 2 cm and 1 degree off the truth, over the tall scan cost (0: N residuals) or
// through factors/compressed_cost.h (1: the same steps, 4 residuals).
void BM_ScanRefine(benchmark::State& state) {
  const MatchFixture& f = GetMatchFixture();
  const bool compressed = state.range(0) != 0;
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 20;
  options.function_tolerance = 1e-6;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  double error_cm = 0.0;
  for (auto _ : state) {
    double pose[3] = {f.truth.x() + 0.02, f.truth.y(), f.truth.theta() + M_PI / 180.0};
    ceres::Problem problem;
    ceres::CostFunction* cost =
        CreateScanToLikelihoodFieldCost(f.map->field(), f.points, {}, ScanCostInterpolation::kDistances);
    problem.AddResidualBlock(compressed ? CreateCompressedCost(cost) : cost, nullptr, pose);
    ceres::Solve(options, &problem, &summary);
    error_cm = 100.0 * std::hypot(pose[0] - f.truth.x(), pose[1] - f.truth.y());
    benchmark::DoNotOptimize(pose);
  }
  state.counters["points"] = static_cast<double>(f.points.size());
  state.counters["iterations"] = static_cast<double>(summary.iterations.size() - 1);
  state.counters["error_cm"] = error_cm;
}
BENCHMARK(BM_ScanRefine)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// ---------------------------------------------------------------------------------------
// Finished submaps: LaserMap::Freeze (crop, 16-bit values, sparse tiles) and loop-closure
// matching against the compact form versus the map it was.

// A submap as the front end finishes one: the first `n` scans of InsertRoom() (0.3 m apart)
// and a copy of it, frozen.
struct SubmapPair {
  const LaserMap* building = nullptr;
  std::unique_ptr<LaserMap> frozen;
};

const SubmapPair& SubmapWithScans(int n) {
  static auto* cache = new std::map<int, std::unique_ptr<SubmapPair>>;
  std::unique_ptr<SubmapPair>& pair = (*cache)[n];
  if (pair == nullptr) {
    pair = std::make_unique<SubmapPair>();
    pair->building = &MapWithScans(n);
    pair->frozen = std::make_unique<LaserMap>(*pair->building);
    pair->frozen->Freeze();
  }
  return *pair;
}

void ReportSubmapSizes(benchmark::State& state, const SubmapPair& pair) {
  const double cells = pair.building->grid().geometry().num_cells();
  const double kept = pair.frozen->grid().geometry().num_cells();
  state.counters["cells"] = cells;
  state.counters["kept_cells"] = kept;
  state.counters["bytes"] = static_cast<double>(pair.building->MemoryBytes());
  state.counters["frozen_bytes"] = static_cast<double>(pair.frozen->MemoryBytes());
  state.counters["frozen_bytes_per_cell"] = pair.frozen->MemoryBytes() / std::max(1.0, cells);
}

//   BM_SubmapFreeze/N    LaserMap::Freeze of the room mapped by N scans (copying the map back
//                        is not timed). Counters: cells before and after the crop, bytes
//                        (MemoryBytes) before and after, frozen bytes per cell of the original.
void BM_SubmapFreeze(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const SubmapPair& pair = SubmapWithScans(n);
  LaserMap map = *pair.building;
  for (auto _ : state) {
    state.PauseTiming();
    map = *pair.building;
    state.ResumeTiming();
    map.Freeze();
    benchmark::ClobberMemory();
  }
  ReportSubmapSizes(state, pair);
}
BENCHMARK(BM_SubmapFreeze)->Arg(10)->Arg(40)->Arg(100)->Unit(benchmark::kMillisecond);

//   BM_SubmapLoopMatch/<frozen>/N
//                        ScanMatcher::MatchWithinWindow with the loop closer's matcher
//                        (LoopCloserOptions::DefaultMatcherOptions: ±2 m, ±45°, depth 4, Ceres
//                        refinement) of a voxel-filtered scan 0.3 m / 10° off, against the
//                        N-scan submap while it is built (frozen = 0) and frozen (frozen = 1):
//                        what the compact form costs or saves per loop search.
void BM_SubmapLoopMatch(benchmark::State& state) {
  const bool frozen = state.range(0) != 0;
  const int n = static_cast<int>(state.range(1));
  const SubmapPair& pair = SubmapWithScans(n);
  const LaserMap& map = frozen ? *pair.frozen : *pair.building;
  const SyntheticRoom& room = InsertRoom();
  const Pose2 truth = room.poses[n / 2] * Pose2(0.12, 0.07, 0.05);
  std::mt19937 rng(31);
  const std::vector<Eigen::Vector2f> points = VoxelFilter(CastScan(room.walls, truth, &rng), 0.2f);
  const double d = 0.3 / std::sqrt(2.0);
  const Pose2 predicted(truth.translation() + Eigen::Vector2d(d, -d), truth.theta() + 10 * kDeg);
  const ScanMatcherOptions options = LoopCloserOptions::DefaultMatcherOptions();
  const ScanMatcher matcher(options);
  ScanMatchResult result;
  for (auto _ : state) {
    result = matcher.MatchWithinWindow(map, predicted, points, options.linear_search_window_meters,
                                       options.angular_search_window_radians);
    benchmark::DoNotOptimize(result.pose);
  }
  CHECK(result.converged) << "the benchmark scan must match: " << result.message;
  state.counters["error_cm"] = 100.0 * (result.pose.translation() - truth.translation()).norm();
  state.counters["candidates"] = result.candidates_scored;
  ReportSubmapSizes(state, pair);
}
BENCHMARK(BM_SubmapLoopMatch)
    ->Args({0, 40})->Args({1, 40})->Args({0, 100})->Args({1, 100})->ArgNames({"frozen", "N"})
    ->Unit(benchmark::kMillisecond);

//   BM_SubmapReachableBound/N
//                        ReachableScoreBound (frontends/scan_matcher.h) of the same scan against
//                        the frozen N-scan submap within the loop closer's typical drift gate
//                        (0.6 m, 0.2 rad): what deciding that a loop search cannot succeed costs,
//                        against BM_SubmapLoopMatch's price of running it. Counter: the bound.
void BM_SubmapReachableBound(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const SubmapPair& pair = SubmapWithScans(n);
  const SyntheticRoom& room = InsertRoom();
  const Pose2 truth = room.poses[n / 2] * Pose2(0.12, 0.07, 0.05);
  std::mt19937 rng(31);
  const std::vector<Eigen::Vector2f> points = VoxelFilter(CastScan(room.walls, truth, &rng), 0.2f);
  double bound = 0.0;
  for (auto _ : state) {
    bound = ReachableScoreBound(*pair.frozen, truth, points, {}, 0.6, 0.2);
    benchmark::DoNotOptimize(bound);
  }
  state.counters["bound"] = bound;
  state.counters["points"] = static_cast<double>(points.size());
}
BENCHMARK(BM_SubmapReachableBound)->Arg(40)->Arg(100)->Unit(benchmark::kMicrosecond);

//   BM_SubmapCoveredShare/N
//                        SubmapGraph::CoveredShare (every occupied cell) of the frozen N-scan
//                        submap by the same map as an earlier submap placed 2 cm / 0.3° off:
//                        what the revisit test costs each time a submap finishes
//                        (OnlineEstimatorOptions::retire_revisited_share). Counter: the share.
void BM_SubmapCoveredShare(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const SubmapPair& pair = SubmapWithScans(n);
  const auto frozen = std::make_shared<const LaserMap>(*pair.frozen);
  SubmapGraph graph{SubmapGraphOptions()};
  for (int i = 0; i < 2; ++i) {
    const Pose2 origin = i == 0 ? Pose2(0.02, 0.0, 0.3 * kDeg) : Pose2::Identity();
    LocalResult result;
    result.inserted = true;
    result.stamp_seconds = i;
    result.local_pose = origin;
    result.new_submaps.push_back({i, origin});
    result.insertions.push_back({i, Pose2::Identity()});
    result.finished = LocalResult::FinishedSubmap{i, frozen};
    graph.AddNode(0, std::move(result));
  }
  double share = 0.0;
  for (auto _ : state) {
    share = graph.CoveredShare({0, 1}, {{0, 0}}, 1);
    benchmark::DoNotOptimize(share);
  }
  state.counters["share"] = share;
}
BENCHMARK(BM_SubmapCoveredShare)->Arg(40)->Arg(100)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace hetslam

BENCHMARK_MAIN();
