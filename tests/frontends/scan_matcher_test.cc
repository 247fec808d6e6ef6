#include "frontends/scan_matcher.h"

#include <cmath>
#include <random>

#include "core/laser_map.h"
#include "core/laser_scan.h"
#include "datasets/sim/world.h"
#include "gtest/gtest.h"
#include "tests/frontends/sim_fixtures.h"

namespace hetslam {
namespace {

using testing_sim::RoomWithPillar;  // no symmetry within the search window

// A scan of `beams` beams over a full turn from straight behind (-180°, counterclockwise;
// 360: 1° steps) from `world_T_robot`, robot frame, with Gaussian range noise, returns up to
// `max_range` metres.
std::vector<Eigen::Vector2f> SimulateScan(const sim::World& world, const Pose2& world_T_robot, double noise_std,
                                          std::mt19937* rng, int beams = 360, double max_range = 20.0) {
  std::normal_distribution<double> noise(0.0, noise_std);
  std::vector<Eigen::Vector2f> points;
  const double half = 0.5 * beams;
  for (int i = 0; i < beams; ++i) {
    const double angle = -M_PI + i * M_PI / half;
    double range = 0.0;
    if (!world.CastRay(world_T_robot.translation(), world_T_robot.theta() + angle, max_range, &range)) continue;
    const double r = range + (noise_std > 0 ? noise(*rng) : 0.0);
    points.emplace_back(static_cast<float>(r * std::cos(angle)), static_cast<float>(r * std::sin(angle)));
  }
  return points;
}

// Scans of `world` from four poses spread over a room, inserted into `map` (range noise as
// SimulateScan's, drawn from `rng`).
void InsertScansFromFourPoses(const sim::World& world, double noise_std, std::mt19937* rng, LaserMap* map) {
  for (const Pose2& pose : {Pose2(0, 0, 0), Pose2(-1.5, -0.5, 0.8), Pose2(1.0, -1.0, -2.0), Pose2(2.0, 1.2, 2.5)}) {
    map->InsertScan(pose, Eigen::Vector2d::Zero(), SimulateScan(world, pose, noise_std, rng));
  }
}

class ScanMatcherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937 rng(1);
    for (const Pose2& pose : {Pose2(0, 0, 0), Pose2(-1.5, -0.5, 0.8), Pose2(1.0, -1.0, -2.0)}) {
      map_.InsertScan(pose, Eigen::Vector2d::Zero(), SimulateScan(world_, pose, 0.01, &rng));
    }
  }

  // Matching a scan taken at `truth` from `truth ∘ offset` lands within 2 cm / 0.5°.
  void ExpectConvergesFrom(const Pose2& truth, const Pose2& offset) {
    std::mt19937 rng(2);
    const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.01, &rng);
    const ScanMatchResult result = matcher_.Match(map_, truth * offset, scan);
    ASSERT_TRUE(result.converged) << result.message;
    EXPECT_NEAR(truth.x(), result.pose.x(), 0.02) << "from offset " << offset;
    EXPECT_NEAR(truth.y(), result.pose.y(), 0.02) << "from offset " << offset;
    EXPECT_NEAR(0.0, WrapAngle(truth.theta() - result.pose.theta()), 0.5 * M_PI / 180) << "from offset " << offset;
    EXPECT_GT(result.score, 0.5);
    EXPECT_GT(result.information.trace(), 0.0);
  }

  sim::World world_ = RoomWithPillar();
  LaserMap map_{OccupancyGridOptions(), LikelihoodFieldOptions()};
  ScanMatcher matcher_{ScanMatcherOptions()};
};

TEST_F(ScanMatcherTest, ConvergesFromOffsetsUpTo30cmAnd10Degrees) {
  const Pose2 truth(0.4, -0.3, 0.3);
  const double deg = M_PI / 180.0;
  for (const Pose2& offset : {Pose2(0, 0, 0), Pose2(0.3, 0, 0), Pose2(0, -0.3, 0), Pose2(0, 0, 10 * deg),
                              Pose2(0, 0, -10 * deg), Pose2(0.21, 0.21, 10 * deg), Pose2(-0.21, 0.21, -10 * deg),
                              Pose2(-0.3, -0.05, 7 * deg)}) {
    ExpectConvergesFrom(truth, offset);
  }
}

TEST_F(ScanMatcherTest, ConvergesFromSparseLogOffsets) {
  // The shared logs' scans are up to ~1 m and ~35° apart with no odometry.
  const double deg = M_PI / 180.0;
  ExpectConvergesFrom(Pose2(-0.5, 0.2, 1.2), Pose2(0.8, -0.6, 30 * deg));
  ExpectConvergesFrom(Pose2(-0.5, 0.2, 1.2), Pose2(-0.9, 0.5, -35 * deg));
}

TEST_F(ScanMatcherTest, FailsCleanlyOnEmptyInput) {
  const ScanMatchResult result = matcher_.Match(map_, Pose2(), {});
  EXPECT_FALSE(result.converged);
  EXPECT_FALSE(result.message.empty());
  LaserMap empty{OccupancyGridOptions(), LikelihoodFieldOptions()};
  const ScanMatchResult on_empty = matcher_.Match(empty, Pose2(), {{1.f, 0.f}});
  EXPECT_FALSE(on_empty.converged);
}

TEST_F(ScanMatcherTest, ZeroWeightPointsAreIgnored) {
  // Clutter points weighted 0 (floor obstacles) must not move the answer.
  std::mt19937 rng(3);
  const Pose2 truth(0.2, 0.1, -0.2);
  std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.01, &rng);
  std::vector<float> weights(scan.size(), 1.f);
  std::uniform_real_distribution<float> clutter(-1.f, 1.f);
  for (int i = 0; i < 200; ++i) {
    scan.emplace_back(clutter(rng), clutter(rng));
    weights.push_back(0.f);
  }
  const ScanMatchResult result = matcher_.Match(map_, truth * Pose2(0.2, -0.1, 0.1), scan, weights);
  ASSERT_TRUE(result.converged);
  EXPECT_NEAR(truth.x(), result.pose.x(), 0.02);
  EXPECT_NEAR(truth.y(), result.pose.y(), 0.02);
  EXPECT_NEAR(0.0, WrapAngle(truth.theta() - result.pose.theta()), 0.5 * M_PI / 180);
}

// Branch and bound must find the same best discrete score as evaluating every candidate.
TEST_F(ScanMatcherTest, BranchAndBoundMatchesBruteForceOnRandomPoses) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> xy(-1.0, 1.0), th(-M_PI, M_PI), off(-0.3, 0.3), off_th(-0.2, 0.2);
  ScanMatcherOptions options;
  options.refine_with_ceres = false;
  options.linear_search_window_meters = 0.4;
  options.angular_search_window_radians = 0.1;
  options.min_correlative_score = 0.0;
  options.fallback_linear_search_window_meters = 0.0;  // compare one search with one search
  options.fallback_angular_search_window_radians = 0.0;
  for (int trial = 0; trial < 12; ++trial) {
    // Half of the trials with a motion prior, whose bound must stay exact too.
    options.translation_penalty_per_square_meter = trial % 2 ? 0.3 : 0.0;
    options.rotation_penalty_per_square_radian = trial % 2 ? 0.5 : 0.0;
    const ScanMatcher matcher(options);
    const Pose2 truth(xy(rng), xy(rng), th(rng));
    const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.02, &rng);
    const Pose2 predicted = truth * Pose2(off(rng), off(rng), off_th(rng));
    const ScanMatchResult fast = matcher.Match(map_, predicted, scan);
    const ScanMatchResult brute = matcher.BruteForceSearch(map_, predicted, scan);
    ASSERT_TRUE(fast.converged);
    EXPECT_FLOAT_EQ(brute.correlative_score, fast.correlative_score) << "trial " << trial;
    EXPECT_LT(fast.candidates_scored, brute.candidates_scored) << "trial " << trial;
  }
}

