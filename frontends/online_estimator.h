// One robot's online SLAM estimator: fed measurements (core/measurement.h) one at a time as
// they arrive, it can say its pose, its map and its graph at any moment. Batch programs
// (examples/hetslam_run.cc) are a loop over Add().
//
// Inside, per measurement kind:
//   MARG sample  -> the MARG attitude filter (frontends/marg_filter.h): roll and pitch for the
//                   2.5D projection of scans (attitude_source kMargFilter), and the attitude and
//                   Euler rates (no heading) as an EKF update;
//   attitude     -> kept for the projection when attitude_source is kLogged;
//   altitude     -> the height of the body for the projection (UAV), and an EKF update;
//   command      -> the EKF's prediction (paper eq. 3);
//   odometry     -> kept for the front end's odometry prediction (use_odometry);
//   laser scan   -> prepared (2.5D projection with the attitude at the scan's stamp, floor hits
//                   dropped), predicted, matched by local SLAM (frontends/local_slam.h) inside
//                   the particle filter (frontends/particle_filter.h: one particle, more under
//                   ambiguity), the best particle's match updates the EKF; final results (at
//                   once with one particle, the kept particle's deferred ones at a collapse)
//                   become nodes of the submap graph (frontends/submap_graph.h), loop closures
//                   are searched (frontends/loop_closer.h) and the graph solved now and then.
//
// The EKF state updater (frontends/ekf_state_updater.h) runs in the front end's local frame.
// It predicts each scan's pose when the stream carries commands or MARG samples (else the
// front end extrapolates its own motion, or uses odometry with use_odometry). Scans may arrive
// later than the MARG samples, commands and altitudes stamped after them (a laser driver's
// latency): everything about a scan at t is computed from the measurements stamped at or
// before t (the EKF's estimate at t, the latest attitude at or before t), and the scan-match
// update is inserted into the EKF's history at t and the newer measurements replayed. So the
// result is the same whatever the delay within the EKF's history window, bit for bit, as long as
// the scans keep their order among themselves. Scans are processed in arrival order; one stamped
// before its predecessor (a log's clock glitch) is processed and counted; one older than the
// EKF's history is refused.
//
// Errors are returned, never CHECK-failed, for bad data: non-finite values, a MARG sample not
// after the previous one, a scan older than the EKF's history. The
// estimator's state is then unchanged and the next measurement may be added.
#ifndef HETSLAM_FRONTENDS_ONLINE_ESTIMATOR_H_
#define HETSLAM_FRONTENDS_ONLINE_ESTIMATOR_H_

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/measurement.h"
#include "core/occupancy_grid.h"
#include "core/status.h"
#include "core/trajectory_io.h"
#include "frontends/ekf_state_updater.h"
#include "frontends/local_slam.h"
#include "frontends/loop_closer.h"
#include "frontends/marg_filter.h"
#include "frontends/particle_filter.h"
#include "frontends/submap_graph.h"

