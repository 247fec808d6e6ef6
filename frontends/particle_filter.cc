#include "frontends/particle_filter.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "Eigen/Eigenvalues"
#include "frontends/scan_matcher.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

// Heap bytes of a scan's points.
size_t PointsBytes(const ScanPoints& points) {
  return (points.all.capacity() + points.matching.capacity() + points.refinement.capacity() +
          points.floor_obstacles.capacity()) *
             sizeof(Eigen::Vector2f) +
         points.labels.capacity() * sizeof(PointLabel) +
         (points.heights_meters.capacity() + points.matching_weights.capacity()) * sizeof(float);
}

// Log-likelihood of a scan whose mean likelihood-field value is `score` (see
// ParticleFilterOptions::effective_points).
double ScanLogLikelihood(const ParticleFilterOptions& options, double score) {
  const double p = options.likelihood_floor + (1.0 - options.likelihood_floor) * std::clamp(score, 0.0, 1.0);
  return options.effective_points * std::log(p);
}

// The motion model's log-likelihood of the last motion in `recent` (at least two poses): its
// sideslip and, given a third pose, its change of speed (see sideslip_sigma_meters and
// speed_change_sigma_mps; a term whose sigma is 0 is left out).
double MotionLogLikelihood(const ParticleFilterOptions& options, const std::vector<StampedPose2>& recent) {
  CHECK_GE(recent.size(), 2u);
  double log_likelihood = 0.0;
  if (options.sideslip_sigma_meters > 0) {
    const double s =
        SideslipMeters(Between(recent[recent.size() - 2].pose, recent.back().pose)) / options.sideslip_sigma_meters;
    log_likelihood -= 0.5 * s * s;
  }
  const std::optional<double> change = SpeedChangeMetersPerSecond(recent);
  if (options.speed_change_sigma_mps > 0 && change.has_value()) {
    const double a = *change / options.speed_change_sigma_mps;
    log_likelihood -= 0.5 * a * a;
  }
  return log_likelihood;
}

// Whether `a` lies within the collapse spread of `b` (translation and yaw).
bool WithinSpread(const ParticleFilterOptions& options, const Pose2& a, const Pose2& b) {
  return (a.translation() - b.translation()).norm() <= options.collapse_spread_meters &&
         std::abs(Between(a, b).theta()) <= options.collapse_spread_radians;
}

// The front end's options, its matcher searching its wide windows for a second mode when the
// filter spawns there.
LocalSlamOptions WithSecondModeSearch(LocalSlamOptions local, const ParticleFilterOptions& options) {
  if (options.spawn_on_second_mode && options.max_particles > 1) {
    local.matcher.wide_second_mode_exclusion_meters = options.second_mode_exclusion_meters;
    local.matcher.wide_second_mode_exclusion_radians = options.second_mode_exclusion_radians;
    local.matcher.wide_second_mode_min_score_ratio = options.second_mode_score_ratio;
  }
  return local;
}

}  // namespace

std::vector<double> NormalizedWeights(const std::vector<double>& log_weights) {
  std::vector<double> weights(log_weights.size(), 0.0);
  if (log_weights.empty()) return weights;
  double max_log = -std::numeric_limits<double>::infinity();
  for (double l : log_weights) {
    if (l == l) max_log = std::max(max_log, l);  // NaN compares false: skipped
  }
  if (!std::isfinite(max_log)) {
    std::fill(weights.begin(), weights.end(), 1.0 / log_weights.size());
    return weights;
  }
  double sum = 0.0;
  for (size_t i = 0; i < log_weights.size(); ++i) {
    const double l = log_weights[i];
    weights[i] = l == l ? std::exp(l - max_log) : 0.0;  // in [0, 1]: no overflow
    sum += weights[i];
  }
  for (double& w : weights) w /= sum;  // sum >= 1: the maximum contributes exp(0)
  return weights;
}

double EffectiveSampleSize(const std::vector<double>& weights) {
  double sum_squares = 0.0;
  for (double w : weights) sum_squares += w * w;
  return sum_squares > 0 ? 1.0 / sum_squares : 0.0;
}

