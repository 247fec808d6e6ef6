// Tests of the scan-to-likelihood-field cost (factors/scan_cost.h): residuals worked out by hand
// from the header's formula, its Jacobian against numeric differences, and the way it pulls a
// scan towards a wall.
//
// The worlds are built with a LaserMap from known hit points, one scan seen from the origin.
// The grid lattice is world-aligned (core/occupancy_grid.cc: the origin is a multiple of the
// cell size), so world cell column k covers [k r, (k + 1) r) whatever the grid's origin.
#include "factors/scan_cost.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "ceres/ceres.h"
#include "ceres/cubic_interpolation.h"
#include "ceres/gradient_checker.h"
#include "core/laser_map.h"
#include "core/se2.h"
#include "factors/se2_manifold.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

using Block = std::array<double, 3>;  // [x, y, yaw] of world_T_robot

// Set here rather than taken from the option defaults, so that the hand values below do not
// move when the defaults do.
constexpr double kResolutionMeters = 0.05;
constexpr double kSigmaMeters = 0.10;
constexpr double kMaxDistanceMeters = 0.30;  // window radius ceil(0.30 / 0.05) = 6 cells
constexpr int kWindowCells = 6;
// The wall's hits lie 1.25 cm into cell column 10 ([0.50, 0.55) m), not at its centre, so the
// field's sub-cell hit points take part in every value.
constexpr double kWallXMeters = 0.5125;
constexpr int kWallColumn = 10;
// Residual tolerance: points are stored as float (a 0.3 m coordinate is off by up to ~1.5e-8 m,
// and the field's slope is at most 1 / sigma = 10 per metre) and so are field values (relative
// rounding 6e-8); with weights up to 2.5 / sqrt(3) both stay within a few 1e-7 in a residual.
constexpr double kResidualTolerance = 1e-6;

Block ToBlock(const Pose2& p) { return {p.x(), p.y(), p.theta()}; }

// A LaserMap holding one scan of `hits_map` (map frame) seen from the map origin, with the map
// frame at `world_T_map` (a pure translation in the equivariance test).
LaserMap MapFromHits(const std::vector<Eigen::Vector2f>& hits_map,
                     const Pose2& world_T_map = Pose2::Identity()) {
  OccupancyGridOptions grid_options;
  grid_options.resolution_meters = kResolutionMeters;
  LikelihoodFieldOptions field_options;
  field_options.sigma_meters = kSigmaMeters;
  field_options.max_distance_meters = kMaxDistanceMeters;
  LaserMap map(grid_options, field_options);
  map.InsertScan(world_T_map, Eigen::Vector2d::Zero(), hits_map);
  return map;
}

// One wall at x = kWallXMeters, one hit per row centre for rows -10..9 (y in [-0.5, 0.5) m).
// `transposed` swaps x and y: the wall y = kWallXMeters, whose field is the same table with
// rows and columns exchanged.
std::vector<Eigen::Vector2f> WallHits(bool transposed = false) {
  std::vector<Eigen::Vector2f> hits;
  for (int row = -10; row < 10; ++row) {
    const Eigen::Vector2f hit(static_cast<float>(kWallXMeters),
                              static_cast<float>((row + 0.5) * kResolutionMeters));
    hits.push_back(transposed ? Eigen::Vector2f(hit.y(), hit.x()) : hit);
  }
  return hits;
}

// Five isolated posts (one hit each, at various sub-cell offsets) around [0.2, 0.5]^2: each
// cell's nearest hit lies off its row and column, so the field varies along both axes there
// (next to a straight wall it is constant along the wall and a Jacobian entry is zero up to
// rounding, where a relative error means nothing).
std::vector<Eigen::Vector2f> PostHits() {
  return {{0.2625f, 0.2625f}, {0.4375f, 0.2375f}, {0.3375f, 0.4375f}, {0.5125f, 0.4125f}, {0.2375f, 0.4625f}};
}

// Field value at the centre of world cell column k, in a row the wall spans, by the formula of
// core/likelihood_field.h: the nearest hit is the one in the same row, d = |centre_x - wall x|;
// 0 when the wall column is outside the 6-cell window.
double WallFieldAtColumn(int k) {
  if (std::abs(k - kWallColumn) > kWindowCells) return 0.0;
  return std::exp(-std::abs((k + 0.5) * kResolutionMeters - kWallXMeters) / kSigmaMeters);
}