namespace hetslam {

enum class AttitudeSource {
  kLevel,       // every scan is level (plain 2D)
  kMargFilter,  // roll/pitch of our MARG filter on the raw MARG samples
  kLogged,      // the log's ATTITUDE readings (a sensor's own filter)
};
// "level", "marg", "logged"; false on anything else.
bool ParseAttitudeSource(const std::string& name, AttitudeSource* source);

struct OnlineEstimatorOptions {
  int robot = 0;  // this robot's id in the submap graph
  LocalSlamOptions local;
  // The front end's particle filter (frontends/particle_filter.h): one particle, more under
  // ambiguity; scans it defers while several particles live enter the graph when they
  // collapse (Trajectory() shows the best particle's poses meanwhile).
  ParticleFilterOptions particles;
  bool loop_closure = true;  // false: the front end alone against one global map
  LoopCloserOptions loop;
  SubmapGraphOptions graph;
  // Solve once this many loop closures were accepted and solve_min_new_nodes scans added since
  // the last solve (the latter bounds the solves of dense logs, where closures arrive at almost
  // every scan); bounded iterations, more at Finish().
  int solve_every_n_loop_closures = 10;
  int solve_min_new_nodes = 20;
  // ... and at least this share of the robot's nodes (issue #15): a solve costs in proportion
  // to the graph, so with a fixed spacing the solves of a long run cost its length squared
  // (Intel x 5: 10.2 s of 36 s). 0.02: unchanged up to 1000 nodes (Intel, ACES, MIT CSAIL);
  // FR079's last solves every 88 nodes.
  double solve_min_new_node_share = 0.02;
  int max_iterations_per_solve = 10;
  int max_iterations_final = 50;
  // Lifelong memory (issue #15): a bound on the bytes the robot's finished submaps' maps hold
  // (SubmapGraph::FinishedSubmapBytes); 0 = none (the default: offline runs keep every map).
  // Whenever a finished submap takes the store over it, the most redundant finished submaps are
  // evicted (SubmapGraph::EvictSubmapMap) until it fits: those with the largest share of
  // occupied cells (every fourth one checked) at which another kept submap's likelihood is at
  // least exp(-1) at the current poses, ties the older, never the newest. An evicted submap is
  // no longer searched for loop closures; the trajectory and the maps rendered from the nodes
  // keep it.
  size_t max_map_store_bytes = 0;
  // Revisits attach to the map they revisit (issue #15): a submap that finishes with at least
  // this share of its occupied cells covered by earlier submaps (SubmapGraph::CoveredShare:
  // structure within the likelihood field's sigma at the current poses; only submaps a loop
  // search of its nodes could have found, LoopCloserOptions::min_node_separation; tested when
  // it finishes and, failing that, once more after the next solve) adds nothing to the map:
  // its map is freed (SubmapGraph::EvictSubmapMap, counted as retired). Its pose stays; loop
  // searches, the particle filter and a team's overlap search use the earlier submaps instead.
  // Only with loop closure. 0 = off.
  double retire_revisited_share = 0.9;
  // ... and after every solve, the nodes of retired submaps (both submaps they entered retired)
  // leave the graph: each rides on its submap at its solved pose there, its constraints, loop
  // closures and matching points released, and a few constraints between submaps sum up what
  // those said (SubmapGraph::AttachRevisits). Re-driving mapped space then adds a node's pose
  // and what it saw (for the rendered maps), not its closures. Only with
  // retire_revisited_share > 0. Off: the nodes and their constraints stay.
  bool attach_revisits = true;
  // The robot's frame is its body at its first scan. That scan built the first submap alone for
  // a moment, and a biased match of the next few turns the map built after them against it
  // (0.4-0.6° on a simulated UAV: 20 cm over 22 m). When the first submap is finished, the
  // first node's scan is refined against it (ScanMatcher::Refine, within four angular search
  // steps) and its heading in it set to the result (SubmapGraph::ReviseFirstNodeInFirstSubmap:
  // the robot's map turns around the first pose). Its position stays: one scan can be flat
  // along a corridor, and a heading error is what grows with distance.
  bool rematch_first_node = true;
  // Before each solve the search tables (ScanMatcher's, not read by a solve) keep resident their
  // pages up to the largest table the searches since the last solve asked for, unless the
  // process is within their size of its memory peak (ScanMatcher::ShrinkScratchForSolve;
  // results are the same either way).
  // Off: they are freed before every solve and faulted in again by the next searches (before
  // session 47; Intel 28.8 instead of 20.2 thousand page faults).
  bool keep_search_tables_over_solves = true;

  AttitudeSource attitude_source = AttitudeSource::kMargFilter;
  MargFilterOptions marg;
  // The attitude (and altitude) for a scan is the latest at or before its stamp, if at most
  // this old; else the scan is taken as level (at height 0).
  double attitude_max_age_seconds = 0.1;
  double altitude_max_age_seconds = 0.3;
  // The floor corrects the attitude's tilt (FloorTiltError, frontends/local_slam.h): the
  // (roll, pitch) a scan's floor line says the projection got wrong is added to a correction,
  // times this gain, that every later scan's attitude takes (from either attitude source). An
  // accelerometer bias tilts a MARG filter's attitude for good; the floor sees it whenever a
  // tilted laser meets the floor in a line (a humanoid's head looking down). 0 = off. At 0.05
  // a correction settles over ~20 such scans (2 s of a 10 Hz laser looking down), averaging
  // the single lines' noise (a tenth of a degree or more) down by ~4.
  double floor_tilt_gain = 0.05;
  // Only lines this far from the body origin (nearer, a body height error looks like a tilt),
  // seen by beams tilted down at least this much (the line at most sensor height / tan of it
  // from the body: a level laser's grazing or wall hits in the floor band say nothing), fitted
  // within this RMS, and saying at most this much tilt (more is not a bias: a slope, a step, a
  // fit on something else) count.
  double floor_tilt_min_line_distance_meters = 0.5;
  double floor_tilt_min_depression_radians = 0.087;  // 5°
  double floor_tilt_max_rms_meters = 0.02;
  double floor_tilt_max_error_radians = 0.035;
  // The correction's roll and pitch stay within this (a MEMS accelerometer's bias is at most a
  // few tenths of m/s², under 3°): a floor that is not level (a ramp) cannot tilt it further.
  double floor_tilt_max_correction_radians = 0.05;