std::optional<double> SpeedChangeMetersPerSecond(const std::vector<StampedPose2>& recent) {
  const size_t n = recent.size();
  if (n < 3) return std::nullopt;
  // Signed by the direction of travel in the earlier pose's frame: reversing is negative.
  auto speed = [](const StampedPose2& from, const StampedPose2& to) -> std::optional<double> {
    const double dt = to.stamp_seconds - from.stamp_seconds;
    if (!(dt > 0)) return std::nullopt;
    const Pose2 motion = Between(from.pose, to.pose);
    return (motion.x() < 0 ? -1.0 : 1.0) * motion.translation().norm() / dt;
  };
  const std::optional<double> earlier = speed(recent[n - 3], recent[n - 2]);
  const std::optional<double> later = speed(recent[n - 2], recent[n - 1]);
  if (!earlier.has_value() || !later.has_value()) return std::nullopt;
  return *later - *earlier;
}

double SideslipMeters(const Pose2& motion) {
  Eigen::Vector2d t = motion.translation();
  if (t.x() < 0) t = -t;  // reversing: the same cone about the backward heading
  if (t.squaredNorm() == 0) return 0.0;
  const double direction = std::atan2(t.y(), t.x());  // in [-pi/2, pi/2]
  const double low = std::min(0.0, motion.theta()), high = std::max(0.0, motion.theta());
  if (direction >= low && direction <= high) return 0.0;
  const double away = direction < low ? low - direction : direction - high;
  return t.norm() * std::sin(std::min(away, 0.5 * M_PI));
}

double UniformDraw(std::mt19937_64* rng) { return static_cast<double>((*rng)() >> 11) * 0x1.0p-53; }

double NormalDraw(std::mt19937_64* rng) {
  // Box-Muller; 1 - u is in (0, 1], so the logarithm is finite.
  const double u1 = 1.0 - UniformDraw(rng);
  const double u2 = UniformDraw(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

std::vector<int> LowVarianceResample(const std::vector<double>& weights, int count, std::mt19937_64* rng) {
  CHECK(!weights.empty()) << "LowVarianceResample: no weights";
  CHECK_GT(count, 0) << "LowVarianceResample: count " << count;
  std::vector<int> picked;
  picked.reserve(count);
  const double step = 1.0 / count;
  const double offset = UniformDraw(rng) * step;
  int i = 0;
  double cumulative = weights[0];
  for (int m = 0; m < count; ++m) {
    const double tooth = offset + m * step;
    while (tooth > cumulative && i + 1 < static_cast<int>(weights.size())) cumulative += weights[++i];
    picked.push_back(i);
  }
  return picked;
}

bool ParticleFilterOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(max_particles >= 1 && max_particles <= 1000)) msg << "max_particles must be in [1, 1000]; ";
  if (!(spawn_min_sigma_meters >= 0 && std::isfinite(spawn_min_sigma_meters)))
    msg << "spawn_min_sigma_meters must be >= 0; ";
  if (!(effective_points > 0 && effective_points <= 1e4)) msg << "effective_points must be in (0, 10000]; ";
  if (!(likelihood_floor > 0 && likelihood_floor < 1)) msg << "likelihood_floor must be in (0, 1); ";
  if (!(resample_ess_fraction >= 0 && resample_ess_fraction <= 1)) msg << "resample_ess_fraction must be in [0, 1]; ";
  if (!(collapse_weight > 0 && collapse_weight <= 1)) msg << "collapse_weight must be in (0, 1]; ";
  if (!(settled_min_score >= 0 && settled_min_score <= 1)) msg << "settled_min_score must be in [0, 1]; ";
  if (!(decisive_weight_ratio >= 1 && std::isfinite(decisive_weight_ratio)))
    msg << "decisive_weight_ratio must be >= 1; ";
  if (std::isnan(collapse_map_margin)) msg << "collapse_map_margin must be a number (negative: off); ";
  if (!(collapse_spread_meters >= 0 && collapse_spread_radians >= 0))
    msg << "collapse spreads must be >= 0; ";
  if (max_ambiguous_scans < 1) msg << "max_ambiguous_scans must be >= 1; ";
  if (!(global_margin_meters >= 0 && std::isfinite(global_margin_meters))) msg << "global_margin_meters must be >= 0; ";
  if (!(second_mode_exclusion_meters > 0 && second_mode_exclusion_meters <= 50 && second_mode_exclusion_radians > 0 &&
        second_mode_exclusion_radians <= M_PI))
    msg << "second_mode_exclusion_meters must be in (0, 50] and second_mode_exclusion_radians in (0, pi]; ";
  if (!(sideslip_sigma_meters >= 0 && std::isfinite(sideslip_sigma_meters)))
    msg << "sideslip_sigma_meters must be >= 0; ";
  if (!(mode_min_sideslip_sigmas >= 0 && std::isfinite(mode_min_sideslip_sigmas)))
    msg << "mode_min_sideslip_sigmas must be >= 0; ";
  if (!(speed_change_sigma_mps >= 0 && std::isfinite(speed_change_sigma_mps)))
    msg << "speed_change_sigma_mps must be >= 0; ";
  if (!(mode_map_min_score >= 0 && mode_map_min_score <= 1)) msg << "mode_map_min_score must be in [0, 1]; ";
  if (!(second_mode_score_ratio > 0 && second_mode_score_ratio <= 1))
    msg << "second_mode_score_ratio must be in (0, 1]; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

ParticleLocalSlam::ParticleLocalSlam(const LocalSlamOptions& local_options, const ParticleFilterOptions& options)
    : options_(options), slam_(WithSecondModeSearch(local_options, options)), particles_(1), rng_(options.seed) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid ParticleFilterOptions: " << error;
}

