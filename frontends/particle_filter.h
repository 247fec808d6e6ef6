// The Rao-Blackwellized particle filter of one robot's front end (paper §III-A; Grisetti et
// al. 2007, "Improved techniques for grid mapping with Rao-Blackwellized particle filters").
//
// A particle is a local SLAM state (frontends/local_slam.h LocalSlamState: the active submaps,
// shared copy-on-write, and the recent poses), a log-weight and the results of the scans it
// took since the filter spawned particles (its recent trajectory, not yet in the submap graph
// and, by default, not yet in its submaps: see insert_while_ambiguous). One particle runs
// normally: each scan's result is committed to the graph at once, exactly as a lone LocalSlam
// would give it.
//
// Spawning (ambiguity). The filter spawns max_particles particles at the next scan when (a) or
// (b), two at this scan when (c):
//   (a) matching was suspended (the laser faced the floor), the EKF carried the pose, and the
//       first match after it did not settle the pose (settled_min_score): the particles'
//       predictions are drawn from the prediction's covariance;
//   (b) opt-in (spawn_on_degenerate): a match was degenerate (a corridor: the pose kept the
//       prediction along the weak direction, LocalResult::degenerate) and the prediction is
//       uncertain there: the draws spread along the weak direction only.
//   (c) on by default (spawn_on_second_mode): a wide search of the matcher (the prediction
//       was not trusted: a gap between scans, a sharp turn without odometry) found a second
//       mode, a pose outside the exclusion around the best scoring at least
//       second_mode_score_ratio of it (frontends/scan_matcher.h
//       ScanMatcherOptions::wide_second_mode_exclusion_*): the scan fits two places. The scan
//       is matched again around the second mode and, when that match holds (converged, still
//       distinct) and one of the two modes slides the robot sideways (mode_min_sideslip_sigmas),
//       two particles go on from this scan, one at each mode; neither is favoured at the
//       collapse. Their weights differ by their scans' scores and, without a motion source, by
//       the motion model (sideslip_sigma_meters). Where neither mode slides the robot sideways
//       (two places along a corridor's length) no particle follows: without a motion source the
//       scan goes on at the place its score, the change of speed (speed_change_sigma_mps) and,
//       where it holds the scan, the earlier map (mode_map_min_score) favour.
// Spawning after (a) and (b) needs a prediction that knows its covariance (the EKF, odometry);
// particle 0 keeps the undisturbed prediction.
//
// Each scan, every particle is predicted by the same motion (the increment of the caller's
// prediction from the pose it last fed the caller's EKF, or the particle's own odometry or
// extrapolation) and matched against its submaps (the proposal: the scan-match mode, Grisetti's
// optimal proposal approximated by its peak): by default the submaps as they were at the spawn,
// the scan going into them when the filter collapses (insert_while_ambiguous: into the
// particle's own copy at once). Its log-weight grows by the
// scan's log-likelihood at that mode, effective_points · log(floor + (1 - floor) · score), where
// score is the mean likelihood-field value (frontends/scan_matcher.h ScoreAt) against the
// submaps as they were at the spawn (common to all particles: a particle's own submaps agree with
// its later scans wherever it is), plus the same against the robot's finished submaps in the
// graph near the particle (the map from before the ambiguity, where a loop is found). When the
// effective sample size drops below resample_ess_fraction of the count, the particles are
// resampled (low variance, seeded).
//
// Collapse: when the best particle's normalised weight reaches collapse_weight (and the graph's
// finished submaps do not prefer another, collapse_map_margin), or all particles agree with
// it within the collapse spread, or after max_ambiguous_scans scans, one
// particle goes on (the best, when the evidence for it is decisive, see decisive_weight_ratio)
// and its deferred results are inserted into its submaps (unless already) and committed, in
// scan order, to the graph.
//
// Deterministic: every draw comes from a std::mt19937_64 seeded with `seed`, turned into
// uniform and normal numbers by this file's own code (same bytes on every platform).
#ifndef HETSLAM_FRONTENDS_PARTICLE_FILTER_H_
#define HETSLAM_FRONTENDS_PARTICLE_FILTER_H_

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/se2.h"
#include "core/trajectory_io.h"
#include "frontends/local_slam.h"
#include "frontends/submap_graph.h"