// Catmull-Rom interpolation from its definition: the cubic through p1 (t = 0) and p2 (t = 1)
// with slopes (p2 - p0) / 2 and (p3 - p1) / 2, written in the Hermite basis.
double CatmullRom(double p0, double p1, double p2, double p3, double t) {
  const double h00 = 2 * t * t * t - 3 * t * t + 1, h10 = t * t * t - 2 * t * t + t;
  const double h01 = -2 * t * t * t + 3 * t * t, h11 = t * t * t - t * t;
  return h00 * p1 + h10 * (p2 - p0) / 2 + h01 * p2 + h11 * (p3 - p1) / 2;
}

// Robot-frame points (float, as the cost takes them) that world_T_robot maps onto p_world.
std::vector<Eigen::Vector2f> PointsSeenFrom(const Pose2& world_T_robot,
                                            const std::vector<Eigen::Vector2d>& points_world) {
  std::vector<Eigen::Vector2f> points_robot;
  for (const Eigen::Vector2d& p : points_world) {
    points_robot.push_back((world_T_robot.inverse() * p).cast<float>());
  }
  return points_robot;
}

// Evaluates `cost` at `pose`; `jacobian` (row-major N x 3) may be null.
std::vector<double> Residuals(const ceres::CostFunction& cost, const Pose2& pose,
                              std::vector<double>* jacobian = nullptr) {
  Block block = ToBlock(pose);
  const double* parameters[1] = {block.data()};
  std::vector<double> residuals(cost.num_residuals());
  if (jacobian != nullptr) jacobian->assign(3 * cost.num_residuals(), 0.0);
  double* jacobians[1] = {jacobian != nullptr ? jacobian->data() : nullptr};
  EXPECT_TRUE(cost.Evaluate(parameters, residuals.data(), jacobian != nullptr ? jacobians : nullptr));
  return residuals;
}

double Norm(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x * x;
  return std::sqrt(sum);
}

// The wall's field by hand at cell centres, checked against the map itself: guards the hand
// values the residual tests below rest on.
TEST(ScanCostTest, WallFieldMatchesTheLikelihoodFormula) {
  const LaserMap map = MapFromHits(WallHits());
  const GridGeometry& g = map.field().geometry();
  for (int k = kWallColumn - kWindowCells - 2; k <= kWallColumn + kWindowCells + 2; ++k) {
    for (int row = -5; row <= 5; ++row) {
      const Eigen::Vector2d centre((k + 0.5) * kResolutionMeters, (row + 0.5) * kResolutionMeters);
      const CellIndex c = g.WorldToCell(centre);
      EXPECT_NEAR(WallFieldAtColumn(k), map.field().Value(c), 1e-6) << "world column " << k << " row " << row;
    }
  }
}