Prediction ParticleLocalSlam::Predict(const std::optional<Pose2>& odometry) const {
  return slam_.PredictFrom(particles_[best_].state, odometry);
}

void ParticleLocalSlam::Spawn(const Eigen::Matrix3d& covariance, const Prediction& prediction,
                              std::vector<Prediction>* predictions) {
  // covariance = V diag(λ) V^T; a draw is V sqrt(λ) n with n standard normal (λ < 0 from
  // rounding taken as 0): valid for the rank-one spread along a weak direction too.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(0.5 * (covariance + covariance.transpose()));
  const Eigen::Matrix3d root = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  particles_[0].undisturbed = true;
  Particle parent = particles_[0];
  parent.undisturbed = false;
  spawn_submaps_ = parent.state.active;  // shared: the particles copy what they change
  // The weights score against every one of them, fields up to date (LaserMap::UpdateField).
  for (ActiveSubmap& submap : spawn_submaps_) submap.map->UpdateField();
  for (int k = 1; k < options_.max_particles; ++k) {
    Eigen::Vector3d n;
    for (int j = 0; j < 3; ++j) n(j) = NormalDraw(&rng_);
    const Eigen::Vector3d delta = root * n;
    Prediction p = prediction;
    p.pose = Pose2(prediction.pose.translation() + delta.head<2>(), prediction.pose.theta() + delta(2));
    particles_.push_back(parent);
    predictions->push_back(p);
  }
  ++stats_.spawns;
}