namespace hetslam {

// Weights w_i = exp(l_i - log Σ_j exp(l_j)) of log-weights l (log-sum-exp: no overflow for
// any finite l). Entries of -inf weigh 0; when every entry is -inf (or NaN), uniform. Empty in,
// empty out.
std::vector<double> NormalizedWeights(const std::vector<double>& log_weights);

// 1 / Σ w_i² of normalised weights: the number of particles that carry the weight.
double EffectiveSampleSize(const std::vector<double>& weights);

// Low-variance resampling (Thrun, Burgard, Fox, Probabilistic Robotics, Table 4.4): `count`
// indices into `weights` (normalised), read off one comb of spacing 1/count offset by a single
// uniform draw from `rng`. Index i is picked floor(count·w_i) or ceil(count·w_i) times, in
// ascending order.
std::vector<int> LowVarianceResample(const std::vector<double>& weights, int count, std::mt19937_64* rng);

// The sideslip of a scan-to-scan `motion` (the later pose in the earlier one's frame), metres:
// a robot that drives (forwards or backwards) and turns moves along a direction between its
// heading before and its heading after (an arc, or a turn and a straight drive in either
// order); this is the component of the translation perpendicular to the nearer of those two
// directions when it lies outside them (0 inside; reversing: the same about the backward
// heading).
double SideslipMeters(const Pose2& motion);

// The change of speed over the last two scan-to-scan motions of `recent` (oldest first, at
// least three poses), m/s: the later motion's speed minus the earlier one's, each its
// translation over its time, negative when reversing. nullopt with fewer poses or a time step
// that is not positive.
std::optional<double> SpeedChangeMetersPerSecond(const std::vector<StampedPose2>& recent);

struct ParticleFilterOptions;
// Whether the normalised `weights` settle an ambiguity on the `best` particle
// (ParticleFilterOptions::collapse_weight): its weight reaches collapse_weight, and the
// particles' scores against the earlier map (`map_scores`, one per particle; empty when none
// was near) do not prefer another one by more than collapse_map_margin.
bool WeightSettles(const ParticleFilterOptions& options, const std::vector<double>& weights, int best,
                   const std::vector<double>& map_scores);

// Uniform in [0, 1) from the top 53 bits of one draw; standard normal by Box-Muller from two.
double UniformDraw(std::mt19937_64* rng);
double NormalDraw(std::mt19937_64* rng);

struct ParticleFilterOptions {
  // Particles spawned under ambiguity; 1 = the single-particle pipeline, never spawning.
  int max_particles = 6;
  uint64_t seed = 1;
  // Spawn only when the prediction is at least this uncertain (1 sigma): along the weak
  // direction of a degenerate match, or in its larger translational direction after
  // suspension. Below it the spread would be inside the matcher's resolution.
  double spawn_min_sigma_meters = 0.05;
  bool spawn_after_suspension = true;
  // ... when the first match after suspended matching did not settle the pose: it failed or
  // scored below this (mean likelihood). A match that found the map well is trusted: spreading
  // particles along directions it left flat only adds noise (measured on humanoid_explore and
  // team_two, seeds 1-5: spawning after every flat first match left the ATE as it was, doubled
  // the time and put single scans up to 0.17 m off, from lineages chosen on later evidence).
  double settled_min_score = 0.5;
  // (b) above. Off by default: measured on humanoid_explore and team_two (seeds 1-5), after a
  // suspension the EKF is uncertain along a flat direction, the draws there cannot be told apart
  // until later evidence, and the lineage that wins may have had its earlier scans off: the ATE
  // stayed as it was (worst 0.016 / 0.018 m), single scans landed up to 0.17 m off (0.07 m with
  // one particle), and the runs took twice as long.
  bool spawn_on_degenerate = false;
  // (c) above. The exclusions set the matcher's wide_second_mode_exclusion_* (a second mode is
  // farther than the metres in x or y, or than the radians in yaw, from the best; both must be
  // set, an exclusion box is passed over only where both hold). The ratio compares the
  // correlative scores of the two discrete modes (the refined ones are left to the weights:
  // measured on MIT CSAIL with --sigma=0.11, the right mode of scan 325 scored 0.530 refined
  // against the wrong one's 0.624, its discrete score 0.519 against 0.528).
  bool spawn_on_second_mode = true;
  double second_mode_exclusion_meters = 0.5;
  double second_mode_exclusion_radians = 20.0 * M_PI / 180.0;
  double second_mode_score_ratio = 0.9;
  // Motion model of scans predicted by the front end's own extrapolation (no motion source),
  // while several particles live: each particle's log-weight also gains -s² / (2 σ²) for the
  // sideslip s of its scan-to-scan motion (SideslipMeters: a robot drives forwards or backwards
  // and turns; it does not slide sideways). The observation alone cannot tell the two modes
  // of an ambiguous match apart (measured on MIT CSAIL, scan 325: the wrong mode, 1.2 m to the
  // side of a robot that turned 27° left, scores better than the right one, and so do the
  // scans after it); the motion can. Scans predicted by a motion source (odometry, the EKF)
  // get no such term. 0 = off (a holonomic robot without a motion source).
  double sideslip_sigma_meters = 0.1;
  // A second mode spawns particles only when one of the two modes slides the robot sideways by
  // at least this many sideslip sigmas (the motion model can weigh them; see SpawnAtSecondMode).
  double mode_min_sideslip_sigmas = 3.0;
  // The motion model's second term, with sideslip_sigma_meters: each particle's log-weight also
  // gains -a² / (2 σ²) for the change of speed a (SpeedChangeMetersPerSecond) from its
  // previous scan-to-scan motion to this one (a robot speeds up and slows down smoothly). Two
  // modes along the direction of travel, which no particle follows (see SpawnAtSecondMode),
  // are weighed by this model and the scan's likelihood at once: the scan goes on at the
  // better. There the wrong mode is the pose of the scan before (the map it matched against was
  // seen from there): a robot that drove on at ~0.35 m/s would have stopped dead (ACES's
  // corridor at t = 151.9 s). Measured under tests/bench/run_sensitivity.sh's ten stopping
  // rules: 0.2 picks a standstill after Intel's turn on the spot at t = 383.8 s on 7 of 10;
  // 0.3 and 0.4 leave Intel's spread as it was and take ACES's far runs from 3 of 10 to 0.
  // 0 = off.
  double speed_change_sigma_mps = 0.3;
  // The earlier map in that decision: when the graph's finished submaps near either place
  // hold the scan (its best score there, ScoreAt, at least this at one of the two places),
  // each place's log-likelihood also gains the scan's against them, as particles' weights do
  // (ScoreAgainstGraph). A robot re-driving mapped space then goes on where the map it made
  // before puts it: on Intel x 5 (tests/bench/run_growth.sh) the third copy's turn on the spot
  // at t = 383.8 s went on at the standstill (the change of speed), 3 m off for the rest of the
  // copy and the ones after, while the earlier map held the scan at the other place (0.80
  // against 0.68); with it copies 2-5 are 0.035-0.045 m rms from the first. Below the floor
  // neither place fits the earlier map, and the difference of two poor scores is noise that the
  // logarithm magnifies: counted at every score, Intel x 5's first pass boundary (0.10 against
  // 0.06) put copies 2-5 2.1 m rms off. 1 = off (the finished submaps are not scored).
  double mode_map_min_score = 0.5;
  // Per-scan log-likelihood: effective_points · log(likelihood_floor + (1 - floor) · score).
  // Beams of one scan are not independent (Thrun et al.'s and GMapping's point: the weights
  // would collapse after one scan), so a scan counts as this many independent points.
  double effective_points = 10.0;
  double likelihood_floor = 0.05;
  // Resample when the effective sample size drops below this fraction of the particle count.
  double resample_ess_fraction = 0.5;
  // Collapse to the best particle when its normalised weight reaches collapse_weight (see
  // collapse_map_margin), when every particle's last pose is within the spread of the best
  // one's, or after max_ambiguous_scans.
  double collapse_weight = 0.95;
  double collapse_spread_meters = 0.03;
  double collapse_spread_radians = 0.01;
  int max_ambiguous_scans = 60;
  // A collapse keeps the best particle only when its weight exceeds that of the best
  // descendant of the spawn's undisturbed prediction (particle 0: what one particle would have
  // done) by this factor; otherwise that descendant (weak evidence along a flat direction is
  // noise: measured on humanoid_explore, picking the best by weight alone put the first scans
  // after a spawn up to 0.19 m off).
  double decisive_weight_ratio = 20.0;
  // The earlier map has the last word: a collapse on weight (collapse_weight) waits while the
  // graph's finished submaps, scored at this scan, prefer another particle by more than this
  // mean likelihood. The spawn's submaps are a few scans old and may hold the very scans that
  // made the ambiguity (a robot carried ~1 m at Intel x 5's pass boundaries put one there, and
  // that particle reached the weight by them: the fifth pass ended 1.3 m off); the finished
  // submaps do not. Agreement of the particles and max_ambiguous_scans still collapse.
  // Negative: off.
  double collapse_map_margin = 0.02;
  // The graph's finished submaps scored for a particle: those whose nodes' box, grown by this,
  // holds the particle's position.
  double global_margin_meters = 1.0;
  // While several particles live, each inserts its scans into its own copy of the active
  // submaps (true: the submaps follow each particle's trajectory, but a particle costs both
  // submaps whole, 6.5-6.9 MiB on humanoid_explore and wheeled_corridor), or every particle
  // matches against the submaps as they were at the spawn and the kept particle's scans go in
  // when the filter collapses (false: an extra particle costs its scans' points and results,
  // the ambiguity lasting at most max_ambiguous_scans).
  bool insert_while_ambiguous = false;