  EkfStateUpdaterOptions ekf;
  bool use_commands = true;    // commands drive the EKF prediction
  bool use_odometry = false;   // predict scans from odometry (the scan's own pose, else the latest reading)
  double odometry_max_age_seconds = 0.05;
  // A scan whose predicted pose is farther than this from the last matched pose (a corrupt
  // odometry pose or command) is refused with an error and counted in scans_refused: mapping
  // it would stretch the submap grids past their size limit (issue #16).
  double max_scan_jump_meters = 100.0;
  // Uncertainty (1 sigma) of a scan-match pose as an EKF measurement. Tight on purpose: the
  // nodes are the matched poses, and the EKF's prediction for the next scan should start from
  // them (measured: 1 cm / 0.005 rad let the EKF lag the matches and made the humanoid and UAV
  // scenarios worse on several seeds).
  double scan_match_translation_sigma_meters = 0.001;
  double scan_match_rotation_sigma_radians = 0.0005;
  // Along the weak direction of a degenerate match (LocalResult::weak_direction: a corridor)
  // the score is flat and the matched position wanders (±0.1–0.3 m on wheeled_corridor): the
  // EKF update takes this standard deviation there, so the EKF's prediction (commands,
  // odometry) carries the pose along it, its covariance grows as the motion model says, and
  // with it the next search window (LocalSlamOptions::covariance_sigmas). Measured on
  // wheeled_corridor seeds 1, 2 (ATE): 0.001 m (the strong directions' value) 0.38, 0.37 m;
  // 0.1 m 0.11, 0.14 m; 10 m 0.48, 0.35 m (a weak direction a few degrees off the corridor
  // then turns every across-track correction into a long along-track one).
  double degenerate_sigma_meters = 0.1;
  // A run is reported as low confidence (ScanConfidence::low) when fewer than this fraction of
  // its scans were placed by a match that constrains x, y and yaw (issue #16: nothing in range,
  // a single wall, a featureless corridor must not look like a good run). In [0, 1].
  double min_well_constrained_fraction = 0.5;