bool ParticleLocalSlam::SpawnAtSecondMode(double stamp_seconds, const ScanPoints& points, bool motion_source,
                                          LocalSlamState before, const SubmapGraph& graph, int robot,
                                          std::vector<LocalResult>* results) {
  const LocalResult& first = results->front();
  const ScanMatchResult& match = first.match;
  const double ratio = options_.second_mode_score_ratio;
  if (!first.awaiting_insertion || !first.matched || !match.converged || !match.wide_search ||
      match.second_mode_correlative_score <= 0 || match.second_mode_correlative_score < ratio * match.correlative_score ||
      before.active.empty()) {
    return false;
  }
  // The second mode is in the frame of the submap matched against (the oldest active one,
  // unchanged by the match).
  const LocalSlamOptions& local = slam_.options();
  const double r = local.grid.resolution_meters;
  const double step = local.matcher.max_angular_step_radians;
  Prediction at_mode;
  at_mode.pose = before.active.front().local_T_submap * match.second_mode_pose;
  at_mode.external = false;
  at_mode.measures_translation = false;
  // A cell and a yaw step: the search stays near the mode (the narrow windows plus three of
  // these), and a poor fit that leaves it counts as failed (outlier_max_score).
  at_mode.covariance = Eigen::Vector3d(r * r, r * r, step * step).asDiagonal();
  std::swap(*slam_.mutable_state(), before);
  LocalResult second = slam_.Match(stamp_seconds, points, at_mode);
  std::swap(*slam_.mutable_state(), before);
  const Pose2 apart = Between(first.local_pose, second.local_pose);
  const bool distinct = std::abs(apart.x()) > options_.second_mode_exclusion_meters ||
                        std::abs(apart.y()) > options_.second_mode_exclusion_meters ||
                        std::abs(apart.theta()) > options_.second_mode_exclusion_radians;
  if (!second.awaiting_insertion || !second.match.converged || !distinct) {
    return false;
  }
  // Only where the motion model can weigh the two modes: one of them slides the robot
  // sideways. Two modes along the direction of travel (a corridor's length) are told apart by
  // the scans alone, whose evidence there is noise: measured on ACES (15 spawns, mostly such)
  // and Intel, the particles drifted apart along corridors and the kept one was often wrong
  // (ACES 0.113 -> 8.7 m against GMapping, Intel's relations 0.022 -> 0.14 m).
  const std::vector<StampedPose2>& recent_first = particles_[0].state.recent;
  bool followed = recent_first.size() >= 2 && options_.sideslip_sigma_meters > 0;
  if (followed) {
    const Pose2& previous = recent_first[recent_first.size() - 2].pose;
    const double sideslip = std::max(SideslipMeters(Between(previous, first.local_pose)),
                                     SideslipMeters(Between(previous, second.local_pose)));
    followed = sideslip >= options_.sideslip_sigma_meters * options_.mode_min_sideslip_sigmas;
  }
  if (!followed) {
    if (stats_.unfollowed_modes++ == 0) stats_.first_unfollowed_mode_stamp = stamp_seconds;
    stats_.last_unfollowed_mode_stamp = stamp_seconds;
    // Weighed at once by the scan and the motion model, when that includes a change of speed
    // for both: both modes' states hold three poses, the newest at the mode (`before` was
    // matched at the second). Without one (too few poses, stamps that do not advance) the
    // better-scoring mode stays.
    const std::vector<StampedPose2>& recent_second = before.recent;
    if (!motion_source && options_.speed_change_sigma_mps > 0 &&
        SpeedChangeMetersPerSecond(recent_first).has_value() && SpeedChangeMetersPerSecond(recent_second).has_value()) {
      double first_log = ScanLogLikelihood(options_, match.score) + MotionLogLikelihood(options_, recent_first);
      double second_log = ScanLogLikelihood(options_, second.match.score) + MotionLogLikelihood(options_, recent_second);
      // The earlier map too, as for particles: the graph's finished submaps near either place.
      const std::optional<std::vector<double>> map =
          options_.mode_map_min_score < 1.0
              ? GraphScores(points, {first.local_pose, second.local_pose}, graph, robot)
              : std::nullopt;
      if (map.has_value() && std::max((*map)[0], (*map)[1]) >= options_.mode_map_min_score) {
        first_log += ScanLogLikelihood(options_, (*map)[0]);
        second_log += ScanLogLikelihood(options_, (*map)[1]);
        ++stats_.modes_weighed_by_map;
      }
      if (second_log > first_log) {
        particles_[0].state = std::move(before);
        results->front() = std::move(second);
        ++stats_.modes_chosen_by_motion;
      }
    }
    return false;
  }
  // Two particles from this scan on; its results are deferred like every scan's while several
  // live. Neither is the undisturbed one: the evidence alone picks at the collapse.
  particles_[0].undisturbed = false;
  Particle other = particles_[0];
  other.state = std::move(before);
  particles_.push_back(std::move(other));
  spawn_submaps_ = particles_[0].state.active;
  for (ActiveSubmap& submap : spawn_submaps_) submap.map->UpdateField();
  results->push_back(std::move(second));
  ambiguous_scans_ = 0;
  ++stats_.spawns;
  ++stats_.mode_spawns;
  return true;
}