  bool IsValid(std::string* error) const;
};

struct ParticleFilterStats {
  int scans = 0;                 // AddScan calls
  long long particle_scans = 0;  // Σ over scans of the particle count after the scan
  int max_particles = 1;         // largest count seen
  int spawns = 0;
  int mode_spawns = 0;           // of which at a second mode (spawn_on_second_mode)
  // Scans whose second mode held when matched again (distinct from the best) but no particle
  // followed it: neither mode slides the robot sideways (two places along a corridor's
  // length). The scan went on at the mode the scan's likelihood and the motion model's change
  // of speed favour (without a motion source; with one, or with speed_change_sigma_mps 0, at
  // the best-scoring mode). Their first and last stamps (NaN when none).
  int unfollowed_modes = 0;
  // Of those, the scans that went on at the second mode: the motion model
  // (speed_change_sigma_mps, sideslip_sigma_meters), the scan's likelihood and, where counted
  // below, the earlier map favoured it.
  int modes_chosen_by_motion = 0;
  // Of the scans weighed by the motion model, those also weighed against the graph's finished
  // submaps near either place (mode_map_min_score).
  int modes_weighed_by_map = 0;
  double first_unfollowed_mode_stamp = std::numeric_limits<double>::quiet_NaN();
  double last_unfollowed_mode_stamp = std::numeric_limits<double>::quiet_NaN();
  int collapses = 0;
  int resamples = 0;
  int global_scorings = 0;       // scans weighted against the graph's finished submaps
  // Memory of one extra particle beyond the best one (its unshared submaps and deferred
  // results, LaserMap::MemoryBytes and the points' vectors): the largest seen, in bytes.
  size_t max_extra_particle_bytes = 0;
  // Wall time of every particle's matches and map insertions, and of the weighting.
  double match_seconds = 0.0;
  double insert_seconds = 0.0;
  double weight_seconds = 0.0;
  double mean_particles() const { return scans > 0 ? static_cast<double>(particle_scans) / scans : 0.0; }
};

// What one scan gave: the results that are final now (to add to the submap graph, in scan
// order) and the best particle's result of this scan.
struct ParticleStep {
  std::vector<LocalResult> committed;
  // This scan's result of the best particle when it is not committed.back() (deferred while
  // ambiguous, or not inserted: suspended, too few points, left out by the motion filter).
  std::optional<LocalResult> current;
  int particles = 1;
  bool spawned = false;
  bool collapsed = false;
  const LocalResult& Current() const { return current.has_value() ? *current : committed.back(); }
};

class ParticleLocalSlam {
 public:
  // CHECK-fails on invalid options (validate user input with IsValid first).
  ParticleLocalSlam(const LocalSlamOptions& local_options, const ParticleFilterOptions& options);