// The search tables are filled only along the scan's outline (a band, NeededSpans), over
// tables left from a search of another map: in a 16 m hall, whose middle no search of a scan
// along its walls reads, branch and bound still finds brute force's best score, also with
// deeper blocks and wider windows.
// A candidate's correlative score is the mean of its points' cell values, coded in 16 bits:
// within half a code step (1 / 65535 of the values' range) of the exact mean, on a map being
// built and on a frozen one.
TEST_F(ScanMatcherTest, LeafScoresAreTheCellValuesMeanWithinHalfACodeStep) {
  ScanMatcherOptions options;
  options.linear_search_window_meters = 0.0;
  options.angular_search_window_radians = 0.0;
  options.refine_with_ceres = false;
  options.free_space_penalty = 0.0;  // every point scores its cell's field value
  options.min_correlative_score = 0.0;
  const ScanMatcher matcher(options);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> offset(-0.3, 0.3);
  LaserMap frozen = map_;
  frozen.Freeze();
  for (const LaserMap* map : {&map_, &frozen}) {
    for (int trial = 0; trial < 20; ++trial) {
      const Pose2 truth(offset(rng), offset(rng), 0.0);
      const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.01, &rng);
      const Pose2 at(truth.x() + offset(rng), truth.y() + offset(rng), offset(rng));
      double sum = 0.0;
      for (const Eigen::Vector2f& p : scan) {
        sum += map->field().Value(map->field().geometry().WorldToCell(at * p.cast<double>()));
      }
      const double exact = sum / scan.size();
      ASSERT_GT(exact, 0.05) << "trial " << trial;  // the points meet the map
      const double half_step = 0.5 / 65535.0;
      EXPECT_NEAR(exact, matcher.BruteForceSearch(*map, at, scan).correlative_score, half_step + 1e-7)
          << "trial " << trial << (map == &frozen ? ", frozen" : "");
    }
  }
}

TEST(ScanMatcherBandTest, TablesFilledAlongTheScanAloneScoreLikeBruteForce) {
  sim::World hall;
  hall.AddBox(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(16.0, 16.0), 0.0);
  hall.AddBox(Eigen::Vector2d(-5.0, 4.0), Eigen::Vector2d(0.8, 0.5), 0.3);
  hall.AddBox(Eigen::Vector2d(4.5, -6.0), Eigen::Vector2d(0.6, 1.2), 0.0);
  std::mt19937 rng(31);
  LaserMap hall_map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  for (const Pose2& pose : {Pose2(0, 0, 0), Pose2(-4, -4, 1.0), Pose2(4, 4, -2.0)}) {
    hall_map.InsertScan(pose, Eigen::Vector2d::Zero(), SimulateScan(hall, pose, 0.01, &rng));
  }
  const sim::World room = RoomWithPillar();
  LaserMap room_map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  room_map.InsertScan(Pose2(0, 0, 0), Eigen::Vector2d::Zero(), SimulateScan(room, Pose2(0, 0, 0), 0.01, &rng));
  std::uniform_real_distribution<double> xy(-3.0, 3.0), th(-M_PI, M_PI), off(-0.3, 0.3), off_th(-0.1, 0.1);
  for (const auto& [depth, window] : {std::pair<int, double>{4, 0.4}, {5, 1.0}, {3, 0.2}}) {
    ScanMatcherOptions options;
    options.refine_with_ceres = false;
    options.branch_and_bound_depth = depth;
    options.linear_search_window_meters = window;
    options.angular_search_window_radians = 0.1;
    options.min_correlative_score = 0.0;
    options.fallback_linear_search_window_meters = 0.0;
    options.fallback_angular_search_window_radians = 0.0;
    const ScanMatcher matcher(options);
    for (int trial = 0; trial < 4; ++trial) {
      // The other map's search first: its tables are what the hall's search finds outside its band.
      const Pose2 room_pose(0.5, -0.5, th(rng));
      ASSERT_TRUE(matcher.Match(room_map, room_pose, SimulateScan(room, room_pose, 0.01, &rng)).converged);
      const Pose2 truth(xy(rng), xy(rng), th(rng));
      const std::vector<Eigen::Vector2f> scan = SimulateScan(hall, truth, 0.01, &rng);
      const Pose2 predicted = truth * Pose2(off(rng), off(rng), off_th(rng));
      const ScanMatchResult fast = matcher.Match(hall_map, predicted, scan);
      const ScanMatchResult brute = matcher.BruteForceSearch(hall_map, predicted, scan);
      ASSERT_TRUE(fast.converged) << "depth " << depth << ", trial " << trial;
      EXPECT_FLOAT_EQ(brute.correlative_score, fast.correlative_score) << "depth " << depth << ", trial " << trial;
      EXPECT_NEAR(brute.pose.x(), fast.pose.x(), 1e-9) << "depth " << depth << ", trial " << trial;
      EXPECT_NEAR(brute.pose.y(), fast.pose.y(), 1e-9) << "depth " << depth << ", trial " << trial;
    }
  }
}

// A finished (frozen: cropped, distances in 8-bit codes) submap matches like the map it was:
// scores and, after refinement, poses within what half a distance step allows (~1 mm), on
// seeded random poses; brute force over the frozen map agrees with branch and bound over it.
TEST_F(ScanMatcherTest, FrozenMapMatchesLikeTheMapItWas) {
  LaserMap frozen = map_;
  frozen.Freeze();
  ASSERT_LT(frozen.MemoryBytes(), map_.MemoryBytes() / 5);
  const double half_step = 0.5 * frozen.field().frozen_codes().distance_step_meters;
  const double sigma = frozen.field().options().sigma_meters;
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> xy(-1.0, 1.0), th(-M_PI, M_PI), off(-0.3, 0.3), off_th(-0.2, 0.2);
  for (int trial = 0; trial < 8; ++trial) {
    const Pose2 truth(xy(rng), xy(rng), th(rng));
    const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.02, &rng);
    const Pose2 predicted = truth * Pose2(off(rng), off(rng), off_th(rng));
    const ScanMatchResult before = matcher_.Match(map_, predicted, scan);
    const ScanMatchResult after = matcher_.Match(frozen, predicted, scan);
    ASSERT_TRUE(before.converged && after.converged) << "trial " << trial;
    // The frozen distances are rounded to half a step (~1 mm): values within half a step over
    // sigma of themselves, poses within about half a step.
    EXPECT_NEAR(before.correlative_score, after.correlative_score, half_step / sigma) << "trial " << trial;
    EXPECT_NEAR(before.pose.x(), after.pose.x(), half_step) << "trial " << trial;
    EXPECT_NEAR(before.pose.y(), after.pose.y(), half_step) << "trial " << trial;
    EXPECT_NEAR(0.0, WrapAngle(before.pose.theta() - after.pose.theta()), 1e-3) << "trial " << trial;
    EXPECT_NEAR(before.score, after.score, half_step / sigma) << "trial " << trial;
    ScanMatcherOptions discrete = matcher_.options();
    discrete.refine_with_ceres = false;
    const ScanMatcher search_only(discrete);
    EXPECT_FLOAT_EQ(search_only.BruteForceSearch(frozen, predicted, scan).correlative_score,
                    search_only.MatchWithinWindow(frozen, predicted, scan, discrete.linear_search_window_meters,
                                                  discrete.angular_search_window_radians)
                        .correlative_score)
        << "trial " << trial;
  }
}