ParticleStep ParticleLocalSlam::AddScan(double stamp_seconds, ScanPoints points, const Prediction& prediction,
                                        const std::optional<Pose2>& odometry, const SubmapGraph& graph, int robot) {
  ++stats_.scans;
  ParticleStep step;
  // Per-particle predictions: the best particle's is the caller's.
  const bool relative = prediction.external && !prediction.motion.has_value() && reference_pose_.has_value();
  std::vector<Prediction> predictions;
  for (int i = 0; i < num_particles(); ++i) {
    if (i == best_) {
      predictions.push_back(prediction);
    } else if (relative) {
      Prediction p = prediction;
      const std::vector<StampedPose2>& recent = particles_[i].state.recent;
      const Pose2 last = recent.empty() ? *reference_pose_ : recent.back().pose;
      p.pose = last * Between(*reference_pose_, prediction.pose);
      predictions.push_back(p);
    } else {
      Prediction p = slam_.PredictFrom(particles_[i].state, odometry);
      // The caller's source flags (and covariance) hold for every particle.
      p.external = prediction.external;
      p.measures_translation = prediction.measures_translation;
      if (!p.covariance.has_value()) p.covariance = prediction.covariance;
      predictions.push_back(p);
    }
  }
  // A trigger spawns at the first scan that will be matched (not facing the floor, enough points).
  const bool usable = !FacesFloor(slam_.options(), points) &&
                      static_cast<int>(points.all.size()) >= slam_.options().min_points;
  if (usable && num_particles() == 1 && spawn_covariance_.has_value()) {
    Spawn(*spawn_covariance_, prediction, &predictions);
    step.spawned = true;
    ambiguous_scans_ = 0;
    spawn_covariance_.reset();
  }

  int n = num_particles();
  std::vector<LocalResult> results(n);
  // (c): the lone particle's scan is matched first and inserted only when it found no second
  // mode; the state before the match (what the match changes: the recent poses and odometry)
  // and the points are kept for a match at the second mode.
  const bool mode_spawning = n == 1 && options_.spawn_on_second_mode && options_.max_particles > 1;
  std::optional<LocalSlamState> before_match;
  std::optional<ScanPoints> mode_points;
  for (int i = 0; i < n; ++i) {
    std::swap(*slam_.mutable_state(), particles_[i].state);
    // Several particles insert every scan: they must all insert the same ones (and the
    // deferred results are all nodes).
    if (mode_spawning) {
      mode_points = points;
      const LocalSlamState& state = slam_.state();
      const std::vector<StampedPose2> recent = state.recent;
      const std::optional<Pose2> last_odometry = state.last_odometry;
      results[i] = slam_.Match(stamp_seconds, std::move(points), predictions[i]);
      const ScanMatchResult& m = results[i].match;
      if (results[i].awaiting_insertion && m.wide_search && m.converged &&
          m.second_mode_correlative_score >= options_.second_mode_score_ratio * m.correlative_score) {
        // A candidate: keep the state as it was before the match (sharing the maps: nothing is
        // inserted while it lives).
        before_match = slam_.state();
        before_match->recent = recent;
        before_match->last_odometry = last_odometry;
      } else if (results[i].awaiting_insertion) {
        slam_.Insert(&results[i]);
      }
    } else if (n == 1) {
      results[i] = slam_.AddScan(stamp_seconds, std::move(points), predictions[i]);
    } else if (options_.insert_while_ambiguous) {
      results[i] = slam_.AddScan(stamp_seconds, points, predictions[i], /*motion_filter=*/false);
    } else {
      // Matched against the submaps as they were at the spawn; inserted when the filter
      // collapses, if this particle is kept.
      results[i] = slam_.Match(stamp_seconds, points, predictions[i]);
    }
    std::swap(*slam_.mutable_state(), particles_[i].state);
    stats_.match_seconds += results[i].match_seconds;
    stats_.insert_seconds += results[i].insert_seconds;
  }
  if (before_match.has_value()) {
    LocalSlamState before = std::move(*before_match);
    before_match.reset();
    if (SpawnAtSecondMode(stamp_seconds, *mode_points, predictions[0].external, std::move(before), graph, robot,
                          &results)) {
      step.spawned = true;
      points = std::move(*mode_points);
      n = num_particles();
    } else {
      std::swap(*slam_.mutable_state(), particles_[0].state);
      slam_.Insert(&results[0]);
      std::swap(*slam_.mutable_state(), particles_[0].state);
      stats_.insert_seconds += results[0].insert_seconds;
    }
  }
  stats_.particle_scans += n;
  stats_.max_particles = std::max(stats_.max_particles, n);

  if (n == 1) {
    LocalResult& result = results[0];
    if (result.suspended) after_suspension_ = true;
    if (result.inserted || result.filtered) {
      reference_pose_ = result.local_pose;
      // The first match after suspended matching: when it cannot settle the pose (it failed,
      // or scored below settled_min_score) and the prediction that carried the pose is
      // uncertain, spread particles from its covariance.
      const bool settled = result.match.converged && result.match.score >= options_.settled_min_score;
      if (after_suspension_ && result.matched && !settled && options_.spawn_after_suspension &&
          options_.max_particles > 1 && prediction.covariance.has_value()) {
        const double sigma = std::sqrt(std::max(
            0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(prediction.covariance->topLeftCorner<2, 2>())
                     .eigenvalues()(1)));
        if (sigma >= options_.spawn_min_sigma_meters) spawn_covariance_ = *prediction.covariance;
      }
      after_suspension_ = false;
      // A degenerate match under an uncertain prediction: spread along the weak direction.
      if (result.degenerate && options_.spawn_on_degenerate && options_.max_particles > 1 &&
          prediction.covariance.has_value()) {
        const Eigen::Vector2d& w = result.weak_direction;
        const double variance = w.dot(prediction.covariance->topLeftCorner<2, 2>() * w);
        if (variance >= options_.spawn_min_sigma_meters * options_.spawn_min_sigma_meters) {
          Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
          spread.topLeftCorner<2, 2>() = variance * w * w.transpose();
          spawn_covariance_ = spread;
        }
      }
      if (result.inserted) {
        step.committed.push_back(std::move(result));
        return step;
      }
    }
    step.current = std::move(result);
    return step;
  }

  // Several particles: weights from the scan at each particle's matched pose.
  ++ambiguous_scans_;
  map_scores_.clear();
  const auto weight_start = std::chrono::steady_clock::now();
  if (results[0].inserted || results[0].awaiting_insertion) {
    // Against the submaps as they were at the spawn (shared by all particles, so the
    // comparison is fair: a particle's own submaps agree with its own later scans whatever
    // its pose), and against the graph's finished submaps.
    for (int i = 0; i < n; ++i) {
      double score = 0.0;
      for (const ActiveSubmap& submap : spawn_submaps_) {
        if (submap.num_scans == 0) continue;
        score = std::max(score, ScoreAt(*submap.map, submap.local_T_submap.inverse() * results[i].local_pose,
                                        points.matching));
      }
      particles_[i].log_weight += ScanLogLikelihood(options_, score);
      // The motion model where no motion source predicted the scan (see sideslip_sigma_meters).
      const std::vector<StampedPose2>& recent = particles_[i].state.recent;
      if (options_.sideslip_sigma_meters > 0 && !predictions[std::min<size_t>(i, predictions.size() - 1)].external &&
          results[i].matched && results[i].match.converged && recent.size() >= 2) {
        particles_[i].log_weight += MotionLogLikelihood(options_, recent);
      }
    }
    ScoreAgainstGraph(points, results, graph, robot);
  }
  stats_.weight_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - weight_start).count();
  const std::vector<double> weights = Weights();
  best_ = static_cast<int>(std::max_element(weights.begin(), weights.end()) - weights.begin());
  // Every particle matched the same points: all were matched, or none (suspended, too few).
  auto deferrable = [](const LocalResult& r) { return r.inserted || r.awaiting_insertion; };
  const bool inserted = deferrable(results[best_]);
  if (inserted) reference_pose_ = results[best_].local_pose;
  LocalResult not_inserted = inserted ? LocalResult() : std::move(results[best_]);
  if (inserted) {
    // The scan's points, once for every particle (they differ only in the matching subset).
    auto scan = std::make_shared<ScanPoints>();
    ScanPoints& common = results[best_].points;
    scan->all = std::move(common.all);
    scan->labels = std::move(common.labels);
    scan->heights_meters = std::move(common.heights_meters);
    scan->floor_obstacles = std::move(common.floor_obstacles);
    for (int i = 0; i < n; ++i) {
      ScanPoints& own = results[i].points;
      std::vector<Eigen::Vector2f>().swap(own.all);
      std::vector<PointLabel>().swap(own.labels);
      std::vector<float>().swap(own.heights_meters);
      std::vector<Eigen::Vector2f>().swap(own.floor_obstacles);
      particles_[i].deferred.push_back({std::make_shared<const LocalResult>(std::move(results[i])), scan});
    }
  }
  for (int i = 0; i < n; ++i) {
    if (i != best_) {
      stats_.max_extra_particle_bytes = std::max(stats_.max_extra_particle_bytes, ExtraParticleBytes(particles_[i]));
    }
  }

  bool agree = true;
  const Pose2 best_pose = particles_[best_].state.recent.empty() ? prediction.pose : particles_[best_].state.recent.back().pose;
  for (const Particle& p : particles_) {
    if (!p.state.recent.empty() && !WithinSpread(options_, p.state.recent.back().pose, best_pose)) agree = false;
  }
  if (WeightSettles(options_, weights, best_, map_scores_) || agree || ambiguous_scans_ >= options_.max_ambiguous_scans) {
    step.committed = Collapse();
    step.collapsed = true;
    if (!inserted) step.current = std::move(not_inserted);
  } else {
    if (EffectiveSampleSize(weights) < options_.resample_ess_fraction * n) Resample();
    step.current = inserted ? Restored(particles_[best_].deferred.back()) : std::move(not_inserted);
  }
  step.particles = n;
  return step;
}

