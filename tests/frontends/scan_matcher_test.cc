#include "frontends/scan_matcher.h"

#include <random>

#include "core/laser_map.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

// A 6 m x 4 m room ([-3, 3] x [-2, 2]) with a 0.6 m square pillar centred at (1.2, 0.7):
// no symmetry within the search window. Returns the 2D ranges of a 360-beam scan from `pose`.
struct Segment {
  Eigen::Vector2d a, b;
};

std::vector<Segment> RoomWithPillar() {
  std::vector<Segment> walls;
  auto box = [&walls](double x0, double y0, double x1, double y1) {
    walls.push_back({{x0, y0}, {x1, y0}});
    walls.push_back({{x1, y0}, {x1, y1}});
    walls.push_back({{x1, y1}, {x0, y1}});
    walls.push_back({{x0, y1}, {x0, y0}});
  };
  box(-3, -2, 3, 2);
  box(0.9, 0.4, 1.5, 1.0);
  return walls;
}

std::vector<Eigen::Vector2f> SimulateScan(const std::vector<Segment>& walls, const Pose2& world_T_robot,
                                          double noise_std, std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, noise_std);
  std::vector<Eigen::Vector2f> points;
  for (int i = 0; i < 360; ++i) {
    const double angle = -M_PI + i * M_PI / 180.0;
    const Eigen::Vector2d origin = world_T_robot.translation();
    const Eigen::Vector2d dir(std::cos(world_T_robot.theta() + angle), std::sin(world_T_robot.theta() + angle));
    double best = 1e9;
    for (const Segment& s : walls) {
      const Eigen::Vector2d e = s.b - s.a;
      const double denom = dir.x() * e.y() - dir.y() * e.x();
      if (std::abs(denom) < 1e-12) continue;
      const Eigen::Vector2d w = s.a - origin;
      const double t = (w.x() * e.y() - w.y() * e.x()) / denom;
      const double u = (w.x() * dir.y() - w.y() * dir.x()) / denom;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    if (best > 20) continue;
    const double r = best + (noise_std > 0 ? noise(*rng) : 0.0);
    points.emplace_back(static_cast<float>(r * std::cos(angle)), static_cast<float>(r * std::sin(angle)));
  }
  return points;
}

class ScanMatcherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937 rng(1);
    for (const Pose2& pose : {Pose2(0, 0, 0), Pose2(-1.5, -0.5, 0.8), Pose2(1.0, -1.0, -2.0)}) {
      map_.InsertScan(pose, Eigen::Vector2d::Zero(), SimulateScan(walls_, pose, 0.01, &rng));
    }
  }

  // Matching a scan taken at `truth` from `truth ∘ offset` lands within 2 cm / 0.5°.
  void ExpectConvergesFrom(const Pose2& truth, const Pose2& offset) {
    std::mt19937 rng(2);
    const std::vector<Eigen::Vector2f> scan = SimulateScan(walls_, truth, 0.01, &rng);
    const ScanMatchResult result = matcher_.Match(map_, truth * offset, scan);
    ASSERT_TRUE(result.converged) << result.message;
    EXPECT_NEAR(truth.x(), result.pose.x(), 0.02) << "from offset " << offset;
    EXPECT_NEAR(truth.y(), result.pose.y(), 0.02) << "from offset " << offset;
    EXPECT_NEAR(0.0, WrapAngle(truth.theta() - result.pose.theta()), 0.5 * M_PI / 180) << "from offset " << offset;
    EXPECT_GT(result.score, 0.5);
    EXPECT_GT(result.information.trace(), 0.0);
  }

  std::vector<Segment> walls_ = RoomWithPillar();
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
  std::vector<Eigen::Vector2f> scan = SimulateScan(walls_, truth, 0.01, &rng);
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
    const std::vector<Eigen::Vector2f> scan = SimulateScan(walls_, truth, 0.02, &rng);
    const Pose2 predicted = truth * Pose2(off(rng), off(rng), off_th(rng));
    const ScanMatchResult fast = matcher.Match(map_, predicted, scan);
    const ScanMatchResult brute = matcher.BruteForceSearch(map_, predicted, scan);
    ASSERT_TRUE(fast.converged);
    EXPECT_FLOAT_EQ(brute.correlative_score, fast.correlative_score) << "trial " << trial;
    EXPECT_LT(fast.candidates_scored, brute.candidates_scored) << "trial " << trial;
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
}

}  // namespace
}  // namespace hetslam