// ReachableScoreBound (issue #15: the loop closer skips searches that cannot reach its score)
// bounds ScoreAt from above at every pose within the translation and rotation it is given, on
// a frozen map; a scan far from the map's structure has bound 0; `enough` stops it early; a map
// being built has bound 1.
TEST_F(ScanMatcherTest, ReachableScoreBoundIsAnUpperBoundOfTheScore) {
  LaserMap frozen = map_;
  frozen.Freeze();
  EXPECT_EQ(1.0, ReachableScoreBound(map_, Pose2(), {Eigen::Vector2f(50.f, 50.f)}, {}, 0.1, 0.1));
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> xy(-1.0, 1.0), th(-M_PI, M_PI), unit(-1.0, 1.0), weight(0.0, 2.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose2 truth(xy(rng), xy(rng), th(rng));
    const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.02, &rng);
    std::vector<float> weights;
    if (trial % 2 == 1) {
      for (size_t i = 0; i < scan.size(); ++i) weights.push_back(static_cast<float>(weight(rng)));
    }
    const double max_translation = 0.05 * (trial % 5), max_rotation = 0.03 * (trial % 4);
    const Pose2 predicted = truth * Pose2(0.2 * unit(rng), 0.2 * unit(rng), 0.1 * unit(rng));
    const double bound = ReachableScoreBound(frozen, predicted, scan, weights, max_translation, max_rotation);
    EXPECT_LE(bound, 1.0 + 1e-12);
    for (int k = 0; k < 50; ++k) {
      // Offsets within the bounds (the translation within its disc), in the prediction's frame.
      const double angle = th(rng), length = max_translation * std::abs(unit(rng));
      const Pose2 offset(length * std::cos(angle), length * std::sin(angle), max_rotation * unit(rng));
      ASSERT_LE(ScoreAt(frozen, predicted * offset, scan, weights), bound + 1e-9) << "trial " << trial << ", " << k;
    }
    // Early stop: at least `enough` whenever the full bound is.
    if (bound >= 0.3) {
      EXPECT_GE(ReachableScoreBound(frozen, predicted, scan, weights, max_translation, max_rotation, 0.3), 0.3);
    }
  }
  // The room's scan placed 20 m away reaches nothing within 0.5 m and 0.1 rad.
  const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, Pose2(), 0.0, &rng);
  EXPECT_EQ(0.0, ReachableScoreBound(frozen, Pose2(20.0, 0.0, 0.0), scan, {}, 0.5, 0.1));
  EXPECT_GT(ReachableScoreBound(frozen, Pose2(), scan, {}, 0.0, 0.0), 0.95);
}

// The narrow first try: a small offset is resolved inside the narrow window with the same
// pose as the full search, scoring fewer candidates; an offset beyond the narrow window lands
// on its border (or scores low), so the full search runs and still finds the truth.
TEST_F(ScanMatcherTest, NarrowFirstTryKeepsSmallOffsetsAndFallsBackForLargeOnes) {
  ScanMatcherOptions narrow_options;
  narrow_options.narrow_linear_search_window_meters = 0.4;
  narrow_options.narrow_angular_search_window_radians = 10 * M_PI / 180;
  narrow_options.narrow_accept_score = 0.4;
  const ScanMatcher narrow(narrow_options);
  const Pose2 truth(0.4, -0.3, 0.3);
  std::mt19937 rng(2);
  const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.01, &rng);
  for (const Pose2& offset : {Pose2(0.1, -0.05, 0.03), Pose2(0.9, 0.4, 0.5)}) {
    const ScanMatchResult with_narrow = narrow.Match(map_, truth * offset, scan);
    const ScanMatchResult full = narrow.Match(map_, truth * offset, scan, {}, /*try_narrow_first=*/false);
    ASSERT_TRUE(with_narrow.converged) << with_narrow.message;
    EXPECT_NEAR(truth.x(), with_narrow.pose.x(), 0.02) << "offset " << offset;
    EXPECT_NEAR(truth.y(), with_narrow.pose.y(), 0.02) << "offset " << offset;
    EXPECT_NEAR(0.0, WrapAngle(truth.theta() - with_narrow.pose.theta()), 0.5 * M_PI / 180) << "offset " << offset;
    EXPECT_NEAR(full.pose.x(), with_narrow.pose.x(), 0.01);
    EXPECT_NEAR(full.pose.y(), with_narrow.pose.y(), 0.01);
    if (offset.translation().norm() < 0.2) {
      EXPECT_LT(with_narrow.candidates_scored, full.candidates_scored);  // the full search was skipped
    } else {
      EXPECT_GT(with_narrow.candidates_scored, full.candidates_scored);  // narrow, then full
    }
  }
}

// The tables are never initialised and keep their buffers across searches and releases
// (frontends/scan_matcher.cc TableBuffer): a search writes every cell it reads, so what a
// larger search or a released buffer left behind changes no result, and ScratchBytes follows
// what the searches since the last release (or trim) asked for.
TEST_F(ScanMatcherTest, TablesLeftByLargerOrReleasedSearchesChangeNoResult) {
  const Pose2 truth(0.4, -0.3, 0.3);
  std::mt19937 rng(2);
  const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.01, &rng);
  const Pose2 predicted = truth * Pose2(0.1, -0.05, 0.03);
  auto expect_same = [](const ScanMatchResult& a, const ScanMatchResult& b, const char* when) {
    ASSERT_TRUE(a.converged && b.converged) << when;
    EXPECT_EQ(a.pose.x(), b.pose.x()) << when;
    EXPECT_EQ(a.pose.y(), b.pose.y()) << when;
    EXPECT_EQ(a.pose.theta(), b.pose.theta()) << when;
    EXPECT_EQ(a.correlative_score, b.correlative_score) << when;
    EXPECT_EQ(a.score, b.score) << when;
    EXPECT_EQ(a.candidates_scored, b.candidates_scored) << when;
    EXPECT_TRUE(a.information == b.information) << when;
  };
  ScanMatcher::ReleaseScratch();
  const ScanMatchResult first = matcher_.MatchWithinWindow(map_, predicted, scan, 0.3, 0.2);
  const size_t narrow_bytes = matcher_.ScratchBytes();
  EXPECT_GT(narrow_bytes, 0u);
  // A wide search from elsewhere writes larger tables over the same buffers.
  const ScanMatchResult wide = matcher_.MatchWithinWindow(map_, Pose2(-1.0, 1.0, -1.0), scan, 2.0, M_PI);
  ASSERT_TRUE(wide.converged) << wide.message;
  const size_t wide_bytes = matcher_.ScratchBytes();
  EXPECT_GT(wide_bytes, narrow_bytes);
  expect_same(first, matcher_.MatchWithinWindow(map_, predicted, scan, 0.3, 0.2), "after a wide search");
  // Released: nothing held, then the narrow search's tables again, in the buffers it had.
  ScanMatcher::ReleaseScratch();
  EXPECT_EQ(0u, matcher_.ScratchBytes());
  expect_same(first, matcher_.MatchWithinWindow(map_, predicted, scan, 0.3, 0.2), "after a release");
  EXPECT_EQ(narrow_bytes, matcher_.ScratchBytes());
  // Another matcher of the thread shares the tables.
  const ScanMatcher other{ScanMatcherOptions()};
  expect_same(first, other.MatchWithinWindow(map_, predicted, scan, 0.3, 0.2), "with another matcher");
  // Trimmed: the tables keep what the searches since the last trim asked for (the wide one's
  // until a trim after only narrow ones), the scratch vectors go, and results stay the same.
  ScanMatcher::ReleaseScratch();
  matcher_.MatchWithinWindow(map_, Pose2(-1.0, 1.0, -1.0), scan, 2.0, M_PI);
  const size_t wide_tables = ScanMatcher::TrimScratch();
  EXPECT_GT(wide_tables, 0u);
  EXPECT_LT(wide_tables, wide_bytes);  // without the scratch vectors
  expect_same(first, matcher_.MatchWithinWindow(map_, predicted, scan, 0.3, 0.2), "after a trim");
  const size_t narrow_tables = ScanMatcher::TrimScratch();
  EXPECT_GT(narrow_tables, 0u);
  EXPECT_LT(narrow_tables, wide_tables);
  EXPECT_LT(narrow_tables, narrow_bytes);
  expect_same(first, matcher_.MatchWithinWindow(map_, predicted, scan, 0.3, 0.2), "after a second trim");
  expect_same(wide, matcher_.MatchWithinWindow(map_, Pose2(-1.0, 1.0, -1.0), scan, 2.0, M_PI), "wide, trimmed");
  // Nothing searched since the last trim: nothing kept.
  ScanMatcher::TrimScratch();
  EXPECT_EQ(0u, ScanMatcher::TrimScratch());
  // Before a solve: either kept (trimmed) or released, never more than the last searches'.
  matcher_.MatchWithinWindow(map_, predicted, scan, 0.3, 0.2);
  ScanMatcher::ShrinkScratchForSolve(true);
  EXPECT_LE(matcher_.ScratchBytes(), narrow_tables);
  expect_same(first, matcher_.MatchWithinWindow(map_, predicted, scan, 0.3, 0.2), "after a solve's shrink");
  EXPECT_FALSE(ScanMatcher::ShrinkScratchForSolve(false));
  EXPECT_EQ(0u, matcher_.ScratchBytes());
  ScanMatcher::ReleaseScratch();
}