bool WeightSettles(const ParticleFilterOptions& options, const std::vector<double>& weights, int best,
                   const std::vector<double>& map_scores) {
  CHECK(best >= 0 && best < static_cast<int>(weights.size()));
  if (weights[best] < options.collapse_weight) return false;
  if (options.collapse_map_margin < 0 || map_scores.size() != weights.size()) return true;
  for (const double score : map_scores) {
    if (score > map_scores[best] + options.collapse_map_margin) return false;
  }
  return true;
}

std::optional<std::vector<double>> ParticleLocalSlam::GraphScores(const ScanPoints& points,
                                                                 const std::vector<Pose2>& local_poses,
                                                                 const SubmapGraph& graph, int robot) const {
  if (!graph.HasRobot(robot)) return std::nullopt;
  const Pose2 robot_T_local = graph.LocalToRobot(robot);
  std::vector<double> best_score(local_poses.size(), 0.0);
  bool any = false;
  for (int s = 0; s < graph.num_submaps(robot); ++s) {
    const SubmapId submap{robot, s};
    const LaserMap* map = graph.FinishedSubmapMap(submap);
    if (map == nullptr) continue;
    Eigen::Vector2d box_min, box_max;
    graph.SubmapBox(submap, &box_min, &box_max);
    const Pose2 submap_T_robot = graph.SubmapPose(submap).inverse() * robot_T_local;
    bool near = false;
    for (const Pose2& local_pose : local_poses) {
      const Eigen::Vector2d p = (submap_T_robot * local_pose).translation();
      near |= (p.array() >= box_min.array() - options_.global_margin_meters).all() &&
              (p.array() <= box_max.array() + options_.global_margin_meters).all();
    }
    if (!near) continue;
    any = true;
    for (size_t i = 0; i < local_poses.size(); ++i) {
      best_score[i] = std::max(best_score[i], ScoreAt(*map, submap_T_robot * local_poses[i], points.matching));
    }
  }
  if (!any) return std::nullopt;
  return best_score;
}

