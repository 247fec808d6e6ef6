// The particle filter's arithmetic (log-space weights, effective sample size, low-variance
// resampling, seeded draws) and its life cycle on simulated scans: spawn after suspended
// matching, collapse, deferred results committed, determinism.
#include "frontends/particle_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <vector>

#include "datasets/sim/world.h"
#include "gtest/gtest.h"
#include "tests/frontends/sim_fixtures.h"

namespace hetslam {
namespace {

TEST(NormalizedWeightsTest, SumsToOneWithoutOverflow) {
  // exp(1000) overflows a double; the log-sum-exp does not.
  const std::vector<double> weights = NormalizedWeights({1000.0, 1000.0 + std::log(3.0), -1e300});
  ASSERT_EQ(3u, weights.size());
  EXPECT_NEAR(0.25, weights[0], 1e-12);
  EXPECT_NEAR(0.75, weights[1], 1e-12);
  EXPECT_EQ(0.0, weights[2]);
  const std::vector<double> small = NormalizedWeights({-2000.0, -2000.0 - std::log(4.0)});
  EXPECT_NEAR(0.8, small[0], 1e-12);
  EXPECT_NEAR(0.2, small[1], 1e-12);
}

TEST(NormalizedWeightsTest, InfiniteAndNanEntries) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> some = NormalizedWeights({-inf, 0.0, std::nan("")});
  EXPECT_EQ(0.0, some[0]);
  EXPECT_EQ(1.0, some[1]);
  EXPECT_EQ(0.0, some[2]);
  const std::vector<double> none = NormalizedWeights({-inf, -inf});
  EXPECT_EQ(0.5, none[0]);
  EXPECT_EQ(0.5, none[1]);
  EXPECT_TRUE(NormalizedWeights({}).empty());
}

TEST(EffectiveSampleSizeTest, UniformAndDegenerate) {
  EXPECT_NEAR(4.0, EffectiveSampleSize({0.25, 0.25, 0.25, 0.25}), 1e-12);
  EXPECT_NEAR(1.0, EffectiveSampleSize({1.0, 0.0, 0.0}), 1e-12);
  EXPECT_NEAR(1.0 / (0.5 * 0.5 + 2 * 0.25 * 0.25), EffectiveSampleSize({0.5, 0.25, 0.25}), 1e-12);
}

// Against the brute-force expectation: over many seeded draws each index is picked
// count·w_i times on average, and every single draw picks it floor or ceil of that.
TEST(LowVarianceResampleTest, MatchesTheExpectationAndNeverStrays) {
  const std::vector<double> weights = {0.05, 0.4, 0.0, 0.3, 0.25};
  const int count = 7;
  std::mt19937_64 rng(42);
  std::vector<double> mean(weights.size(), 0.0);
  const int draws = 20000;
  for (int d = 0; d < draws; ++d) {
    const std::vector<int> picked = LowVarianceResample(weights, count, &rng);
    ASSERT_EQ(count, static_cast<int>(picked.size()));
    std::vector<int> times(weights.size(), 0);
    for (size_t k = 0; k < picked.size(); ++k) {
      ++times[picked[k]];
      if (k > 0) {
        ASSERT_LE(picked[k - 1], picked[k]) << "ascending";
      }
    }
    for (size_t i = 0; i < weights.size(); ++i) {
      const double expected = count * weights[i];
      ASSERT_GE(times[i], std::floor(expected) - 1e-9) << i;
      ASSERT_LE(times[i], std::ceil(expected) + 1e-9) << i;
      mean[i] += times[i];
    }
  }
  for (size_t i = 0; i < weights.size(); ++i) EXPECT_NEAR(count * weights[i], mean[i] / draws, 0.02) << i;
}

TEST(LowVarianceResampleTest, SameSeedSameIndices) {
  const std::vector<double> weights = {0.1, 0.2, 0.3, 0.4};
  std::mt19937_64 a(7), b(7);
  for (int d = 0; d < 100; ++d) EXPECT_EQ(LowVarianceResample(weights, 9, &a), LowVarianceResample(weights, 9, &b));
}

TEST(DrawTest, UniformAndNormalMoments) {
  std::mt19937_64 rng(3);
  double sum = 0, sum_sq = 0, uniform_sum = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double u = UniformDraw(&rng);
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    uniform_sum += u;
    const double x = NormalDraw(&rng);
    ASSERT_TRUE(std::isfinite(x));
    sum += x;
    sum_sq += x * x;
  }
  EXPECT_NEAR(0.5, uniform_sum / n, 0.005);
  EXPECT_NEAR(0.0, sum / n, 0.01);
  EXPECT_NEAR(1.0, sum_sq / n, 0.02);
}