// One straight wall (y = 0, 30 m): a scan from 2 m away is flat along it. Started 0.3 m
// along and 4 cm across off, turned 1°, the refinement holding the along direction puts the
// pose back on the wall's distance and heading and leaves it 0.3 m along, where it started.
TEST(ScanMatcherRefineHoldingDirectionTest, PlacesAcrossAndInYawKeepsAlong) {
  sim::World world;
  world.AddWall(Eigen::Vector2d(-15.0, 0.0), Eigen::Vector2d(15.0, 0.0));
  std::mt19937 rng(5);
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  for (double x = -1.0; x <= 1.0; x += 0.25) {
    const Pose2 pose(x, 2.0, 0.0);
    map.InsertScan(pose, Eigen::Vector2d::Zero(), SimulateScan(world, pose, 0.01, &rng));
  }
  const Pose2 truth(0.1, 2.0, 0.0);
  const std::vector<Eigen::Vector2f> scan = SimulateScan(world, truth, 0.01, &rng);
  const ScanMatcher matcher{ScanMatcherOptions()};
  const Pose2 start(truth.x() + 0.3, truth.y() + 0.04, truth.theta() + M_PI / 180.0);
  const Pose2 refined = matcher.RefineHoldingDirection(map, start, Eigen::Vector2d::UnitX(), scan);
  EXPECT_NEAR(start.x(), refined.x(), 1e-9) << "held along the wall";
  EXPECT_NEAR(truth.y(), refined.y(), 0.01) << refined;
  EXPECT_NEAR(truth.theta(), refined.theta(), 0.2 * M_PI / 180.0) << refined;
  // A direction at 45°: the pose moves only along (-1, 1)/sqrt(2) (and in yaw).
  const Pose2 diagonal = matcher.RefineHoldingDirection(map, start, Eigen::Vector2d(1.0, 1.0), scan);
  EXPECT_NEAR(0.0, (diagonal.translation() - start.translation()).dot(Eigen::Vector2d(1.0, 1.0)), 1e-9);
  // Nothing to match: the start comes back.
  EXPECT_EQ(start.ToVector(), matcher.RefineHoldingDirection(map, start, Eigen::Vector2d::UnitX(), {}).ToVector());
}

// An 8 m x 5 m room with a 0.5 m box, mapped from four poses, and a scan of it from `truth`
// (range noise 5 mm).
struct MappedRoomWithBox {
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  std::vector<Eigen::Vector2f> scan;
};

MappedRoomWithBox MapRoomWithBox(const Pose2& truth) {
  sim::World world;
  world.AddBox(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(8.0, 5.0), 0.0);
  world.AddBox(Eigen::Vector2d(1.5, 1.0), Eigen::Vector2d(0.5, 0.5), 0.0);
  std::mt19937 rng(7);
  MappedRoomWithBox room;
  InsertScansFromFourPoses(world, 0.005, &rng, &room.map);
  room.scan = SimulateScan(world, truth, 0.005, &rng);
  return room;
}

// Refine (the first node's rematch, OnlineEstimatorOptions::rematch_first_node): from a start
// 0.5 degrees and 3 cm off in a room mapped from several poses, the pose comes back to the truth
// to a fraction of the offset; a rotation bound the refinement exceeds, or nothing to match,
// gives nothing.
TEST(ScanMatcherRefineTest, ReturnsTheRefinedPoseWithinItsBounds) {
  const Pose2 truth(-0.4, 0.3, 0.2);
  const MappedRoomWithBox room = MapRoomWithBox(truth);
  const LaserMap& map = room.map;
  const std::vector<Eigen::Vector2f>& scan = room.scan;
  const ScanMatcher matcher{ScanMatcherOptions()};
  const double degree = M_PI / 180.0;
  const Pose2 start(truth.x() + 0.03, truth.y() - 0.02, truth.theta() + 0.5 * degree);
  const std::optional<Pose2> refined = matcher.Refine(map, start, scan, {}, 2.0 * degree);
  ASSERT_TRUE(refined.has_value());
  EXPECT_NEAR(truth.x(), refined->x(), 0.01) << *refined;
  EXPECT_NEAR(truth.y(), refined->y(), 0.01) << *refined;
  EXPECT_NEAR(truth.theta(), refined->theta(), 0.1 * degree) << *refined;
  EXPECT_FALSE(matcher.Refine(map, start, scan, {}, 0.1 * degree).has_value()) << "it turns more than that";
  EXPECT_FALSE(matcher.Refine(map, start, {}, {}, 2.0 * degree).has_value());
}