// Three points by hand, pose (0.2 m, -0.1 m, pi/2): two land on cell centres, where the
// bicubic interpolant equals the cell value exp(-d / sigma); one lands between centres, where
// it is the Catmull-Rom cubic of the four neighbouring columns (the rows around every point lie
// in the wall's span and hold the same values, and Catmull-Rom reproduces a constant, so the
// row direction drops out). r_i = w_i / sqrt(3) (1 - L_i). The same numbers hold with x and y
// swapped (wall y = 0.5125, points transposed, another pose), which checks the row direction
// of the lookup and the y half of the transform as the first case checks the column and x.
TEST(ScanCostTest, ResidualByHandWithUnitZeroAndNonUnitWeights) {
  for (const bool transposed : {false, true}) {
    SCOPED_TRACE(transposed ? "wall y = 0.5125" : "wall x = 0.5125");
    const LaserMap map = MapFromHits(WallHits(transposed));
    const Pose2 world_T_robot = transposed ? Pose2(-0.1, 0.15, -0.4) : Pose2(0.2, -0.1, M_PI / 2);
    std::vector<Eigen::Vector2d> points_world = {
        {0.325, 0.025},   // centre of column 6: d = 0.5125 - 0.325 = 0.1875 m
        {0.475, -0.075},  // centre of column 9: d = 0.5125 - 0.475 = 0.0375 m
        {0.41, 0.04}};    // continuous column 0.41 / 0.05 - 0.5 = 7.7: between centres 7 and 8
    if (transposed) {
      for (Eigen::Vector2d& p : points_world) p = Eigen::Vector2d(p.y(), p.x());
    }
    const std::vector<double> likelihood = {
        std::exp(-0.1875 / kSigmaMeters), std::exp(-0.0375 / kSigmaMeters),
        // Columns 6..9 at d = 0.1875, 0.1375, 0.0875, 0.0375 m, t = 0.7.
        CatmullRom(std::exp(-1.875), std::exp(-1.375), std::exp(-0.875), std::exp(-0.375), 0.7)};
    // The interpolated value must lie between its two neighbouring cell values (sanity of the
    // hand formula, not of the cost).
    ASSERT_GT(likelihood[2], std::exp(-1.375));
    ASSERT_LT(likelihood[2], std::exp(-0.875));
    const std::vector<Eigen::Vector2f> points_robot = PointsSeenFrom(world_T_robot, points_world);
    const double inv_sqrt_n = 1.0 / std::sqrt(3.0);

    // No weights given: all 1.
    std::unique_ptr<ceres::CostFunction> unit(CreateScanToLikelihoodFieldCost(map.field(), points_robot));
    ASSERT_EQ(3, unit->num_residuals());
    const std::vector<double> r_unit = Residuals(*unit, world_T_robot);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(inv_sqrt_n * (1.0 - likelihood[i]), r_unit[i], kResidualTolerance) << "point " << i;
    }

    // A zero weight gives a zero residual and a zero Jacobian row (no pull at all); the other
    // weights scale by w_i / sqrt(N), with N = 3 still counting the zero-weight point (the
    // header's formula sums over all N points).
    const std::vector<float> weights = {0.f, 2.5f, 0.4f};
    std::unique_ptr<ceres::CostFunction> weighted(
        CreateScanToLikelihoodFieldCost(map.field(), points_robot, weights));
    std::vector<double> jacobian;
    const std::vector<double> r_weighted = Residuals(*weighted, world_T_robot, &jacobian);
    EXPECT_EQ(0.0, r_weighted[0]);
    for (int j = 0; j < 3; ++j) EXPECT_EQ(0.0, jacobian[j]) << "d r_0 / d pose[" << j << "]";
    EXPECT_NEAR(2.5 * inv_sqrt_n * (1.0 - likelihood[1]), r_weighted[1], kResidualTolerance);
    // 0.4f is not 0.4 exactly (relative error 1.5e-8), far below the tolerance.
    EXPECT_NEAR(0.4 * inv_sqrt_n * (1.0 - likelihood[2]), r_weighted[2], kResidualTolerance);
    // The non-zero weights scale the unit residuals exactly (same point, same pose).
    EXPECT_NEAR(2.5 * r_unit[1], r_weighted[1], 1e-12);
    EXPECT_NEAR(double(0.4f) * r_unit[2], r_weighted[2], 1e-12);
  }
}

// Where the field is 0, r_i = w_i / sqrt(N) exactly: with N = 4, half of each weight. That holds
// away from the wall and outside the grid, where the lookup takes the nearest border cell (Ceres
// Grid2D clamps) and a LaserMap's border cells are 0 (its border margin exceeds the window).
TEST(ScanCostTest, PointsWhereTheFieldIsZeroGiveWeightOverSqrtN) {
  const LaserMap map = MapFromHits(WallHits());
  // Interpolation coordinates along x 0, 0.7 and -2.1: neighbour columns -4..2, all more than 6
  // columns from the wall's column 10. The last point lies far outside the grid (about +-2.5 m).
  const std::vector<Eigen::Vector2d> points_world = {{0.025, 0.025}, {0.06, -0.13}, {-0.08, 0.2}, {50.0, -30.0}};
  ASSERT_FALSE(map.field().geometry().Contains(map.field().geometry().WorldToCell(points_world[3])));
  const Pose2 world_T_robot(0.01, 0.02, 0.3);
  const std::vector<float> weights = {1.f, 3.f, 0.f, 0.5f};
  std::unique_ptr<ceres::CostFunction> cost(
      CreateScanToLikelihoodFieldCost(map.field(), PointsSeenFrom(world_T_robot, points_world), weights));
  const std::vector<double> r = Residuals(*cost, world_T_robot);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(weights[i] / 2.0, r[i]) << "point " << i;
}