TEST(ParticleFilterOptionsTest, RejectsBadValues) {
  ParticleFilterOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.max_particles = 0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("max_particles"));
  options = ParticleFilterOptions();
  options.likelihood_floor = 0.0;
  EXPECT_FALSE(options.IsValid(&error));
  options = ParticleFilterOptions();
  options.collapse_weight = 1.5;
  EXPECT_FALSE(options.IsValid(&error));
  options = ParticleFilterOptions();
  options.collapse_map_margin = std::nan("");
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("collapse_map_margin"));
  options = ParticleFilterOptions();
  options.mode_map_min_score = 1.5;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("mode_map_min_score"));
}

// The earlier map has the last word: a weight that reaches collapse_weight settles the
// ambiguity only when the particles' scores against the finished submaps do not prefer
// another particle by more than collapse_map_margin (0.02).
TEST(WeightSettlesTest, WaitsWhileTheEarlierMapPrefersAnotherParticle) {
  const ParticleFilterOptions options;
  ASSERT_DOUBLE_EQ(0.95, options.collapse_weight);
  ASSERT_DOUBLE_EQ(0.02, options.collapse_map_margin);
  const std::vector<double> weights = {0.04, 0.96};
  EXPECT_TRUE(WeightSettles(options, weights, 1, {}));                // no finished submap near
  EXPECT_TRUE(WeightSettles(options, weights, 1, {0.60, 0.62}));      // the map agrees
  EXPECT_TRUE(WeightSettles(options, weights, 1, {0.63, 0.62}));      // within the margin
  EXPECT_FALSE(WeightSettles(options, weights, 1, {0.42, 0.34}));     // Intel x 5's fifth pass
  EXPECT_FALSE(WeightSettles(options, {0.06, 0.94}, 1, {0.60, 0.62}));  // below collapse_weight
  ParticleFilterOptions off = options;
  off.collapse_map_margin = -1.0;
  EXPECT_TRUE(WeightSettles(off, weights, 1, {0.42, 0.34}));
  // Three particles: any one the map prefers holds the collapse.
  EXPECT_FALSE(WeightSettles(options, {0.01, 0.97, 0.02}, 1, {0.5, 0.5, 0.6}));
  EXPECT_TRUE(WeightSettles(options, {0.01, 0.97, 0.02}, 1, {0.5, 0.6, 0.6}));
}

TEST(SideslipTest, DrivingAndTurningIsNoSideslip) {
  EXPECT_EQ(0.0, SideslipMeters(Pose2(1.0, 0.0, 0.0)));           // straight ahead
  EXPECT_EQ(0.0, SideslipMeters(Pose2(-0.5, 0.0, 0.0)));          // straight back
  EXPECT_EQ(0.0, SideslipMeters(Pose2(0.0, 0.0, 1.0)));           // a turn on the spot
  EXPECT_EQ(0.0, SideslipMeters(Pose2(1.0, 0.1, 0.3)));           // an arc to the left (chord at 0.15 rad)
  EXPECT_EQ(0.0, SideslipMeters(Pose2(1.0, -0.1, -0.3)));         // ... and to the right
  EXPECT_EQ(0.0, SideslipMeters(Pose2(1.0, 0.25, 0.3)));          // turn, then drive (0.245 rad)
  EXPECT_EQ(0.0, SideslipMeters(Pose2(-1.0, 0.1, -0.3)));         // reversing on an arc
  EXPECT_NEAR(1.0, SideslipMeters(Pose2(0.0, 1.0, 0.0)), 1e-12);  // sideways
  EXPECT_NEAR(1.0, SideslipMeters(Pose2(0.0, -1.0, 0.0)), 1e-12);
  // 1 m ahead and 1 m to the right while turning 0.3 rad left: sqrt(2) m at pi/4 below the
  // nearer bound (heading 0).
  EXPECT_NEAR(std::sqrt(2.0) * std::sin(M_PI / 4), SideslipMeters(Pose2(1.0, -1.0, 0.3)), 1e-12);
  // ... and 1 m to the left while turning 0.3 rad right: pi/4 above the heading before.
  EXPECT_NEAR(std::sqrt(2.0) * std::sin(M_PI / 4), SideslipMeters(Pose2(1.0, 1.0, -0.3)), 1e-12);
}