// Refinement points (LocalSlamOptions::refine_on_middle_beams): the search places the scan on
// its own points, the refinement and the information use the refinement points, the score
// stays on the searched points. Refinement points 4 cm ahead of the scan's own put the pose 4
// cm back; the same points as the scan's give the plain match bit for bit.
TEST(ScanMatcherRefinementPointsTest, TheRefinementUsesItsOwnPointsAndTheScoreTheSearched) {
  const Pose2 truth(-0.4, 0.3, 0.2);
  const MappedRoomWithBox room = MapRoomWithBox(truth);
  const LaserMap& map = room.map;
  const std::vector<Eigen::Vector2f>& scan = room.scan;
  std::vector<Eigen::Vector2f> ahead = scan;
  for (Eigen::Vector2f& p : ahead) p.x() += 0.04f;
  const ScanMatcher matcher{ScanMatcherOptions()};
  const Pose2 predicted = truth * Pose2(0.05, -0.03, 0.02);
  const ScanMatchResult plain = matcher.MatchWithinWindow(map, predicted, scan, 0.3, 0.2);
  const ScanMatchResult same = matcher.MatchWithinWindow(map, predicted, scan, 0.3, 0.2, {}, 0.0, &scan);
  const ScanMatchResult shifted = matcher.MatchWithinWindow(map, predicted, scan, 0.3, 0.2, {}, 0.0, &ahead);
  ASSERT_TRUE(plain.converged && same.converged && shifted.converged) << plain.message << shifted.message;
  EXPECT_EQ(plain.pose.ToVector(), same.pose.ToVector());
  EXPECT_EQ(plain.score, same.score);
  EXPECT_EQ(plain.information, same.information);
  EXPECT_NEAR(truth.x(), plain.pose.x(), 0.01) << plain.pose;
  EXPECT_NEAR(truth.y(), plain.pose.y(), 0.01) << plain.pose;
  // The search is the same; the refined pose is the one that puts the points ahead on the walls.
  EXPECT_EQ(plain.correlative_score, shifted.correlative_score);
  const Pose2 back = truth * Pose2(-0.04, 0.0, 0.0);
  EXPECT_NEAR(back.x(), shifted.pose.x(), 0.01) << shifted.pose;
  EXPECT_NEAR(back.y(), shifted.pose.y(), 0.01) << shifted.pose;
  EXPECT_NEAR(truth.theta(), shifted.pose.theta(), 0.3 * M_PI / 180.0) << shifted.pose;
  // Scored on the scan's own points, 4 cm off them.
  EXPECT_LT(shifted.score, plain.score - 0.02);
  // Through Match as well.
  const ScanMatchResult through_match = matcher.Match(map, predicted, scan, {}, true, &ahead);
  ASSERT_TRUE(through_match.converged) << through_match.message;
  EXPECT_NEAR(back.x(), through_match.pose.x(), 0.01) << through_match.pose;
  // More refinement points than searched ones (refine_on_all_points): the information is a
  // mean over the points (factors/scan_cost.h: 1/sqrt(N)), so its scale does not grow with
  // them. Each point twice: the same pose and information.
  std::vector<Eigen::Vector2f> twice = scan;
  twice.insert(twice.end(), scan.begin(), scan.end());
  const ScanMatchResult doubled = matcher.MatchWithinWindow(map, predicted, scan, 0.3, 0.2, {}, 0.0, &twice);
  ASSERT_TRUE(doubled.converged) << doubled.message;
  EXPECT_NEAR(0.0, (doubled.pose.ToVector() - plain.pose.ToVector()).norm(), 1e-4) << doubled.pose;
  EXPECT_LT((doubled.information - plain.information).norm(), 1e-3 * plain.information.norm())
      << doubled.information << "\nagainst\n" << plain.information;
}

// The second mode: in a bare rectangular room a scan fits its half-turn about the room's centre
// as well as the truth (a symmetric room: ambiguous); with the pillar it fits only the truth.
TEST(ScanMatcherSecondModeTest, TellsASymmetricRoomFromAnAsymmetricOne) {
  ScanMatcherOptions options;
  options.translation_penalty_per_square_meter = 0.0;
  options.branch_and_bound_depth = 6;
  options.second_mode_exclusion_meters = 0.5;
  options.second_mode_exclusion_radians = 10.0 * M_PI / 180.0;
  const Pose2 truth(-1.0, 0.5, 0.3);
  double margins[2] = {0.0, 0.0};
  for (const bool pillar : {false, true}) {
    sim::World world;
    world.AddBox(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(6.0, 4.0), 0.0);
    if (pillar) world.AddBox(Eigen::Vector2d(1.2, 0.7), Eigen::Vector2d(0.6, 0.6), 0.0);
    std::mt19937 rng(3);
    LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
    InsertScansFromFourPoses(world, 0.01, &rng, &map);
    const std::vector<Eigen::Vector2f> scan = SimulateScan(world, truth, 0.01, &rng);
    const ScanMatchResult result =
        ScanMatcher(options).MatchWithinWindow(map, Pose2(0.0, 0.0, 0.0), scan, 2.5, M_PI);
    ASSERT_TRUE(result.converged) << result.message;
    // The best is one of the two modes (the truth or its half-turn); the second, the other.
    const Pose2 half_turn = Pose2(0.0, 0.0, M_PI) * truth;
    const auto near = [](const Pose2& a, const Pose2& b) {
      return (a.translation() - b.translation()).norm() < 0.1 && std::abs(WrapAngle(a.theta() - b.theta())) < 0.05;
    };
    if (pillar) {
      EXPECT_TRUE(near(result.pose, truth)) << result.pose;
      // Off by default: the same search without the option reports no second mode.
      const ScanMatchResult plain = ScanMatcher(ScanMatcherOptions()).MatchWithinWindow(map, Pose2(0.0, 0.0, 0.0),
                                                                                      scan, 2.5, M_PI);
      ASSERT_TRUE(plain.converged) << plain.message;
      EXPECT_EQ(0.0, plain.second_mode_correlative_score);
      EXPECT_EQ(Pose2(0.0, 0.0, 0.0).ToVector(), plain.second_mode_pose.ToVector());
    } else {
      EXPECT_TRUE(near(result.pose, truth) || near(result.pose, half_turn)) << result.pose;
      EXPECT_TRUE(near(result.second_mode_pose, near(result.pose, truth) ? half_turn : truth))
          << result.second_mode_pose;
    }
    margins[pillar ? 1 : 0] = result.correlative_score - result.second_mode_correlative_score;
  }
  EXPECT_LT(margins[0], 0.03) << "bare room: the two modes score alike";
  EXPECT_GT(margins[1], 0.05) << "with the pillar the truth stands out";
}

// The wide second mode: Match's full-window search looks for a second mode when
// wide_second_mode_exclusion_* is set (the bare room's half-turn), its narrow first try does not.
TEST(ScanMatcherSecondModeTest, WideSearchesAloneLookForASecondMode) {
  ScanMatcherOptions options;
  options.translation_penalty_per_square_meter = 0.0;
  options.branch_and_bound_depth = 6;
  options.linear_search_window_meters = 2.5;
  options.angular_search_window_radians = M_PI;
  options.fallback_linear_search_window_meters = 0.0;
  options.fallback_angular_search_window_radians = 0.0;
  options.narrow_linear_search_window_meters = 0.4;
  options.narrow_angular_search_window_radians = 10.0 * M_PI / 180.0;
  options.narrow_accept_score = 0.4;
  options.wide_second_mode_exclusion_meters = 0.5;
  options.wide_second_mode_exclusion_radians = 0.35;
  sim::World world;
  world.AddBox(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(6.0, 4.0), 0.0);
  std::mt19937 rng(3);
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  InsertScansFromFourPoses(world, 0.01, &rng, &map);
  const Pose2 truth(-1.0, 0.5, 0.3);
  const Pose2 half_turn = Pose2(0.0, 0.0, M_PI) * truth;
  const std::vector<Eigen::Vector2f> scan = SimulateScan(world, truth, 0.01, &rng);
  const ScanMatcher matcher(options);
  const auto near = [](const Pose2& a, const Pose2& b) {
    return (a.translation() - b.translation()).norm() < 0.1 && std::abs(WrapAngle(a.theta() - b.theta())) < 0.05;
  };
  // Close to the truth: the narrow try settles it, no second mode is searched.
  const ScanMatchResult narrow = matcher.Match(map, truth * Pose2(0.1, -0.05, 0.03), scan);
  ASSERT_TRUE(narrow.converged) << narrow.message;
  EXPECT_FALSE(narrow.wide_search);
  EXPECT_EQ(0.0, narrow.second_mode_correlative_score);
  // Without the narrow try: the full window, both modes.
  const ScanMatchResult wide = matcher.Match(map, Pose2(0.0, 0.0, 0.0), scan, {}, /*try_narrow_first=*/false);
  ASSERT_TRUE(wide.converged) << wide.message;
  EXPECT_TRUE(wide.wide_search);
  EXPECT_TRUE(near(wide.pose, truth) || near(wide.pose, half_turn)) << wide.pose;
  EXPECT_TRUE(near(wide.second_mode_pose, near(wide.pose, truth) ? half_turn : truth)) << wide.second_mode_pose;
  EXPECT_GT(wide.second_mode_correlative_score, 0.9 * wide.correlative_score);
}