// Seeded random poses whose three scan points land among the posts, so that every Jacobian
// row is non-zero along x, y and yaw. Yaws 0 and near +-pi are included: the Se2Manifold wraps
// yaw there, and the cost must stay smooth across the cut.
//
// Where the cubic pieces meet: the Ceres bicubic interpolant is C1 (Catmull-Rom), but it is a
// different cubic in every cell and its second derivative jumps on the cell-centre lines.
// GradientChecker differentiates numerically with Ridders' extrapolation, whose first step is
// 2^(max_num_ridders_extrapolations / 2) * max(rho, rho |parameter|) = 32 max(rho, rho |p|),
// rho = ridders_relative_initial_step_size (ceres/internal/numeric_diff.h). At the default
// rho = 1e-2 that is 0.32 m, six cells, and the extrapolation across centre lines made the
// "numeric" Jacobian wrong by up to 100% (the cost's own Jacobian matched plain central
// differences with a 1e-6 step to nine digits). With rho = 1e-5 the first step is 3.2e-4 m = 0.0064 cell in x and y
// (|x|, |y| < 1 m here) and 32 * pi * 1e-5 rad ~ 1e-3 rad through yaw, which moves a point at
// most 0.33 m * 1e-3 = 3.3e-4 m = 0.0066 cell; every point is kept at least 0.02 cell from a
// centre line, so each stencil stays inside one cubic piece.
TEST(ScanCostTest, GradientCheckerAgreesAtSeededRandomPoses) {
  const LaserMap map = MapFromHits(PostHits());
  const std::vector<Eigen::Vector2f> points_robot = {{0.30f, 0.0f}, {0.32f, 0.05f}, {0.28f, -0.06f}};
  std::unique_ptr<ceres::CostFunction> cost(CreateScanToLikelihoodFieldCost(map.field(), points_robot));
  const Se2Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds = {&manifold};
  ceres::NumericDiffOptions numeric_options;
  numeric_options.ridders_relative_initial_step_size = 1e-5;
  const ceres::GradientChecker checker(cost.get(), &manifolds, numeric_options);

  // Among the posts: some post is within 6 cells of every neighbour.
  auto in_post_region = [](const Eigen::Vector2d& p) {
    return p.x() > 0.22 && p.x() < 0.45 && p.y() > 0.22 && p.y() < 0.45;
  };
  auto off_centre_lines = [](const Eigen::Vector2d& p) {
    for (int i = 0; i < 2; ++i) {
      const double s = p[i] / kResolutionMeters - 0.5;  // interpolation coordinate
      const double fraction = s - std::floor(s);
      if (fraction < 0.02 || fraction > 0.98) return false;
    }
    return true;
  };
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> target(0.24, 0.43), yaw(-M_PI, M_PI);
  std::vector<double> yaws = {0.0, M_PI - 1e-4, -M_PI + 1e-4};
  for (int i = 0; i < 20; ++i) yaws.push_back(yaw(rng));
  int probes = 0;
  for (double yaw_radians : yaws) {
    // Place the first point on a random target, the rest follow; redraw until all land well.
    Pose2 pose;
    bool placed = false;
    for (int attempt = 0; attempt < 1000 && !placed; ++attempt) {
      const Eigen::Vector2d p0_world(target(rng), target(rng));
      const Pose2 rotation(0.0, 0.0, yaw_radians);
      pose = Pose2(p0_world - rotation * points_robot[0].cast<double>(), yaw_radians);
      placed = true;
      for (const Eigen::Vector2f& p : points_robot) {
        const Eigen::Vector2d p_world = pose * p.cast<double>();
        placed = placed && in_post_region(p_world) && off_centre_lines(p_world);
      }
    }
    ASSERT_TRUE(placed) << "no placement found for yaw " << yaw_radians;
    Block block = ToBlock(pose);
    double* parameters[1] = {block.data()};
    ceres::GradientChecker::ProbeResults results;
    // 1e-6: within one cubic piece Ridders' extrapolation is exact up to rounding; a wrong
    // term (sign, factor, swapped axis) is an O(1) relative error.
    const bool ok = checker.Probe(parameters, 1e-6, &results);
    EXPECT_TRUE(ok) << "at " << pose << "\n" << results.error_log;
    EXPECT_TRUE(results.return_value) << "at " << pose << "\n" << results.error_log;
    EXPECT_LT(results.maximum_relative_error, 1e-6) << "at " << pose << "\n" << results.error_log;
    for (int r = 0; r < 3; ++r) {
      EXPECT_GT(results.local_jacobians[0].row(r).norm(), 0.0) << "flat field at point " << r << ", pose " << pose;
    }
    ++probes;
  }
  EXPECT_EQ(23, probes);
}