// A scan in a bare rectangular room fits two places: its pose and the half-turn about the
// room's centre. Without a motion source the front end's wide search finds both; with
// spawn_on_second_mode a particle goes on at each, and the motion model (the half-turn mode
// slides the robot sideways) settles it on the truth at once.
struct ModeRun {
  std::vector<ParticleStep> steps;
  ParticleFilterStats stats;
  std::vector<Pose2> particle_poses;  // at the second scan, before any collapse
};

// A noiseless 360-beam scan (1° apart) of `world` from `truth`, every point structure, matched
// on 0.1 m voxels.
ScanPoints NoiselessScan(const sim::World& world, const Pose2& truth, double max_range_meters) {
  ScanPoints points;
  for (int i = 0; i < 360; ++i) {
    const double angle = -M_PI + i * M_PI / 180.0;
    double range = 0.0;
    if (!world.CastRay(truth.translation(), truth.theta() + angle, max_range_meters, &range)) continue;
    points.all.emplace_back(static_cast<float>(range * std::cos(angle)), static_cast<float>(range * std::sin(angle)));
  }
  points.labels.assign(points.all.size(), PointLabel::kStructure);
  points.heights_meters.assign(points.all.size(), 0.0f);
  points.valid_points = static_cast<int>(points.all.size());
  points.matching = VoxelFilter(points.all, 0.1f);
  return points;
}

ModeRun RunInBareRoom(const ParticleFilterOptions& options, const Pose2& first, const Pose2& second) {
  sim::World world;
  world.AddBox(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(6.0, 4.0), 0.0);
  LocalSlamOptions local;
  local.matcher.translation_penalty_per_square_meter = 0.0;  // the two modes score alike
  local.matcher.branch_and_bound_depth = 6;
  local.matcher.linear_search_window_meters = 2.5;
  local.matcher.angular_search_window_radians = M_PI;
  local.matcher.fallback_linear_search_window_meters = 0.0;
  local.matcher.fallback_angular_search_window_radians = 0.0;
  ParticleLocalSlam filter(local, options);
  SubmapGraph graph{SubmapGraphOptions()};
  ModeRun run;
  double stamp = 0.0;
  for (const Pose2& truth : {first, second}) {
    ScanPoints points = NoiselessScan(world, truth, 20.0);
    // The front end's own prediction (no motion source); the first scan sets the frame.
    Prediction prediction = filter.Predict(std::nullopt);
    if (stamp == 0.0) prediction.pose = first;
    run.steps.push_back(filter.AddScan(stamp, std::move(points), prediction, std::nullopt, graph, 0));
    if (stamp > 0.0) run.particle_poses = filter.Poses();
    stamp += 1.0;
  }
  run.stats = filter.stats();
  return run;
}

TEST(ParticleLocalSlamTest, SpawnsAtASecondModeAndTheMotionModelSettlesIt) {
  const Pose2 first(-0.8, 0.6, -1.5);
  const Pose2 second = first * Pose2(0.4, 0.02, 0.1);  // an arc: no sideslip
  const Pose2 half_turn = Pose2(0.0, 0.0, M_PI) * second;
  ASSERT_EQ(0.0, SideslipMeters(Between(first, second)));
  ASSERT_GT(SideslipMeters(Between(first, half_turn)), 0.5) << "the wrong mode must slide sideways";
  const auto near = [](const Pose2& a, const Pose2& b) {
    return (a.translation() - b.translation()).norm() < 0.03 && std::abs(WrapAngle(a.theta() - b.theta())) < 0.02;
  };

  ParticleFilterOptions options;
  options.spawn_on_second_mode = true;
  const ModeRun run = RunInBareRoom(options, first, second);
  ASSERT_EQ(2u, run.steps.size());
  EXPECT_TRUE(run.steps[1].spawned);
  EXPECT_EQ(2, run.steps[1].particles);
  EXPECT_EQ(1, run.stats.mode_spawns);
  // Decided at once: collapsed on the truth, the scan committed there.
  EXPECT_TRUE(run.steps[1].collapsed);
  ASSERT_EQ(1u, run.steps[1].committed.size());
  EXPECT_TRUE(near(run.steps[1].committed[0].local_pose, second)) << run.steps[1].committed[0].local_pose;
  ASSERT_EQ(1u, run.particle_poses.size());

  // With a motion model too loose to tell them apart, both modes stay alive (they score
  // alike): the spawn found them.
  options.sideslip_sigma_meters = 100.0;
  options.mode_min_sideslip_sigmas = 0.0;
  const ModeRun undecided = RunInBareRoom(options, first, second);
  EXPECT_TRUE(undecided.steps[1].spawned);
  ASSERT_EQ(2u, undecided.particle_poses.size());
  EXPECT_TRUE((near(undecided.particle_poses[0], second) && near(undecided.particle_poses[1], half_turn)) ||
              (near(undecided.particle_poses[1], second) && near(undecided.particle_poses[0], half_turn)))
      << undecided.particle_poses[0] << " " << undecided.particle_poses[1];

  // Off: one particle, whichever mode scored best.
  options.spawn_on_second_mode = false;
  const ModeRun off = RunInBareRoom(options, first, second);
  EXPECT_EQ(0, off.stats.spawns);
  EXPECT_EQ(1, off.steps[1].particles);
  EXPECT_EQ(0, off.stats.unfollowed_modes);  // not looked for
  EXPECT_EQ(0, run.stats.unfollowed_modes);  // followed
}