  bool IsValid(std::string* error) const;
};

// What a log says of its platform (its PARAM lines, MeasurementLog::params), into `options`:
// `command_response_seconds` (EkfStateUpdaterOptions::command_response_seconds). An error names
// the PARAM when its value is not a number in the option's range; `options` is then unchanged.
// Params it does not know are left alone.
Status ApplyLogParams(const std::map<std::string, std::string>& params, OnlineEstimatorOptions* options);

struct OnlineEstimatorStats {
  int scans = 0;                    // laser scans added
  int scans_refused = 0;            // older than the EKF history or a jump (an error was returned)
  int scans_stamped_backwards = 0;  // stamped before the previous scan (processed)
  int skipped_too_few_points = 0;
  int match_failures = 0;           // inserted at the prediction
  int degenerate_matches = 0;       // weak direction kept the prediction
  // Converged matches, by whether the score is flat along a direction (LocalSlamOptions
  // degenerate_eigenvalue_ratio, degenerate_max_drop_ratio), whatever the prediction: a flat
  // match is a degenerate match when a motion source held the pose along that direction, and
  // the matcher's own guess there otherwise.
  int well_constrained_matches = 0;
  int flat_matches = 0;
  int frontier_scans = 0;           // scans with points left out at the map's frontier
  long long frontier_points = 0;    // points left out (LocalSlamOptions::frontier_margin_meters)
  long long floor_points = 0;       // end points dropped as floor hits
  long long floor_obstacle_points = 0;  // end points labelled floor obstacles (planner map only)
  int suspended_scans = 0;          // the laser faced the floor: the EKF carried the pose
  int filtered_scans = 0;           // matched, not inserted: nothing new (the motion filter)
  int projected_scans = 0;          // projected with an attitude (2.5D)
  // The lowest height above the floor that a ray of a projected scan passed through free space
  // at: the laser's own height, or a lower end point's (0 once a beam met the floor). A surface
  // whose hits all lie well below it may stand under every ray of the scans (a low box under a
  // UAV's laser: merger/map_merge.h, CompareMaps). Unset before the first projected scan.
  std::optional<double> lowest_ray_height_meters;
  int scans_without_attitude = 0;   // the stream has attitudes, but none near the scan: level
  int floor_tilt_updates = 0;       // scans whose floor line corrected the attitude's tilt
  Eigen::Vector2d floor_tilt_radians = Eigen::Vector2d::Zero();  // the (roll, pitch) correction now
  int ekf_predicted_scans = 0;      // scans predicted by the EKF
  // The first scan's heading in the finished first submap against where it was inserted
  // (OnlineEstimatorOptions::rematch_first_node): the turn given to the robot's map; unset
  // until then, or when the refinement gave nothing.
  std::optional<double> first_node_rematch_radians;
  size_t active_submap_bytes_at_finish = 0;  // LaserMap::MemoryBytes of the active submaps Finish() freed
  int marg_samples = 0;
  int marg_errors = 0;              // samples the MARG filter refused
  int marg_restarts = 0;            // MARG filter restarted after a gap in the samples
  int ekf_errors = 0;               // EKF updates refused
  int loop_solves_failed = 0;
  // Wall time per stage (seconds): scan preparation (2.5D projection, labels, voxel filter) and
  // the graph's node insertions; matching, map insertion and particle weighting are in
  // ParticleFilterStats, loop search in LoopCloserStats, solves in SubmapGraphStats.
  double prepare_seconds = 0.0;
  double add_node_seconds = 0.0;
};

// How well the laser placed the scans of a run so far: every scan added falls in exactly one
// class. `low` when the well-constrained fraction is under
// OnlineEstimatorOptions::min_well_constrained_fraction (or no scan was added): the map and
// trajectory then rest mostly on the prediction (commands, odometry, the front end's
// extrapolation), not on the laser.
struct ScanConfidence {
  int scans = 0;
  int well_constrained = 0;  // a converged match that constrains x, y and yaw
  int flat = 0;              // a converged match flat along one direction (a single wall, a corridor)
  int failed = 0;            // the match did not converge: the scan sits at its prediction
  int unmatched = 0;         // the first scan, too few points in range, or suspended (facing the floor)
  int refused = 0;           // refused with an error (too late, too far)
  double well_constrained_fraction = 0.0;  // well_constrained / scans (0 without scans)
  bool low = true;
};

class OnlineEstimator {
 public:
  // CHECK-fails on invalid options (validate user input with IsValid first).
  explicit OnlineEstimator(const OnlineEstimatorOptions& options);
  // A team member: its nodes go into `team_graph` (not owned; it must outlive the estimator)
  // under options.robot, next to its teammates', whose inter-robot constraints a merger adds.
  // The estimator's solves then solve the whole team graph.
  OnlineEstimator(const OnlineEstimatorOptions& options, SubmapGraph* team_graph);
  ~OnlineEstimator();

  // Processes one measurement. Errors (the measurement is ignored, the estimator unchanged)
  // as described above. After Finish(), every Add is an error.
  Status Add(const Measurement& measurement);
  // Final solve (loop closure on), then frees what only further scans would use: the active
  // submaps (their bytes are kept in stats().active_submap_bytes_at_finish; the graph's nodes
  // and finished submaps stay, so trajectories and rendered maps are unchanged) and this
  // thread's branch-and-bound tables. Idempotent.
  void Finish();