void ParticleLocalSlam::ScoreAgainstGraph(const ScanPoints& points, const std::vector<LocalResult>& results,
                                          const SubmapGraph& graph, int robot) {
  std::vector<Pose2> poses;
  for (const LocalResult& r : results) poses.push_back(r.local_pose);
  std::optional<std::vector<double>> scores = GraphScores(points, poses, graph, robot);
  if (!scores.has_value()) return;
  ++stats_.global_scorings;
  for (size_t i = 0; i < scores->size(); ++i) particles_[i].log_weight += ScanLogLikelihood(options_, (*scores)[i]);
  map_scores_ = std::move(*scores);
}

void ParticleLocalSlam::Resample() {
  const std::vector<int> picked = LowVarianceResample(Weights(), num_particles(), &rng_);
  std::vector<Particle> resampled;
  resampled.reserve(picked.size());
  int new_best = -1;
  for (size_t k = 0; k < picked.size(); ++k) {
    resampled.push_back(particles_[picked[k]]);
    resampled.back().log_weight = 0.0;
    if (picked[k] == best_ && new_best < 0) new_best = static_cast<int>(k);
  }
  particles_ = std::move(resampled);
  best_ = std::max(0, new_best);
  ++stats_.resamples;
}

int ParticleLocalSlam::CollapseChoice() const {
  // Without decisive evidence against it, the descendant of the undisturbed prediction (what
  // one particle would have done) is kept: a draw that merely scores a little better along a
  // flat direction is noise.
  const std::vector<double> weights = Weights();
  int undisturbed = -1;
  for (int i = 0; i < num_particles(); ++i) {
    if (particles_[i].undisturbed && (undisturbed < 0 || weights[i] > weights[undisturbed])) undisturbed = i;
  }
  if (undisturbed < 0 || weights[best_] > options_.decisive_weight_ratio * weights[undisturbed]) return best_;
  return undisturbed;
}