TEST(ParticleLocalSlamTest, ASecondModeNoParticleFollowsIsCounted) {
  const Pose2 first(-0.8, 0.6, -1.5);
  const Pose2 second = first * Pose2(0.4, 0.02, 0.1);
  ParticleFilterOptions options;
  options.spawn_on_second_mode = true;
  // No sideslip is ever enough: the sideslip could not weigh the modes (as for two places along
  // a corridor), and two scans give no change of speed either, so the scan goes on alone at the
  // better-scoring one, and is counted.
  options.mode_min_sideslip_sigmas = 1e6;
  const ModeRun run = RunInBareRoom(options, first, second);
  ASSERT_EQ(2u, run.steps.size());
  EXPECT_FALSE(run.steps[1].spawned);
  EXPECT_EQ(1, run.steps[1].particles);
  EXPECT_EQ(0, run.stats.spawns);
  EXPECT_EQ(1, run.stats.unfollowed_modes);
  EXPECT_EQ(1.0, run.stats.first_unfollowed_mode_stamp);  // the second scan's stamp
  EXPECT_EQ(1.0, run.stats.last_unfollowed_mode_stamp);
  // Without particles there is nothing to follow a mode with; none is looked for.
  options.max_particles = 1;
  const ModeRun single = RunInBareRoom(options, first, second);
  EXPECT_EQ(0, single.stats.unfollowed_modes);
  EXPECT_TRUE(std::isnan(single.stats.first_unfollowed_mode_stamp));
}

TEST(SpeedChangeTest, IsTheLaterMotionsSpeedMinusTheEarlierOnes) {
  const Pose2 start(1.0, 2.0, 0.5);
  const Pose2 middle = start * Pose2(0.5, 0.0, 0.2);  // 0.5 m in 1 s
  const Pose2 end = middle * Pose2(1.6, 1.2, 0.0);    // 2 m in 2 s
  EXPECT_NEAR(0.5, *SpeedChangeMetersPerSecond({{0.0, start}, {1.0, middle}, {3.0, end}}), 1e-12);
  // Reversing is a negative speed: -1 m/s after +0.5 m/s.
  const Pose2 back = middle * Pose2(-2.0, 0.0, 0.0);
  EXPECT_NEAR(-1.5, *SpeedChangeMetersPerSecond({{0.0, start}, {1.0, middle}, {3.0, back}}), 1e-12);
  // Only the last three poses count.
  EXPECT_NEAR(0.5, *SpeedChangeMetersPerSecond({{-5.0, Pose2(9.0, 9.0, 0.0)}, {0.0, start}, {1.0, middle}, {3.0, end}}),
              1e-12);
  EXPECT_FALSE(SpeedChangeMetersPerSecond({{0.0, start}, {1.0, middle}}).has_value());
  EXPECT_FALSE(SpeedChangeMetersPerSecond({{0.0, start}, {1.0, middle}, {1.0, end}}).has_value());  // no time
  EXPECT_FALSE(SpeedChangeMetersPerSecond({{0.0, start}, {1.0, middle}, {0.5, end}}).has_value());  // backwards
}

// A corridor with a post every metre on both sides fits a scan at every metre along it. The
// robot drives at 1 m/s, a scan a second; the last scan's prediction (the front end's own, no
// motion source) is set near the pose of the scan before, so the best-scoring match is that
// standstill, 1 m behind the truth, and the truth is its second mode. Neither slides sideways,
// so no particle follows it; the change of speed (1 m/s to 0) decides for the truth.
struct CorridorRun {
  LocalResult last;
  ParticleFilterStats stats;
};