// Paper §III-E, by hand: a wall at x = 1.025 m (20 cells, y in [-0.5, 0.5], hit at 0.2 and
// 0.6 m: a height span, so wall cells) and a box face at x = 1.425 m (30 cells, y in
// [-0.75, 0.75], hit at 0.2 m only: structure, not wall), both on cell centres, the box
// seen from its far side. 0.4 m apart: outside each other's 0.3 m window.
class WallWeightTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::vector<Eigen::Vector2f> wall, box;
    for (int k = 0; k < 20; ++k) wall.emplace_back(1.025f, -0.475f + 0.05f * k);
    for (int k = 0; k < 30; ++k) box.emplace_back(-1.075f, -0.725f + 0.05f * k);  // from (2.5, 0), facing -x
    const std::vector<float> wall_low(wall.size(), 0.2f), wall_high(wall.size(), 0.6f), box_low(box.size(), 0.2f);
    for (int pass = 0; pass < 2; ++pass) {
      map_.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), wall, nullptr, pass ? &wall_high : &wall_low);
      map_.InsertScan(Pose2(2.5, 0.0, 0.0), Eigen::Vector2d::Zero(), box, nullptr, &box_low);
    }
  }

  // The correlative score of `points` at exactly `pose` (windows 0: one candidate).
  double ScoreOfOneCandidate(double wall_weight, const Pose2& pose, const std::vector<Eigen::Vector2f>& points) const {
    ScanMatcherOptions options;
    options.linear_search_window_meters = 0.0;
    options.angular_search_window_radians = 0.0;
    options.refine_with_ceres = false;
    options.wall_weight = wall_weight;
    return ScanMatcher(options).BruteForceSearch(map_, pose, points).correlative_score;
  }

  LaserMap map_{OccupancyGridOptions(), LikelihoodFieldOptions(), /*keep_wall_field=*/true};
};

// A point on a wall cell scores the weight, a point on other structure 1, at whatever pose puts
// them there (no prediction involved).
TEST_F(WallWeightTest, APointOnAWallScoresTheWeightOnOtherStructureOne) {
  ASSERT_NE(nullptr, map_.wall_field());
  const std::vector<Eigen::Vector2f> one_point{{0.0f, 0.0f}};
  const Pose2 on_wall(1.025, 0.025, 0.0), on_box(1.425, 0.025, 0.0), nowhere(0.3, 0.025, 0.0);
  for (const double w : {1.0, 2.0, 3.5}) {
    EXPECT_NEAR(w, ScoreOfOneCandidate(w, on_wall, one_point), 1e-4) << "weight " << w;
    EXPECT_NEAR(1.0, ScoreOfOneCandidate(w, on_box, one_point), 1e-4) << "weight " << w;
    // Free space away from any surface: the penalty, unweighted.
    EXPECT_NEAR(-ScanMatcherOptions().free_space_penalty, ScoreOfOneCandidate(w, nowhere, one_point), 1e-6)
        << "weight " << w;
  }
  // The mean over points: one on the wall and one on the box, w = 2: (2 + 1) / 2.
  const std::vector<Eigen::Vector2f> two_points{{0.0f, 0.0f}, {0.4f, 0.0f}};
  EXPECT_NEAR(1.5, ScoreOfOneCandidate(2.0, on_wall, two_points), 1e-4);
  // ScoreAt (the result's `score`) stays the unweighted mean.
  EXPECT_NEAR(1.0, ScoreAt(map_, on_wall, two_points), 1e-4);
}

// A 30-point line 0.2 m from both: moved 0.2 m towards the wall it lies along the whole 20-cell
// wall (its 10 other points just past the wall's ends: about 22.8 / 30 = 0.76); moved 0.2 m the
// other way, along the whole box face (30 / 30 = 1). Unweighted the box wins; with weight 2 the
// wall does (2 × 0.76 = 1.52 > 1), from the same prediction halfway between.
TEST_F(WallWeightTest, MatcherPrefersAligningWallsOverClutter) {
  std::vector<Eigen::Vector2f> line;
  for (int k = 0; k < 30; ++k) line.emplace_back(1.225f, -0.725f + 0.05f * k);
  const Pose2 predicted = Pose2::Identity();
  for (const bool frozen : {false, true}) {
    for (const bool in_refinement : {false, true}) {
      SCOPED_TRACE(testing::Message() << "frozen " << frozen << ", in the refinement " << in_refinement);
      LaserMap map = map_;
      if (frozen) map.Freeze();
      ScanMatcherOptions options;
      options.wall_weight_in_refinement = in_refinement;
      const ScanMatchResult plain = ScanMatcher(options).Match(map, predicted, line);
      options.wall_weight = 2.0;
      const ScanMatchResult weighted = ScanMatcher(options).Match(map, predicted, line);
      ASSERT_TRUE(plain.converged && weighted.converged) << plain.message << weighted.message;
      EXPECT_NEAR(0.2, plain.pose.x(), 0.02);  // on the box
      EXPECT_NEAR(-0.2, weighted.pose.x(), 0.02);  // on the wall
      EXPECT_NEAR(0.0, WrapAngle(weighted.pose.theta()), 1.0 * M_PI / 180);
      // The search's objective counts the wall twice; `score` is the plain mean field value.
      EXPECT_NEAR(1.0, plain.score, 0.02);
      EXPECT_NEAR(0.76, weighted.score, 0.03);
      EXPECT_NEAR(2 * weighted.score, weighted.correlative_score, 0.05);
    }
  }
}

// With the wall channel the branch-and-bound bound stays exact: the same best discrete score as
// brute force, on seeded random predictions, building and frozen.
TEST_F(WallWeightTest, BranchAndBoundMatchesBruteForceWithWallWeight) {
  std::vector<Eigen::Vector2f> scan;
  for (int k = 0; k < 20; ++k) scan.emplace_back(1.025f, -0.475f + 0.05f * k);
  for (int k = 0; k < 30; ++k) scan.emplace_back(1.425f, -0.725f + 0.05f * k);
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> off(-0.3, 0.3), off_th(-0.1, 0.1);
  ScanMatcherOptions options;
  options.refine_with_ceres = false;
  options.linear_search_window_meters = 0.4;
  options.angular_search_window_radians = 0.1;
  options.min_correlative_score = 0.0;
  options.fallback_linear_search_window_meters = 0.0;
  options.fallback_angular_search_window_radians = 0.0;
  options.wall_weight = 2.5;
  const ScanMatcher matcher(options);
  LaserMap frozen = map_;
  frozen.Freeze();
  for (int trial = 0; trial < 8; ++trial) {
    const Pose2 predicted(off(rng), off(rng), off_th(rng));
    for (const LaserMap* map : {&map_, &frozen}) {
      const ScanMatchResult fast = matcher.Match(*map, predicted, scan);
      const ScanMatchResult brute = matcher.BruteForceSearch(*map, predicted, scan);
      ASSERT_TRUE(fast.converged) << "trial " << trial;
      EXPECT_FLOAT_EQ(brute.correlative_score, fast.correlative_score) << "trial " << trial;
      EXPECT_GT(fast.correlative_score, 1.0) << "trial " << trial;  // the wall counts more than once
    }
  }
}