  // The latest pose estimate (robot frame = world frame of a lone robot): the EKF's, else the
  // last node's. Identity before the first scan.
  Pose2 CurrentPose() const;
  // The pose at a past stamp: the EKF's filtered estimate within its history window, else the
  // nodes' poses interpolated (or the nearest end). Error before the first scan.
  Status PoseAt(double stamp_seconds, Pose2* pose) const;
  // Optimised poses of every inserted scan (robot frame), and of the scans that are not nodes
  // (relative to the node before them): those whose matching was suspended (the EKF's pose)
  // and those the motion filter left out (their match), in stamp order.
  std::vector<StampedPose2> Trajectory() const;
  // The front end's (drifting, never corrected) poses of the scans of Trajectory().
  std::vector<StampedPose2> LocalTrajectory() const;
  // An occupancy grid of a layer of the map at the optimised poses: the structure localisation
  // uses (every inserted scan), the floor obstacles (also those seen while matching was
  // suspended), or both for a planner. In the robot's frame, or rendered in another frame
  // where the robot's frame is at frame_T_robot (a team's common frame).
  std::unique_ptr<OccupancyGrid> RenderMap(SubmapGraph::Layer layer = SubmapGraph::Layer::kStructure,
                                           const Pose2& frame_T_robot = Pose2::Identity()) const;
  const SubmapGraph& graph() const { return *graph_; }
  // For constraints found by other means (a fiducial, a teammate): added like loop closures.
  SubmapGraph& mutable_graph() { return *graph_; }
  // The EKF's constant-rate output (every ekf.output_period_seconds) since the previous call, up
  // to `stamp_seconds`, in the robot frame: for a live node that publishes at a fixed rate.
  std::vector<StampedPose2> AdvanceTo(double stamp_seconds);
  const LocalSlam& local_slam() const { return local_.local_slam(); }
  const ParticleLocalSlam& particle_filter() const { return local_; }
  // The particle count over time: an entry at the first scan and whenever the count changed.
  struct ParticleCount {
    double stamp_seconds;
    int particles;
  };
  const std::vector<ParticleCount>& particle_counts() const { return particle_counts_; }
  const LoopCloser& loop_closer() const { return loop_; }
  const EkfStateUpdater& ekf() const { return ekf_; }
  const OnlineEstimatorStats& stats() const { return stats_; }
  // The classes of the scans added so far, from stats().
  ScanConfidence Confidence() const;
  const OnlineEstimatorOptions& options() const { return options_; }
  // Match scores of the converged front-end matches, in scan order.
  const std::vector<double>& match_scores() const { return match_scores_; }

 private:
  Status AddScan(const LaserReading& reading);
  Status AddMarg(const MargSample& sample);
  std::optional<BodyAttitude> AttitudeAt(double stamp_seconds) const;
  // Adds a final front-end result to the graph, searches loop closures, solves now and then.
  void AddNode(LocalResult result);
  void RecordParticleCount(double stamp_seconds, int particles);
  void Solve(int max_iterations);
  // Frees the map of the submap that just finished when earlier ones cover it (see
  // retire_revisited_share); else, with `recheck_after_solve`, tests it once more after the
  // next solve (its poses corrected by the closures of its nodes).
  void RetireIfRevisited(int finished, bool recheck_after_solve);
  // Evicts finished submaps until the store fits max_map_store_bytes (see the option).
  void EnforceMapStoreBound();
  // See OnlineEstimatorOptions::rematch_first_node.
  void RematchFirstNode();
  void Prune(double newest_stamp_seconds);

  OnlineEstimatorOptions options_;
  ParticleLocalSlam local_;
  std::unique_ptr<SubmapGraph> owned_graph_;
  SubmapGraph* graph_;  // owned_graph_, or a team's
  LoopCloser loop_;
  MargFilter marg_filter_;
  EkfStateUpdater ekf_;
  // Histories of the last ekf.history_window_seconds (attitude at a scan's stamp).
  std::deque<MargAttitude> marg_attitudes_;
  // The (roll, pitch) the floor lines say every scan's attitude needs (floor_tilt_gain); kept in
  // stats_ too.
  Eigen::Vector2d floor_tilt_radians_ = Eigen::Vector2d::Zero();
  std::deque<AttitudeReading> logged_attitudes_;
  std::deque<AltitudeReading> altitudes_;
  std::deque<OdometryReading> odometry_;
  std::optional<VelocityCommand> pending_command_;  // latest command before the EKF started
  // Stamp of the earliest command or MARG sample: the EKF predicts the scans stamped after it.
  std::optional<double> first_motion_stamp_;
  std::optional<double> last_command_stamp_;  // newest command added (use_commands)
  std::optional<double> last_scan_stamp_;
  int loop_closures_since_solve_ = 0;
  std::vector<int> retire_recheck_;  // finished submaps to test again after the next solve
  int nodes_since_solve_ = 0;
  bool finished_ = false;
  std::vector<double> match_scores_;
  std::vector<ParticleCount> particle_counts_;
  std::vector<SubmapGraph::AnchoredPoints> suspended_obstacles_;
  // Scans that are not nodes (matching suspended, or left out by the motion filter): their
  // pose relative to the node before them.
  struct NonNodePose {
    double stamp_seconds;
    NodeId node;
    Pose2 node_T_scan;
  };
  std::vector<NonNodePose> non_node_poses_;
  OnlineEstimatorStats stats_;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_ONLINE_ESTIMATOR_H_