// Six scans of `world` (`range_meters`) at x = 0.5, 1.5, ... 5.5, a second apart from
// `first_stamp`. The scans before the last one are placed by a tight motion source at the truth
// (a metre-periodic corridor cannot place them alone); the last is predicted 0.6 m short of the
// truth, near the scan before, by the front end itself (no motion source) unless
// `last_external`. `graph` holds the finished submaps the filter may weigh against.
CorridorRun DriveSixScans(const sim::World& world, double range_meters, const ParticleFilterOptions& options,
                          const SubmapGraph& graph, double first_stamp, bool last_external) {
  ParticleLocalSlam filter(LocalSlamOptions(), options);
  CorridorRun run;
  const int scans = 6;
  for (int k = 0; k < scans; ++k) {
    const Pose2 truth(0.5 + k, 0.0, 0.0);
    Prediction prediction = filter.Predict(std::nullopt);
    if (k < scans - 1) {
      prediction.pose = truth;
      prediction.external = true;
      prediction.covariance = Eigen::Vector3d(0.02 * 0.02, 0.02 * 0.02, 0.01 * 0.01).asDiagonal();
    } else {
      prediction.pose = Pose2(truth.x() - 0.6, 0.0, 0.0);
      prediction.external = last_external;
    }
    ParticleStep step = filter.AddScan(first_stamp + k, NoiselessScan(world, truth, range_meters), prediction,
                                       std::nullopt, graph, 0);
    if (k == scans - 1) run.last = step.Current();
  }
  run.stats = filter.stats();
  return run;
}

// `last_external`: the last scan's prediction comes from a motion source (no covariance).
CorridorRun RunInPostedCorridor(const ParticleFilterOptions& options, bool last_external = false) {
  sim::World world;
  world.AddWall(Eigen::Vector2d(-40.0, 1.2), Eigen::Vector2d(40.0, 1.2));
  world.AddWall(Eigen::Vector2d(-40.0, -1.2), Eigen::Vector2d(40.0, -1.2));
  for (int k = -40; k <= 40; ++k) {
    for (const double y : {1.0, -1.0}) world.AddBox(Eigen::Vector2d(k, y), Eigen::Vector2d(0.2, 0.2), 0.0);
  }
  return DriveSixScans(world, 8.0, options, SubmapGraph{SubmapGraphOptions()}, 0.0, last_external);
}

TEST(ParticleLocalSlamTest, TwoPlacesAlongACorridorAreWeighedByTheChangeOfSpeed) {
  const double truth_x = 0.5 + 5;
  ParticleFilterOptions options;
  ASSERT_GT(options.speed_change_sigma_mps, 0.0) << "on by default";
  // At the truth the scan's far end runs a metre past the mapped corridor, so the truth
  // scores below the standstill: it counts as a second mode at half the best score.
  options.second_mode_score_ratio = 0.5;
  const CorridorRun run = RunInPostedCorridor(options);
  EXPECT_EQ(1, run.stats.unfollowed_modes);
  EXPECT_EQ(1, run.stats.modes_chosen_by_motion);
  EXPECT_EQ(0, run.stats.spawns);
  EXPECT_NEAR(truth_x, run.last.local_pose.x(), 0.05) << run.last.local_pose;

  // Predicted by a motion source: no motion model, the better-scoring standstill.
  const CorridorRun predicted = RunInPostedCorridor(options, /*last_external=*/true);
  EXPECT_EQ(1, predicted.stats.unfollowed_modes);
  EXPECT_EQ(0, predicted.stats.modes_chosen_by_motion);
  EXPECT_NEAR(truth_x - 1.0, predicted.last.local_pose.x(), 0.05) << predicted.last.local_pose;
  EXPECT_NEAR(0.0, run.last.local_pose.y(), 0.05);

  // Off: the scan goes on at the better-scoring standstill, a metre behind.
  options.speed_change_sigma_mps = 0.0;
  const CorridorRun off = RunInPostedCorridor(options);
  EXPECT_EQ(1, off.stats.unfollowed_modes);
  EXPECT_EQ(0, off.stats.modes_chosen_by_motion);
  EXPECT_NEAR(truth_x - 1.0, off.last.local_pose.x(), 0.05) << off.last.local_pose;
}