// A scan facing the wall (yaw 0, three points 0.25 m ahead) driven toward it: while the points
// are short of the wall, every 1 cm step lowers |r| strictly, the gradient of 1/2 |r|^2 points
// away from the wall (so a descent step moves toward it) and has no y component (the wall is
// uniform along y). Over a sweep through the wall, the smallest |r| lies within one cell of it.
TEST(ScanCostTest, MovingTowardTheWallLowersTheResidual) {
  const LaserMap map = MapFromHits(WallHits());
  const std::vector<Eigen::Vector2f> points_robot = {{0.25f, -0.05f}, {0.25f, 0.0f}, {0.25f, 0.05f}};
  std::unique_ptr<ceres::CostFunction> cost(CreateScanToLikelihoodFieldCost(map.field(), points_robot));
  double previous_norm = std::numeric_limits<double>::infinity();
  // Robot x from 0 to 0.20 m: the points from 0.25 m (interpolation coordinate 4.5) to 0.45 m
  // (8.5, 1.25 cells short of the wall hits); they interpolate columns 3..10, whose values rise
  // toward the wall (column 3 is outside the window: 0).
  for (int step = 0; step <= 20; ++step) {
    const Pose2 pose(0.01 * step, 0.0, 0.0);
    std::vector<double> jacobian;
    const std::vector<double> r = Residuals(*cost, pose, &jacobian);
    const double norm = Norm(r);
    EXPECT_LT(norm, previous_norm) << "robot x " << pose.x();
    previous_norm = norm;
    double gradient_x = 0.0, gradient_y = 0.0;  // J^T r
    for (int i = 0; i < 3; ++i) {
      gradient_x += jacobian[3 * i + 0] * r[i];
      gradient_y += jacobian[3 * i + 1] * r[i];
    }
    EXPECT_LT(gradient_x, 0.0) << "robot x " << pose.x();
    EXPECT_NEAR(0.0, gradient_y, 1e-12) << "robot x " << pose.x();
  }
  // Points from 0.25 m to 0.80 m in 5 mm steps, across the wall at 0.5125 m.
  double best_norm = std::numeric_limits<double>::infinity(), best_points_x = 0.0;
  for (int step = 0; step <= 110; ++step) {
    const double points_x = 0.25 + 0.005 * step;
    const double norm = Norm(Residuals(*cost, Pose2(points_x - 0.25, 0.0, 0.0)));
    if (norm < best_norm) {
      best_norm = norm;
      best_points_x = points_x;
    }
  }
  EXPECT_NEAR(kWallXMeters, best_points_x, kResolutionMeters);
}

// The wall's hits lie 1.25 cm off column 10's centre (0.525 m). Sweeping points across it in
// 1 mm steps: interpolating the field's values, the cost is lowest at the cell centre (the
// kernel's cusp is interpolated by its samples); interpolating distances, on the wall itself.
// Both costs agree at cell centres.
TEST(ScanCostTest, InterpolatedDistancesPutTheMinimumOnTheWallNotOnTheCellCentre) {
  const LaserMap map = MapFromHits(WallHits());
  const std::vector<Eigen::Vector2f> points_robot = {{0.25f, -0.05f}, {0.25f, 0.0f}, {0.25f, 0.05f}};
  double best[2] = {0.0, 0.0};
  int k = 0;
  for (const ScanCostInterpolation interpolation : {ScanCostInterpolation::kValues, ScanCostInterpolation::kDistances}) {
    std::unique_ptr<ceres::CostFunction> cost(
        CreateScanToLikelihoodFieldCost(map.field(), points_robot, {}, interpolation));
    double best_norm = std::numeric_limits<double>::infinity();
    for (int step = 0; step <= 100; ++step) {
      const double points_x = 0.47 + 0.001 * step;
      const double norm = Norm(Residuals(*cost, Pose2(points_x - 0.25, 0.0, 0.0)));
      if (norm < best_norm) {
        best_norm = norm;
        best[k] = points_x;
      }
    }
    ++k;
  }
  // Values: the minimum 4 mm from column 10's centre (0.525 m) and 8.5 mm from the wall.
  EXPECT_GT(std::abs(best[0] - kWallXMeters), 0.006) << "values: pulled towards the cell centre";
  EXPECT_LT(std::abs(best[0] - (kWallColumn + 0.5) * kResolutionMeters), 0.005);
  EXPECT_NEAR(kWallXMeters, best[1], 0.0015) << "distances: the minimum on the wall";
  // The same residuals where the points sit on cell centres (y too: rows -1, 0 and 1), up to
  // the distance's 1 mm floor (sqrt(d^2 + 1e-6): 0.3% of the likelihood 1.25 cm from the wall).
  const std::vector<Eigen::Vector2f> at_centres = {{0.025f, -0.025f}, {0.025f, 0.025f}, {0.075f, 0.075f}};
  std::unique_ptr<ceres::CostFunction> values(CreateScanToLikelihoodFieldCost(map.field(), at_centres));
  std::unique_ptr<ceres::CostFunction> distances(
      CreateScanToLikelihoodFieldCost(map.field(), at_centres, {}, ScanCostInterpolation::kDistances));
  for (const double x : {0.35, 0.40, 0.45, 0.50}) {
    const std::vector<double> a = Residuals(*values, Pose2(x, 0.0, 0.0));
    const std::vector<double> b = Residuals(*distances, Pose2(x, 0.0, 0.0));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(a[i], b[i], 5e-4) << "x " << x << " point " << i;
  }
}