  // The best particle's own prediction (LocalSlam::Predict).
  Prediction Predict(const std::optional<Pose2>& odometry) const;

  // Adds one prepared scan. `prediction` is the best particle's; an external one without
  // odometry motion (the caller's EKF) is taken as relative to the best particle's last
  // matched pose, which the caller is expected to have fed its EKF: the other particles get
  // the same increment from their own poses. Otherwise (odometry, the front end's own
  // extrapolation) each particle predicts from its own state with `odometry`. `graph` holds the
  // finished submaps of `robot` that particles are weighted against (the deferred results are
  // not in it yet).
  ParticleStep AddScan(double stamp_seconds, ScanPoints points, const Prediction& prediction,
                       const std::optional<Pose2>& odometry, const SubmapGraph& graph, int robot);

  // Collapses to the best particle now; returns its deferred results (scan order) to commit.
  std::vector<LocalResult> Collapse();
  // Drops every particle's active submaps (the memory of the maps being built): after the last
  // scan, when nothing will be matched against them again. state().active is empty afterwards.
  void ReleaseActiveSubmaps();

  int num_particles() const { return static_cast<int>(particles_.size()); }
  // The best particle's state and its deferred poses (local frame, scan order).
  const LocalSlamState& state() const { return particles_[best_].state; }
  std::vector<StampedPose2> DeferredPoses() const;
  // The normalised weights and last poses (local frame) of the particles, for outputs and tests.
  std::vector<double> Weights() const;
  std::vector<Pose2> Poses() const;
  const ParticleFilterStats& stats() const { return stats_; }
  const ParticleFilterOptions& options() const { return options_; }
  const LocalSlam& local_slam() const { return slam_; }