// A posted corridor (posts up to x = 7) with a dead end at x = 8.6, scanned with a 4 m range:
// the scans at x = 0.5 ... 4.5 (placed by a tight motion source) do not reach the dead end, the
// last one, at x = 5.5, does. Its prediction is the front end's own, near the scan before; the
// best match is that standstill (x = 4.5), the truth its second mode. At both places the dead
// end is unmapped in the submaps being built, and at the truth so are the last 0.1 m of side
// wall: the scan alone fits the standstill better (0.67 against 0.58). With `earlier_map`, a
// first drive to the dead end and back (at the truth) left finished submaps in the graph; they
// hold the dead end where the truth puts it (0.77 there against 0.63 at the standstill).
CorridorRun RunInDeadEndCorridor(const ParticleFilterOptions& options, bool earlier_map) {
  const double kRange = 4.0;
  sim::World world;
  world.AddWall(Eigen::Vector2d(-40.0, 1.2), Eigen::Vector2d(8.6, 1.2));
  world.AddWall(Eigen::Vector2d(-40.0, -1.2), Eigen::Vector2d(8.6, -1.2));
  world.AddWall(Eigen::Vector2d(8.6, -1.2), Eigen::Vector2d(8.6, 1.2));
  for (int k = -40; k <= 7; ++k) {
    for (const double y : {1.0, -1.0}) world.AddBox(Eigen::Vector2d(k, y), Eigen::Vector2d(0.2, 0.2), 0.0);
  }
  SubmapGraph graph{SubmapGraphOptions()};
  if (earlier_map) {
    ParticleFilterOptions single = options;
    single.max_particles = 1;
    ParticleLocalSlam first_drive(LocalSlamOptions(), single);
    // Out to the dead end and back, so that the submaps holding it finish.
    for (int k = 0; k <= 64; ++k) {
      Prediction prediction = first_drive.Predict(std::nullopt);
      prediction.pose = Pose2(-8.0 + 0.5 * std::min(k, 64 - k), 0.0, k <= 32 ? 0.0 : M_PI);
      prediction.external = true;
      prediction.covariance = Eigen::Vector3d(0.02 * 0.02, 0.02 * 0.02, 0.01 * 0.01).asDiagonal();
      ParticleStep step = first_drive.AddScan(k, NoiselessScan(world, prediction.pose, kRange), prediction,
                                              std::nullopt, graph, 0);
      for (LocalResult& result : step.committed) graph.AddNode(0, std::move(result));
    }
  }
  return DriveSixScans(world, kRange, options, graph, 100.0, /*last_external=*/false);
}

TEST(ParticleLocalSlamTest, TheEarlierMapWeighsTwoPlacesAlongACorridor) {
  const double truth_x = 0.5 + 5;
  ParticleFilterOptions options;
  ASSERT_DOUBLE_EQ(0.5, options.mode_map_min_score);
  options.second_mode_score_ratio = 0.5;
  // The change of speed as good as silent: the scan and the earlier map decide.
  options.speed_change_sigma_mps = 10.0;
  // Alone, the scan fits the standstill better.
  const CorridorRun alone = RunInDeadEndCorridor(options, /*earlier_map=*/false);
  EXPECT_EQ(1, alone.stats.unfollowed_modes);
  EXPECT_EQ(0, alone.stats.modes_weighed_by_map);
  EXPECT_NEAR(truth_x - 1.0, alone.last.local_pose.x(), 0.05) << alone.last.local_pose;
  // The earlier map knows the dead end: the truth.
  const CorridorRun mapped = RunInDeadEndCorridor(options, /*earlier_map=*/true);
  EXPECT_EQ(1, mapped.stats.unfollowed_modes);
  EXPECT_EQ(1, mapped.stats.modes_weighed_by_map);
  EXPECT_EQ(1, mapped.stats.modes_chosen_by_motion);
  EXPECT_NEAR(truth_x, mapped.last.local_pose.x(), 0.05) << mapped.last.local_pose;
  // Off (the earlier map never holds the scan well enough): the standstill.
  options.mode_map_min_score = 1.0;
  const CorridorRun off = RunInDeadEndCorridor(options, /*earlier_map=*/true);
  EXPECT_EQ(0, off.stats.modes_weighed_by_map);
  EXPECT_NEAR(truth_x - 1.0, off.last.local_pose.x(), 0.05) << off.last.local_pose;
}

// The ring of rooms (tests/frontends/sim_fixtures.h), fed as scans with the true motion as an
// "external" prediction with a covariance (as the EKF gives it); some scans are marked as facing
// the floor.
struct Feed {
  sim::SimulationResult simulation;
};

Feed OfficeScans() { return Feed{testing_sim::SimulateRing(11)}; }

struct FilterRun {
  std::vector<ParticleStep> steps;
  std::vector<LocalResult> committed;
  int filtered = 0;  // scans the motion filter made no node (matched, in the map)
  ParticleFilterStats stats;
  std::vector<StampedPose2> deferred_at_end;
};