// Distance costs remember the squared distances they read (per thread, per cost: see
// SquaredDistanceGrid in factors/scan_cost.cc). A cost over another map reading the same cell
// indices in between (here a wall 2 cm further, at the same grid origin) changes nothing: each
// cost gives exactly its first residuals again, and a new cost over the first map the same.
TEST(ScanCostTest, DistanceCostsOfDifferentMapsNeverShareRememberedDistances) {
  const LaserMap near_wall = MapFromHits(WallHits());
  std::vector<Eigen::Vector2f> further = WallHits();
  for (Eigen::Vector2f& hit : further) hit.x() += 0.02f;
  const LaserMap far_wall = MapFromHits(further);
  ASSERT_EQ(near_wall.field().geometry().origin(), far_wall.field().geometry().origin());
  const std::vector<Eigen::Vector2f> points_robot = {{0.25f, -0.05f}, {0.25f, 0.0f}, {0.25f, 0.05f}};
  const Pose2 pose(0.22, 0.01, 0.02);
  auto distance_cost = [&](const LaserMap& map) {
    return std::unique_ptr<ceres::CostFunction>(
        CreateScanToLikelihoodFieldCost(map.field(), points_robot, {}, ScanCostInterpolation::kDistances));
  };
  const std::unique_ptr<ceres::CostFunction> near_cost = distance_cost(near_wall);
  const std::vector<double> near_residuals = Residuals(*near_cost, pose);
  const std::unique_ptr<ceres::CostFunction> far_cost = distance_cost(far_wall);
  const std::vector<double> far_residuals = Residuals(*far_cost, pose);
  EXPECT_GT(std::abs(near_residuals[1] - far_residuals[1]), 1e-3) << "the two maps differ where the points are";
  EXPECT_EQ(near_residuals, Residuals(*near_cost, pose));
  EXPECT_EQ(far_residuals, Residuals(*far_cost, pose));
  EXPECT_EQ(near_residuals, Residuals(*distance_cost(near_wall), pose));
}

// Shifting the hits and the pose by the same whole number of cells (7, -4) gives the same
// residuals and Jacobians: the shifted hits sit at the same sub-cell offsets on the
// world-aligned lattice, so the field is the same table under another grid origin, and the
// cost must use that origin consistently. (A shift by a fraction of a cell moves the samples
// relative to the hits and changes the values; it is not tested.)
TEST(ScanCostTest, TranslationByWholeCellsLeavesResidualsUnchanged) {
  const Pose2 world_T_shifted(7 * kResolutionMeters, -4 * kResolutionMeters, 0.0);
  const LaserMap map = MapFromHits(WallHits());
  const LaserMap shifted = MapFromHits(WallHits(), world_T_shifted);
  ASSERT_NE(map.field().geometry().origin(), shifted.field().geometry().origin());
  const std::vector<Eigen::Vector2f> points_robot = {{0.3f, -0.1f}, {0.35f, 0.02f}, {0.28f, 0.12f}};
  std::unique_ptr<ceres::CostFunction> cost(CreateScanToLikelihoodFieldCost(map.field(), points_robot));
  std::unique_ptr<ceres::CostFunction> shifted_cost(
      CreateScanToLikelihoodFieldCost(shifted.field(), points_robot));
  std::mt19937 rng(47);
  std::uniform_real_distribution<double> x(-0.05, 0.2), y(-0.15, 0.15), yaw(-0.5, 0.5);
  for (int i = 0; i < 20; ++i) {
    const Pose2 pose(x(rng), y(rng), yaw(rng));
    std::vector<double> jacobian, shifted_jacobian;
    const std::vector<double> r = Residuals(*cost, pose, &jacobian);
    const std::vector<double> r_shifted = Residuals(*shifted_cost, world_T_shifted * pose, &shifted_jacobian);
    for (int k = 0; k < 3; ++k) {
      // Not vacuous: each point sees the wall (L > 0 makes r < 1 / sqrt(3)).
      EXPECT_LT(r[k], 1.0 / std::sqrt(3.0) - 1e-3) << "point " << k << " at " << pose;
      EXPECT_NEAR(r[k], r_shifted[k], kResidualTolerance) << "point " << k << " at " << pose;
    }
    // The slopes are weighted differences of float field values (rounding ~6e-8 each) divided
    // by the cell size (x 20 per metre): a few 1e-6 at most.
    for (int k = 0; k < 9; ++k) {
      EXPECT_NEAR(jacobian[k], shifted_jacobian[k], 1e-5) << "entry " << k << " at " << pose;
    }
  }
}