// Weight 1, or a map that keeps no wall field: exactly the plain matcher (poses and scores bit
// for bit), so maps without labels are unaffected by the option.
TEST_F(ScanMatcherTest, WallWeightWithoutAWallFieldChangesNothing) {
  std::mt19937 rng(5);
  const Pose2 truth(0.3, -0.2, 0.4);
  const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.01, &rng);
  ASSERT_EQ(nullptr, map_.wall_field());
  ScanMatcherOptions options;
  options.wall_weight = 3.0;
  const ScanMatchResult plain = matcher_.Match(map_, truth * Pose2(0.2, 0.1, 0.05), scan);
  const ScanMatchResult weighted = ScanMatcher(options).Match(map_, truth * Pose2(0.2, 0.1, 0.05), scan);
  ASSERT_TRUE(plain.converged);
  EXPECT_EQ(plain.pose.x(), weighted.pose.x());
  EXPECT_EQ(plain.pose.y(), weighted.pose.y());
  EXPECT_EQ(plain.pose.theta(), weighted.pose.theta());
  EXPECT_EQ(plain.score, weighted.score);
  EXPECT_EQ(plain.correlative_score, weighted.correlative_score);
}

TEST_F(ScanMatcherTest, TheRefinementStopsByItsOwnRule) {
  // Predicted at the truth: the search's best candidate is the same for every rule, and only
  // the refinement that follows it differs.
  const Pose2 truth(0.41, -0.27, 0.3);
  std::mt19937 rng(3);
  const std::vector<Eigen::Vector2f> scan = SimulateScan(world_, truth, 0.01, &rng);
  auto match = [&](int max_iterations, double function_tolerance) {
    ScanMatcherOptions options;
    options.max_ceres_iterations = max_iterations;
    options.refine_function_tolerance = function_tolerance;
    return ScanMatcher(options).Match(map_, truth, scan);
  };
  const ScanMatchResult standard = match(20, 1e-6);
  ASSERT_TRUE(standard.converged) << standard.message;
  EXPECT_GE(standard.iterations, 2);
  EXPECT_LE(standard.iterations, 20);
  const ScanMatchResult capped = match(1, 1e-6);
  ASSERT_TRUE(capped.converged);
  EXPECT_LE(capped.iterations, 1);
  // Stops at the first step that lowers the cost by less than half.
  const ScanMatchResult loose = match(20, 0.5);
  ASSERT_TRUE(loose.converged);
  EXPECT_LT(loose.iterations, standard.iterations);
  for (const ScanMatchResult* result : {&standard, &capped, &loose}) {
    EXPECT_NEAR(truth.x(), result->pose.x(), 0.03);
    EXPECT_NEAR(truth.y(), result->pose.y(), 0.03);
  }
}

TEST(ScanMatcherOptionsTest, RejectsBadValues) {
  ScanMatcherOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.angular_search_window_radians = -1;
  options.branch_and_bound_depth = 20;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("angular_search_window_radians"));
  EXPECT_NE(std::string::npos, error.find("branch_and_bound_depth"));
  options = ScanMatcherOptions();
  options.wall_weight = 0.5;  // below 1: the wall channel's cost weight sqrt(w - 1) is undefined
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("wall_weight"));
  for (const double tolerance : {0.0, 1.0, std::nan("")}) {
    options = ScanMatcherOptions();
    options.refine_function_tolerance = tolerance;
    EXPECT_FALSE(options.IsValid(&error)) << tolerance;
    EXPECT_NE(std::string::npos, error.find("refine_function_tolerance"));
  }
  options = ScanMatcherOptions();
  options.max_ceres_iterations = -1;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("max_ceres_iterations"));
}

// Each voxel's first point turns a match: of the beams whose end points fall in a voxel, the
// first in scan order lies nearest the side the sweep enters by (a surface's end there, or a
// point that range noise carried across it), so the first points lie off the surfaces by an
// error whose sign goes with the sweep's direction. Matches refined on them turn one way on
// average (LocalSlamOptions::refine_on_all_points: the simulated robots' front ends turned
// +0.04 to +2.25 degrees a run), refined on each voxel's last point the other way, and on
// every point neither. 200 scans, each at its own pose in a room with a pillar, matched
// against a map of noisy scans three ways; the mean heading error of each.
TEST(ScanMatcherRefinementPointsTest, EveryPointRefinesWithoutTheFirstPointsTurn) {
  const sim::World world = RoomWithPillar();
  std::mt19937 rng(7);
  // 1440 beams (0.25 degrees, as fine as the simulated robots' lasers), 1 cm range noise.
  const auto fine_scan = [&world, &rng](const Pose2& world_T_robot) {
    return SimulateScan(world, world_T_robot, 0.01, &rng, 1440);
  };
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  for (const Pose2& pose : {Pose2(0, 0, 0), Pose2(-1.5, -0.5, 0.8), Pose2(1.0, -1.0, -2.0), Pose2(2.0, 1.2, 2.5)}) {
    map.InsertScan(pose, Eigen::Vector2d::Zero(), fine_scan(pose));
  }
  const ScanMatcher matcher{ScanMatcherOptions()};
  std::uniform_real_distribution<double> position(-0.8, 0.8), heading(-M_PI, M_PI);
  double first_sum = 0.0, last_sum = 0.0, all_sum = 0.0;
  int n = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Pose2 truth(position(rng), 0.5 * position(rng), heading(rng));
    const std::vector<Eigen::Vector2f> scan = fine_scan(truth);
    const std::vector<Eigen::Vector2f> voxels = VoxelFilter(scan, 0.2f);
    const std::vector<Eigen::Vector2f> reversed(scan.rbegin(), scan.rend());
    const std::vector<Eigen::Vector2f> last_voxels = VoxelFilter(reversed, 0.2f);
    const Pose2 predicted = truth * Pose2(0.03, -0.02, 0.01);
    const ScanMatchResult first = matcher.MatchWithinWindow(map, predicted, voxels, 0.3, 0.2);
    const ScanMatchResult last = matcher.MatchWithinWindow(map, predicted, last_voxels, 0.3, 0.2);
    const ScanMatchResult all = matcher.MatchWithinWindow(map, predicted, voxels, 0.3, 0.2, {}, 0.0, &scan);
    ASSERT_TRUE(first.converged && last.converged && all.converged) << first.message << last.message << all.message;
    first_sum += WrapAngle(first.pose.theta() - truth.theta());
    last_sum += WrapAngle(last.pose.theta() - truth.theta());
    all_sum += WrapAngle(all.pose.theta() - truth.theta());
    ++n;
  }
  const double degree = M_PI / 180.0;
  const double first_mean = first_sum / n / degree, last_mean = last_sum / n / degree, all_mean = all_sum / n / degree;
  // Measured: first +0.042, last -0.068, every point -0.009 degrees.
  EXPECT_GT(first_mean, 0.02);
  EXPECT_LT(last_mean, -0.02);
  EXPECT_LT(std::abs(all_mean), 0.25 * (first_mean - last_mean))
      << "first " << first_mean << ", last " << last_mean << ", every point " << all_mean << " deg";
}