// Scans [first_suspended, first_suspended + suspended) face the floor: their points are
// marked as mostly floor hits, so LocalSlam suspends them. The first scan after them is
// corrupted (every range 30% long: its match cannot settle the pose), so the filter spawns at
// the scan after it.
FilterRun RunFilter(const sim::SimulationResult& simulation, const ParticleFilterOptions& options, int scans,
              int first_suspended, int suspended, double prediction_sigma_meters) {
  LocalSlamOptions local;
  local.motion_filter_distance_meters = 0.05;  // with one particle, some scans add nothing
  ParticleLocalSlam filter(local, options);
  SubmapGraph graph{SubmapGraphOptions()};
  FilterRun run;
  Pose2 last_truth;
  Pose2 last_fed;
  for (int k = 0; k < scans && k < static_cast<int>(simulation.log.lasers.size()); ++k) {
    LaserScan scan = simulation.log.lasers[k].scan;
    if (k == first_suspended + suspended) {
      for (double& range : scan.ranges_meters) range *= 1.3;
    }
    ScanPoints points = PrepareScanPoints(local, scan);
    if (k >= first_suspended && k < first_suspended + suspended) {
      points.floor_points = points.valid_points;  // the laser faces the floor
    }
    const Pose2 truth = simulation.truth[k].pose;
    Prediction prediction;
    if (k == 0) {
      prediction.pose = Pose2();
    } else {
      // The true motion from the pose the caller last fed its EKF, as the EKF would predict.
      prediction.pose = last_fed * Between(last_truth, truth);
      prediction.external = true;
      const double s = prediction_sigma_meters;
      prediction.covariance = Eigen::Vector3d(s * s, s * s, 0.02 * 0.02).asDiagonal();
    }
    ParticleStep step = filter.AddScan(scan.stamp_seconds, std::move(points), prediction, std::nullopt,
                                       graph, 0);
    const LocalResult& current = step.Current();
    run.filtered += current.filtered;
    if (current.inserted || current.filtered || current.awaiting_insertion) {
      last_fed = current.local_pose;
      last_truth = truth;
    }
    for (LocalResult& r : step.committed) run.committed.push_back(r);
    run.steps.push_back(std::move(step));
  }
  run.deferred_at_end = filter.DeferredPoses();
  for (LocalResult& r : filter.Collapse()) run.committed.push_back(std::move(r));
  run.stats = filter.stats();
  return run;
}

TEST(ParticleLocalSlamTest, OneParticleCommitsEveryScanAtOnce) {
  const Feed feed = OfficeScans();
  ParticleFilterOptions options;
  options.max_particles = 1;
  const FilterRun run = RunFilter(feed.simulation, options, 120, 40, 10, 0.2);
  EXPECT_EQ(0, run.stats.spawns);
  EXPECT_EQ(1, run.stats.max_particles);
  // Every scan but the suspended ones, unless the motion filter found it adds nothing.
  EXPECT_GT(run.filtered, 0);
  EXPECT_EQ(110u, run.committed.size() + run.filtered);
  for (const ParticleStep& step : run.steps) {
    EXPECT_EQ(1, step.particles);
    EXPECT_TRUE(step.Current().inserted || step.Current().suspended || step.Current().filtered);
    EXPECT_EQ(!step.Current().inserted, step.current.has_value());
  }
}

TEST(ParticleLocalSlamTest, SpawnsAfterSuspensionDefersAndCollapses) {
  const Feed feed = OfficeScans();
  ParticleFilterOptions options;
  options.max_particles = 5;
  options.max_ambiguous_scans = 15;
  const FilterRun run = RunFilter(feed.simulation, options, 120, 40, 10, 0.2);
  EXPECT_GE(run.stats.spawns, 1);
  EXPECT_EQ(5, run.stats.max_particles);
  EXPECT_GE(run.stats.collapses, 1);
  // The first scan after the suspension (scan 50) is corrupted: spawned at scan 51.
  EXPECT_EQ(1, run.steps[50].particles);
  EXPECT_TRUE(run.steps[51].spawned);
  EXPECT_EQ(5, run.steps[51].particles);
  // While deferred, nothing is committed; every inserted scan is committed exactly once (with
  // several particles the motion filter is off: they all insert the same scans).
  EXPECT_TRUE(run.steps[51].committed.empty() || run.steps[51].collapsed);
  EXPECT_EQ(110u, run.committed.size() + run.filtered);
  for (const ParticleStep& step : run.steps) EXPECT_TRUE(step.particles == 1 || !step.Current().filtered);
  std::map<double, int> committed_stamps;
  for (const LocalResult& r : run.committed) ++committed_stamps[r.stamp_seconds];
  for (const auto& [stamp, times] : committed_stamps) EXPECT_EQ(1, times) << stamp;
  for (size_t i = 1; i < run.committed.size(); ++i) {
    EXPECT_LT(run.committed[i - 1].stamp_seconds, run.committed[i].stamp_seconds);
  }
  // The committed trajectory stays on the truth: the best particle won.
  for (const LocalResult& r : run.committed) {
    const auto it = std::find_if(feed.simulation.truth.begin(), feed.simulation.truth.end(),
                                 [&](const StampedPose2& t) { return t.stamp_seconds == r.stamp_seconds; });
    ASSERT_NE(feed.simulation.truth.end(), it);
    const Pose2 start = feed.simulation.truth.front().pose;
    const Pose2 truth = Between(start, it->pose);
    EXPECT_LT((r.local_pose.translation() - truth.translation()).norm(), 0.15) << r.stamp_seconds;
  }
  // One extra particle: its deferred poses and matching subsets; it changes no cell while it
  // lives (the kept particle's scans go into the submaps at the collapse).
  EXPECT_GT(run.stats.max_extra_particle_bytes, 0u);
  EXPECT_LT(run.stats.max_extra_particle_bytes, 200u * 1024);
}