 private:
  // A scan a particle took while several lived. Every particle matched the same scan, so its
  // points (all, labels, heights, floor obstacles) are kept once, in `scan`, shared by every
  // particle's entry; `result` holds the rest (its pose, match, matching subset).
  struct Deferred {
    std::shared_ptr<const LocalResult> result;
    std::shared_ptr<const ScanPoints> scan;
  };
  // The whole result of a deferred scan.
  static LocalResult Restored(const Deferred& deferred);
  struct Particle {
    LocalSlamState state;
    double log_weight = 0.0;
    std::vector<Deferred> deferred;
    bool undisturbed = false;  // descends from the spawn's undisturbed prediction
  };
  // The particle a collapse keeps: the best, unless its weight is less than
  // decisive_weight_ratio times that of the best undisturbed descendant.
  int CollapseChoice() const;
  // Draws max_particles - 1 more particles; their predictions for this scan are the
  // prediction displaced by draws from `covariance` (x, y, yaw; local frame).
  void Spawn(const Eigen::Matrix3d& covariance, const Prediction& prediction, std::vector<Prediction>* predictions);
  // (c): whether `result` (the lone particle's match, not yet inserted) found a second mode
  // close in score; then matches the scan around it from `before` (the particle's state before
  // that match) and, when that match holds, adds it as a second particle (its result appended
  // to `results`) and returns true. A second mode no particle follows replaces the first (its
  // result and the particle's state) when the motion model, the scan and the earlier map
  // (`graph`'s finished submaps of `robot`, see mode_map_min_score) favour it; false then
  // too. `motion_source`: the scan was predicted by one (no motion model then).
  bool SpawnAtSecondMode(double stamp_seconds, const ScanPoints& points, bool motion_source, LocalSlamState before,
                         const SubmapGraph& graph, int robot, std::vector<LocalResult>* results);
  // The scan's best score (ScoreAt of its matching points) at each of `local_poses` against
  // the graph's finished submaps of `robot` whose box, grown by global_margin_meters, holds
  // one of the poses; nullopt when none does.
  std::optional<std::vector<double>> GraphScores(const ScanPoints& points, const std::vector<Pose2>& local_poses,
                                                 const SubmapGraph& graph, int robot) const;
  // Log-likelihood of the scan at each particle's pose against the graph's finished submaps.
  void ScoreAgainstGraph(const ScanPoints& points, const std::vector<LocalResult>& results, const SubmapGraph& graph,
                         int robot);
  void Resample();
  size_t ExtraParticleBytes(const Particle& particle) const;

  ParticleFilterOptions options_;
  LocalSlam slam_;  // matcher and options; each particle's state is swapped through it
  std::vector<Particle> particles_;
  int best_ = 0;
  std::mt19937_64 rng_;
  // The best particle's last matched pose: what the caller's EKF was last fed.
  std::optional<Pose2> reference_pose_;
  std::optional<Eigen::Matrix3d> spawn_covariance_;  // a trigger fired: spawn at the next scan
  // The active submaps when the particles spawned (kept unchanged: copy-on-write).
  std::vector<ActiveSubmap> spawn_submaps_;
  bool after_suspension_ = false;
  int ambiguous_scans_ = 0;
  // Each particle's best score against the graph's finished submaps at the last weighted scan
  // (ScoreAgainstGraph); empty when no finished submap was near.
  std::vector<double> map_scores_;
  ParticleFilterStats stats_;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_PARTICLE_FILTER_H_