// A frozen field (cropped, distances in 8-bit codes) gives the residuals of the field it was,
// within what the distance step allows, at seeded random poses over the posts: each sample's
// distance is off by at most half a step Δ, the interpolation (Catmull-Rom weights, at most
// 1.25 in absolute value per axis) carries that to the interpolated distance, and the kernel
// exp(-d / sigma) changes by at most 1 / sigma per metre (scaled by the weight / sqrt(N)).
// Jacobians: within that over the cell size, four times (d/dx of the interpolation).
TEST(ScanCostTest, FrozenFieldGivesTheSameResiduals) {
  const LaserMap map = MapFromHits(PostHits());
  LaserMap frozen = map;
  frozen.Freeze();
  ASSERT_TRUE(frozen.field().frozen());
  const std::vector<Eigen::Vector2f> points_robot = {{0.30f, 0.0f}, {0.32f, 0.05f}, {0.28f, -0.06f}};
  std::unique_ptr<ceres::CostFunction> cost(CreateScanToLikelihoodFieldCost(map.field(), points_robot));
  std::unique_ptr<ceres::CostFunction> frozen_cost(CreateScanToLikelihoodFieldCost(frozen.field(), points_robot));
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> xy(-0.3, 0.3), yaw(-M_PI, M_PI);
  const double sigma = frozen.field().options().sigma_meters;
  const double step = 1.25 * 1.25 * 0.5 * frozen.field().frozen_codes().distance_step_meters / sigma;
  const double residual_tolerance = step / std::sqrt(3.0) + kResidualTolerance;
  for (int i = 0; i < 30; ++i) {
    Block block = {0.3 + xy(rng), 0.3 + xy(rng), yaw(rng)};
    const double* parameters[1] = {block.data()};
    double residuals[3], frozen_residuals[3];
    double jacobian[9], frozen_jacobian[9];
    double* jacobians[1] = {jacobian};
    double* frozen_jacobians[1] = {frozen_jacobian};
    ASSERT_TRUE(cost->Evaluate(parameters, residuals, jacobians));
    ASSERT_TRUE(frozen_cost->Evaluate(parameters, frozen_residuals, frozen_jacobians));
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(residuals[r], frozen_residuals[r], residual_tolerance) << "pose " << i;
    for (int k = 0; k < 9; ++k) EXPECT_NEAR(jacobian[k], frozen_jacobian[k], 4 * step / kResolutionMeters) << "pose " << i;
  }
}

// The cost's derivatives are written out (factors/scan_cost.cc); they repeat the arithmetic of
// automatic differentiation of the header's formula. The reference here is that formula as a
// Ceres functor over the same samples (the field's values, its squared distances, a frozen
// field's code table), differentiated by ceres::AutoDiffCostFunction: every residual and
// Jacobian entry must be the same double, evaluated with and without Jacobians, again at the
// same pose (the cost keeps the last pose's samples) and after another pose.
class ReferenceGrid {
 public:
  enum { DATA_DIMENSION = 1 };
  ReferenceGrid(const LikelihoodField& field, ScanCostInterpolation interpolation)
      : field_(field), distances_(interpolation == ScanCostInterpolation::kDistances) {}
  void GetValue(int row, int col, double* f) const {
    const GridGeometry& g = field_.geometry();
    const int x = std::clamp(col, 0, g.width() - 1), y = std::clamp(row, 0, g.height() - 1);
    if (field_.frozen()) {
      const LikelihoodField::FrozenCodes& codes = field_.frozen_codes();
      f[0] = distances_ ? codes.squared_distance[field_.FrozenCode(x, y)] : codes.value[field_.FrozenCode(x, y)];
      return;
    }
    const double value = field_.values().Get(x, y);
    if (!distances_) {
      f[0] = value;
      return;
    }
    const double sigma = field_.options().sigma_meters;
    const double max_distance = field_.window_radius_cells() * g.resolution_meters();
    const double d = value > std::exp(-max_distance / sigma) ? -sigma * std::log(value) : max_distance;
    f[0] = d * d;
  }

 private:
  const LikelihoodField& field_;
  const bool distances_;
};