// The per-particle submap copies (insert_while_ambiguous) commit the same scans, each once, on
// the truth; an extra particle then costs its copies of the active submaps.
TEST(ParticleLocalSlamTest, InsertWhileAmbiguousCommitsTheSameScans) {
  const Feed feed = OfficeScans();
  ParticleFilterOptions options;
  options.max_particles = 5;
  options.max_ambiguous_scans = 15;
  options.insert_while_ambiguous = true;
  const FilterRun copies = RunFilter(feed.simulation, options, 120, 40, 10, 0.2);
  options.insert_while_ambiguous = false;
  const FilterRun deferred = RunFilter(feed.simulation, options, 120, 40, 10, 0.2);
  EXPECT_GE(copies.stats.spawns, 1);
  EXPECT_EQ(110u, copies.committed.size() + copies.filtered);
  std::map<double, int> committed_stamps;
  for (const LocalResult& r : copies.committed) {
    ++committed_stamps[r.stamp_seconds];
    EXPECT_TRUE(r.inserted);
    EXPECT_FALSE(r.awaiting_insertion);
    const auto it = std::find_if(feed.simulation.truth.begin(), feed.simulation.truth.end(),
                                 [&](const StampedPose2& t) { return t.stamp_seconds == r.stamp_seconds; });
    ASSERT_NE(feed.simulation.truth.end(), it);
    const Pose2 truth = Between(feed.simulation.truth.front().pose, it->pose);
    EXPECT_LT((r.local_pose.translation() - truth.translation()).norm(), 0.15) << r.stamp_seconds;
  }
  for (const auto& [stamp, times] : committed_stamps) EXPECT_EQ(1, times) << stamp;
  for (const LocalResult& r : deferred.committed) {
    EXPECT_TRUE(r.inserted);
    EXPECT_FALSE(r.awaiting_insertion);
  }
  EXPECT_GT(copies.stats.max_extra_particle_bytes, 10 * deferred.stats.max_extra_particle_bytes);
}

TEST(ParticleLocalSlamTest, NoSpawnWhenThePredictionIsCertain) {
  const Feed feed = OfficeScans();
  ParticleFilterOptions options;
  options.max_particles = 5;
  options.spawn_min_sigma_meters = 0.5;
  const FilterRun run = RunFilter(feed.simulation, options, 80, 40, 10, 0.2);
  EXPECT_EQ(0, run.stats.spawns);
}

TEST(ParticleLocalSlamTest, SameSeedSameBytes) {
  const Feed feed = OfficeScans();
  ParticleFilterOptions options;
  options.max_particles = 5;
  options.max_ambiguous_scans = 15;
  const FilterRun a = RunFilter(feed.simulation, options, 100, 40, 10, 0.2);
  const FilterRun b = RunFilter(feed.simulation, options, 100, 40, 10, 0.2);
  ASSERT_GT(a.stats.spawns, 0);
  ASSERT_EQ(a.committed.size(), b.committed.size());
  for (size_t i = 0; i < a.committed.size(); ++i) {
    ASSERT_EQ(a.committed[i].local_pose.x(), b.committed[i].local_pose.x()) << i;
    ASSERT_EQ(a.committed[i].local_pose.y(), b.committed[i].local_pose.y()) << i;
    ASSERT_EQ(a.committed[i].local_pose.theta(), b.committed[i].local_pose.theta()) << i;
  }
  EXPECT_EQ(a.stats.resamples, b.stats.resamples);
}

}  // namespace
}  // namespace hetslam