void ParticleLocalSlam::ReleaseActiveSubmaps() {
  for (Particle& particle : particles_) std::vector<ActiveSubmap>().swap(particle.state.active);
  std::vector<ActiveSubmap>().swap(spawn_submaps_);
}

std::vector<LocalResult> ParticleLocalSlam::Collapse() {
  Particle kept = std::move(particles_[CollapseChoice()]);
  kept.undisturbed = false;
  if (particles_.size() > 1) ++stats_.collapses;
  // The others go first: the kept particle's submaps are then its own (no copy on insertion).
  particles_.clear();
  spawn_submaps_.clear();
  std::vector<LocalResult> committed;
  committed.reserve(kept.deferred.size());
  std::swap(*slam_.mutable_state(), kept.state);
  for (const Deferred& d : kept.deferred) {
    committed.push_back(Restored(d));
    // Matched only while several particles lived: into the kept particle's submaps now, in
    // scan order (each a node: the motion filter is off for them).
    if (committed.back().awaiting_insertion) {
      slam_.Insert(&committed.back(), /*motion_filter=*/false);
      stats_.insert_seconds += committed.back().insert_seconds;
    }
  }
  std::swap(*slam_.mutable_state(), kept.state);
  kept.deferred.clear();
  kept.log_weight = 0.0;
  particles_.push_back(std::move(kept));
  best_ = 0;
  ambiguous_scans_ = 0;
  if (!committed.empty()) reference_pose_ = committed.back().local_pose;
  return committed;
}

std::vector<StampedPose2> ParticleLocalSlam::DeferredPoses() const {
  std::vector<StampedPose2> poses;
  for (const Deferred& d : particles_[best_].deferred) {
    poses.push_back({d.result->stamp_seconds, d.result->local_pose});
  }
  return poses;
}

std::vector<double> ParticleLocalSlam::Weights() const {
  std::vector<double> logs;
  for (const Particle& p : particles_) logs.push_back(p.log_weight);
  return NormalizedWeights(logs);
}

std::vector<Pose2> ParticleLocalSlam::Poses() const {
  std::vector<Pose2> poses;
  for (const Particle& p : particles_) poses.push_back(p.state.recent.empty() ? Pose2() : p.state.recent.back().pose);
  return poses;
}

size_t ParticleLocalSlam::ExtraParticleBytes(const Particle& particle) const {
  const Particle& best = particles_[best_];
  size_t bytes = 0;
  for (const ActiveSubmap& submap : particle.state.active) {
    const bool shared = std::any_of(best.state.active.begin(), best.state.active.end(),
                                    [&](const ActiveSubmap& b) { return b.map == submap.map; });
    if (!shared) bytes += submap.map->MemoryBytes();
  }
  for (const Deferred& d : particle.deferred) {
    const bool shared = std::any_of(best.deferred.begin(), best.deferred.end(),
                                    [&](const Deferred& b) { return b.result == d.result; });
    if (!shared) {
      bytes += sizeof(LocalResult) + PointsBytes(d.result->points);
      if (d.result->finished.has_value()) bytes += d.result->finished->map->MemoryBytes();
    }
    const bool scan_shared = std::any_of(best.deferred.begin(), best.deferred.end(),
                                         [&](const Deferred& b) { return b.scan == d.scan; });
    if (!scan_shared) bytes += PointsBytes(*d.scan);
  }
  return bytes;
}

LocalResult ParticleLocalSlam::Restored(const Deferred& deferred) {
  LocalResult result = *deferred.result;
  result.points.all = deferred.scan->all;
  result.points.labels = deferred.scan->labels;
  result.points.heights_meters = deferred.scan->heights_meters;
  result.points.floor_obstacles = deferred.scan->floor_obstacles;
  return result;
}

}  // namespace hetslam