// With more refinement points than searched ones (LocalSlamOptions::refine_on_all_points), the
// score profile takes every k-th refinement point, as many as the searched ones at most: points
// from the whole scan. In a corridor (walls at y = +-1.2 m, 30 m long) a dense scan's match is
// flat along the walls; with a wall across it 3 m ahead (a dead end), which a quarter of the
// beams see, it is not. The profile on the thinned points tells the two apart as the profile
// on all of them does, with the same drops to 10%, and the pose is the refinement's.
TEST(ScanMatcherRefinementPointsTest, TheProfileOnEveryKthPointSeesTheWholeScan) {
  const double degree = M_PI / 180.0;
  for (const bool dead_end : {false, true}) {
    SCOPED_TRACE(dead_end ? "dead end" : "open corridor");
    sim::World world;
    world.AddWall(Eigen::Vector2d(-15.0, -1.2), Eigen::Vector2d(15.0, -1.2));
    world.AddWall(Eigen::Vector2d(-15.0, 1.2), Eigen::Vector2d(15.0, 1.2));
    if (dead_end) world.AddWall(Eigen::Vector2d(3.0, -1.2), Eigen::Vector2d(3.0, 1.2));
    std::mt19937 rng(11);
    // 1440 beams from straight behind (-180°), counterclockwise, up to 8 m; 1 cm range noise.
    const auto fine_scan = [&world, &rng](const Pose2& world_T_robot) {
      return SimulateScan(world, world_T_robot, 0.01, &rng, 1440, 8.0);
    };
    LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
    for (double x = -1.0; x <= 1.0; x += 0.5) {
      const Pose2 pose(x, 0.1, 0.05);
      map.InsertScan(pose, Eigen::Vector2d::Zero(), fine_scan(pose));
    }
    const Pose2 truth(0.2, -0.1, 0.1);
    const std::vector<Eigen::Vector2f> scan = fine_scan(truth);
    const std::vector<Eigen::Vector2f> voxels = VoxelFilter(scan, 0.2f);
    ASSERT_GT(scan.size(), 4 * voxels.size());
    const ScanMatcher matcher{ScanMatcherOptions()};
    const Pose2 predicted = truth * Pose2(0.0, 0.03, 0.01);
    // Searched on the voxels, refined on every point: the profile on every k-th point.
    const ScanMatchResult thinned = matcher.MatchWithinWindow(map, predicted, voxels, 0.3, 0.2, {}, 0.0, &scan);
    // Searched and refined on every point: the profile on all of them.
    const ScanMatchResult all = matcher.MatchWithinWindow(map, predicted, scan, 0.3, 0.2, {}, 0.0, &scan);
    ASSERT_TRUE(thinned.converged && all.converged) << thinned.message << all.message;
    for (const ScanMatchResult* result : {&thinned, &all}) {
      const double ratio = result->weak_direction_score_drop / result->strong_direction_score_drop;
      if (dead_end) {
        EXPECT_GT(ratio, 0.12) << "weak " << result->weak_direction_score_drop;
      } else {
        EXPECT_LT(ratio, 0.05) << "weak " << result->weak_direction_score_drop;
        EXPECT_LT(std::abs(std::atan(result->weak_direction.y() / result->weak_direction.x())), 2.0 * degree)
            << result->weak_direction.transpose();
      }
    }
    EXPECT_NEAR(all.weak_direction_score_drop, thinned.weak_direction_score_drop,
                0.1 * all.strong_direction_score_drop);
    EXPECT_NEAR(all.strong_direction_score_drop, thinned.strong_direction_score_drop,
                0.1 * all.strong_direction_score_drop);
    EXPECT_NEAR(truth.y(), thinned.pose.y(), 0.01) << thinned.pose;
    EXPECT_NEAR(truth.theta(), thinned.pose.theta(), 0.2 * degree) << thinned.pose;
    if (dead_end) {
      EXPECT_NEAR(truth.x(), thinned.pose.x(), 0.01) << thinned.pose;
    }
  }
}

// ScanMatcherOptions::weak_direction_snap_radians: in a corridor turned 5.7° from the map's
// axes, between two of the profile's sixteen directions, a match's weak direction is the
// profile's estimate without the option and the walls' direction with it; a window narrower
// than the estimate's error leaves the estimate.
TEST(ScanMatcherProfileTest, TheWeakDirectionSnapsToTheWallsWithinTheWindow) {
  const double axis = 0.1;  // radians
  const Eigen::Vector2d along(std::cos(axis), std::sin(axis)), across(-std::sin(axis), std::cos(axis));
  sim::World world;
  for (const double side : {-1.2, 1.2}) {
    world.AddWall(-15.0 * along + side * across, 15.0 * along + side * across);
  }
  std::mt19937 rng(5);
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  for (double t = -1.0; t <= 1.0; t += 0.5) {
    const Eigen::Vector2d p = t * along + 0.1 * across;
    const Pose2 pose(p.x(), p.y(), axis + 0.05);
    map.InsertScan(pose, Eigen::Vector2d::Zero(), SimulateScan(world, pose, 0.01, &rng));
  }
  const Eigen::Vector2d p = 0.2 * along - 0.1 * across;
  const Pose2 truth(p.x(), p.y(), axis + 0.3);
  const std::vector<Eigen::Vector2f> scan = SimulateScan(world, truth, 0.01, &rng);
  const Pose2 predicted = truth * Pose2(0.0, 0.03, 0.01);
  const auto angle_off = [&along](const Eigen::Vector2d& d) {
    return std::acos(std::min(1.0, std::abs(d.dot(along))));
  };
  ScanMatcherOptions options;
  const ScanMatchResult profile = ScanMatcher(options).MatchWithinWindow(map, predicted, scan, 0.3, 0.2);
  ASSERT_TRUE(profile.converged) << profile.message;
  ASSERT_LT(profile.weak_direction_score_drop, 0.1 * profile.strong_direction_score_drop) << "flat along the walls";
  const double profile_off = angle_off(profile.weak_direction);
  options.weak_direction_snap_radians = 11.25 * M_PI / 180.0;
  const ScanMatchResult snapped = ScanMatcher(options).MatchWithinWindow(map, predicted, scan, 0.3, 0.2);
  ASSERT_TRUE(snapped.converged) << snapped.message;
  EXPECT_EQ(profile.pose.ToVector(), snapped.pose.ToVector());
  EXPECT_EQ(profile.weak_direction_score_drop, snapped.weak_direction_score_drop);
  // Measured: the profile 0.20° off, the walls 0.02°.
  EXPECT_LT(angle_off(snapped.weak_direction), 0.05 * M_PI / 180.0) << snapped.weak_direction.transpose();
  EXPECT_LT(angle_off(snapped.weak_direction), 0.25 * profile_off) << snapped.weak_direction.transpose();
  EXPECT_NEAR(1.0, snapped.weak_direction.norm(), 1e-12);
  // The same sense as the profile's.
  EXPECT_GT(snapped.weak_direction.dot(profile.weak_direction), 0.0);
  // A window narrower than the profile's error: no snap.
  options.weak_direction_snap_radians = 0.5 * profile_off;
  const ScanMatchResult narrow = ScanMatcher(options).MatchWithinWindow(map, predicted, scan, 0.3, 0.2);
  EXPECT_EQ(profile.weak_direction, narrow.weak_direction);
  // Out of range: refused.
  options.weak_direction_snap_radians = 2.0;
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("weak_direction_snap_radians")) << error;
}

}  // namespace
}  // namespace hetslam