struct ReferenceScanCost {
  template <typename T>
  bool operator()(const T* const world_T_robot, T* residuals) const {
    const T c = ceres::cos(world_T_robot[2]);
    const T s = ceres::sin(world_T_robot[2]);
    const double inv_r = 1.0 / geometry.resolution_meters();
    for (size_t i = 0; i < points.size(); ++i) {
      const T px = T(double(points[i].x()));
      const T py = T(double(points[i].y()));
      const T wx = c * px - s * py + world_T_robot[0];
      const T wy = s * px + c * py + world_T_robot[1];
      const T col = (wx - geometry.origin().x()) * inv_r - 0.5;
      const T row = (wy - geometry.origin().y()) * inv_r - 0.5;
      T sample;
      interpolator.Evaluate(row, col, &sample);
      T likelihood;
      if (sigma_meters > 0) {
        const T d = ceres::sqrt((sample < T(0) ? T(0) : sample) + T(1e-6));
        likelihood = ceres::exp(-d / sigma_meters);
      } else {
        likelihood = 1.0 * sample;
      }
      residuals[i] = weights[i] * (1.0 - likelihood);
    }
    return true;
  }
  GridGeometry geometry;
  double sigma_meters;
  const ceres::BiCubicInterpolator<ReferenceGrid>& interpolator;
  std::vector<Eigen::Vector2f> points;
  std::vector<double> weights;  // w_i / sqrt(N)
};

TEST(ScanCostTest, WrittenOutDerivativesAreTheAutomaticOnesBitForBit) {
  const LaserMap built = MapFromHits(PostHits());
  LaserMap frozen = built;
  frozen.Freeze();
  const std::vector<Eigen::Vector2f> points_robot = {{0.30f, 0.0f}, {0.32f, 0.05f}, {0.28f, -0.06f}, {0.9f, 0.9f}};
  const std::vector<float> weights = {1.0f, 0.5f, 2.0f, 1.0f};
  int compared = 0;
  for (const LaserMap* map : {&built, static_cast<const LaserMap*>(&frozen)}) {
    for (const ScanCostInterpolation interpolation : {ScanCostInterpolation::kValues, ScanCostInterpolation::kDistances}) {
      const ReferenceGrid grid(map->field(), interpolation);
      const ceres::BiCubicInterpolator<ReferenceGrid> interpolator(grid);
      std::vector<double> scaled;
      for (const float w : weights) scaled.push_back(w / std::sqrt(static_cast<double>(weights.size())));
      const double sigma = interpolation == ScanCostInterpolation::kDistances ? map->field().options().sigma_meters : 0.0;
      ceres::AutoDiffCostFunction<ReferenceScanCost, ceres::DYNAMIC, 3> reference(
          new ReferenceScanCost{map->field().geometry(), sigma, interpolator, points_robot, scaled},
          static_cast<int>(points_robot.size()));
      std::unique_ptr<ceres::CostFunction> cost(
          CreateScanToLikelihoodFieldCost(map->field(), points_robot, weights, interpolation));
      std::mt19937 rng(53);
      std::uniform_real_distribution<double> xy(-0.1, 0.5), yaw(-M_PI, M_PI);
      std::vector<Pose2> poses;
      for (int i = 0; i < 20; ++i) poses.emplace_back(xy(rng), xy(rng), yaw(rng));
      poses.push_back(poses[3]);  // a pose again after others
      for (const Pose2& pose : poses) {
        // Without, with, with and without Jacobians at the same pose.
        for (const bool with_jacobian : {false, true, true, false}) {
          std::vector<double> jacobian, expected_jacobian;
          const std::vector<double> residuals = Residuals(*cost, pose, with_jacobian ? &jacobian : nullptr);
          const std::vector<double> expected = Residuals(reference, pose, with_jacobian ? &expected_jacobian : nullptr);
          for (size_t r = 0; r < residuals.size(); ++r) EXPECT_EQ(expected[r], residuals[r]) << "residual " << r;
          for (size_t k = 0; k < jacobian.size(); ++k) EXPECT_EQ(expected_jacobian[k], jacobian[k]) << "entry " << k;
          ++compared;
        }
      }
    }
  }
  EXPECT_EQ(4 * 21 * 4, compared);
}

TEST(ScanCostDeathTest, RejectsWeightCountMismatchAndEmptyScan) {
  const LaserMap map = MapFromHits(WallHits());
  const std::vector<Eigen::Vector2f> points = {{0.3f, 0.0f}, {0.4f, 0.0f}};
  EXPECT_DEATH(CreateScanToLikelihoodFieldCost(map.field(), points, {1.f}), "got 1 weights for 2 points");
  EXPECT_DEATH(CreateScanToLikelihoodFieldCost(map.field(), {}), "at least one point");
}

}  // namespace
}  // namespace hetslam
