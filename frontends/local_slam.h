// Local SLAM: one robot's scan-to-submap front end (paper §III-C/§III-E, DESIGN.md "local SLAM").
//
// Each scan arrives as prepared points (PrepareScanPoints: 2.5D projection, floor hits
// dropped, labels, matching subset with weights) with a predicted pose in the front end's own
// drifting "local" frame. It is matched (frontends/scan_matcher.h) against the older of the (up
// to) two active submaps and inserted into both. A submap is a LaserMap in its own frame, that
// of the local pose of its first scan; a new one starts every scans_per_submap / 2 scans and a
// submap is finished (frozen, handed out in the result) after scans_per_submap scans. With
// scans_per_submap = 0 there is one submap that never finishes: the front end matches against
// one global map.
//
// AddScan returns a LocalResult (the pose, the match with its information matrix, the points,
// the submaps the scan went into, a submap that just finished): the submap graph
// (frontends/submap_graph.h) takes it as a node. Everything a scan changes lives in one
// copyable value, LocalSlamState (the active submaps with their maps, the recent poses), so a
// particle of a particle filter can be one LocalSlam.
#ifndef HETSLAM_FRONTENDS_LOCAL_SLAM_H_
#define HETSLAM_FRONTENDS_LOCAL_SLAM_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/laser_map.h"
#include "core/laser_scan.h"
#include "core/se2.h"
#include "core/trajectory_io.h"
#include "frontends/scan_matcher.h"

namespace hetslam {

enum class MotionPrediction {
  kStationary,        // predict the last pose
  kConstantVelocity,  // last pose ∘ (fraction of the last scan-to-scan motion)
  kOdometry,          // last pose ∘ increment of an external motion source (odometry, the EKF)
};

// Parses "stationary", "constant_velocity", "odometry"; false on anything else.
bool ParseMotionPrediction(const std::string& name, MotionPrediction* prediction);

struct LocalSlamOptions {
  OccupancyGridOptions grid;
  LikelihoodFieldOptions field;
  ScanMatcherOptions matcher = DefaultFrontEndMatcherOptions();
  // Scans per submap (a new submap starts every half of it); 0: one global map.
  int scans_per_submap = 40;
  MotionPrediction prediction = MotionPrediction::kConstantVelocity;
  // Fractions of the last scan-to-scan translation (in the robot frame) and heading change
  // extrapolated by kConstantVelocity (0 = stationary). Heading changes of robots without
  // odometry come in bursts (turn, then go straight), so by default only translation is
  // extrapolated.
  double velocity_fraction = 0.5;
  double angular_velocity_fraction = 0.0;
  // Points farther than this are not used (long ranges amplify yaw error and cost time).
  double max_point_range_meters = 30.0;
  // Points used for matching are thinned to one per voxel of this size (0 = all points);
  // the map always receives every point.
  double matching_voxel_meters = 0.20;
  // The search keeps each voxel's first point (in beam order); with this the refinement of the
  // pose it finds (and the match's information and score profile) uses each voxel's middle
  // point instead (core/laser_scan.h VoxelPoint::kMiddle): the first point sits at a
  // surface's end on one side of the scan only, and turned the pose towards that side scan
  // after scan (the simulated 2.5D robots' worst heading from their start over seeds 1-5: up
  // to 1.13 degrees, up to 0.58 with this but wheeled_corridor's 0.99; README, Teams). The
  // search itself stays on the first points: with the middle ones it picked the wrong one of
  // two modes 1.2 m apart along an ACES corridor (4 m off at the end). Off by default: the simulated office loop's corrected
  // trajectory (not its front end) and wheeled_corridor's are worse with it (README, Teams).
  // refine_on_voxel_ends (below) takes precedence over it.
  // Used when the scan carries no matching weights.
  bool refine_on_middle_beams = false;
  // The search keeps each voxel's first point; with this the refinement (and the match's
  // information, a mean over the points, and its score profile, on every k-th point: as many as
  // were searched) uses every point of the scan.
  // No choice within a voxel, so none of the first point's turn: of a voxel's beams the first
  // lies nearest the side the sweep enters by (a surface's end, or a point that range noise
  // carried across), and the simulated robots' front ends turned +0.04 to +2.25 degrees a run on
  // all 55 runs of seeds 1-5 (-0.3 to -1.7 with each voxel's last point; -0.57 to +0.51 with
  // this). On by default since session 51 (README, "Every point refined by default"): the
  // simulated robots' worst heading from their start over seeds 1-5 1.13 -> 0.61 degrees, the
  // teams' relative poses after the second constraint team_three drone-nao 0.233 -> 0.046 m,
  // team_overlap 0.063 -> 0.036 m, Intel 0.0230 -> 0.0192 m on its relations, MIT CSAIL 0.157 ->
  // 0.098 m against GMapping; at a cost: ACES 0.095 -> 0.102 m, the office loop's seed 1 0.030 ->
  // 0.046 m, Intel 8-10% and FR079 16-28% more wall time (two same-hour measurements). Takes
  // precedence over refine_on_middle_beams.
  // Used when the scan carries no matching weights.
  bool refine_on_all_points = true;
  // The search keeps each voxel's first point; with this the refinement (and the match's
  // information and score profile) uses each voxel's first and last point (core/laser_scan.h
  // VoxelPoint::kFirstAndLast): where a surface ends in a voxel, its end on whichever side of
  // the scan, at most twice the searched points. The first point alone turned every simulated
  // front end the same way (+0.04 to +2.25 degrees a run), the last alone the other way.
  // Measured against the default (README, "The refinement on each voxel's first and last
  // beam"): the simulated robots' worst heading from their start over seeds 1-5 1.13 -> 0.56
  // degrees, team_three's drone-nao frames 0.233 m / 1.09 deg -> 0.104 m / 0.43 deg after the
  // second constraint, team_overlap's 0.063 -> 0.019 m, ACES 0.095 -> 0.086 m and MIT CSAIL
  // 0.157 -> 0.118 m against GMapping, Intel and FR079 as before, about 3% of FR079's time. Off by
  // default: under tests/bench/run_sensitivity.sh's ten stopping rules Intel (0.087 m) and ACES
  // (0.66 m) each end far off on one (none by default), humanoid_explore's wall precision is
  // 0.944 on its worst seed (0.952), and the office loop 0.039-0.062 m (0.029-0.038).
  // refine_on_all_points takes precedence over it, and it over refine_on_middle_beams.
  // Used when the scan carries no matching weights.
  bool refine_on_voxel_ends = false;
  // Scans with fewer valid points are not matched or inserted (counted as skipped).
  int min_points = 20;
  // With a known body attitude (a tilting head, a UAV), the scan is projected under the 2.5D
  // assumption (core/laser_scan.h ProjectScan, paper §III-D) and end points lower than this
  // above the floor are floor hits: neither matched nor mapped (walls are vertical, so a wall
  // hit at any other height projects onto the wall).
  double floor_max_height_meters = 0.08;
  // ... plus distance from the sensor × tan(this): a far floor hit lifted by attitude error
  // (our MARG filter: ~1° RMS) is still floor.
  double floor_attitude_tolerance_radians = 1.5 * M_PI / 180.0;
  // Floor obstacles (paper §III-E), with an attitude: points at most this high above the floor
  // and at least floor_obstacle_min_drop_meters below the sensor (a beam tilted down; the drop
  // exceeds what a degree of attitude error makes at the laser's range, so a level laser never
  // labels any) are objects on the floor that break the 2.5D assumption: never matched, never
  // in the localisation map, kept for the planner map. 0 = off.
  double floor_obstacle_max_height_meters = 0.35;
  double floor_obstacle_min_drop_meters = 0.15;
  // Low floor obstacles (below the floor rule's band above): a tilted scan's floor hits lie on
  // one line, their heights displaced from 0 only by the attitude's and the body height's
  // error, linearly along it; the line fitted to them (robustly, FitFloorLine) is the floor as
  // this scan sees it. A hit in the floor band at least this high above it (or 4 times its RMS
  // residual, if more), and meeting the floor-obstacle rules above, is a floor obstacle too (a
  // 5 cm box the band would call floor). It still counts as a floor hit for suspension
  // (suspend_floor_fraction). 0 = off.
  double floor_obstacle_min_height_above_floor_meters = 0.03;
  // Paper §III-E, walls are the invariants of the 2.5D assumption. A head tilted a few degrees
  // down (before the floor dominates and matching is suspended) hits the far walls low, below
  // floor_obstacle_max_height_meters: by height alone those hits are floor obstacles, and only
  // the near structure is left to match. team_three's nao (seed 2), the last scan before a
  // suspension: 294 of 418 beams labelled floor obstacles, 27 matching points, a match 1° and
  // 7 cm off that the EKF then carried through the 3.5 s of suspension (the README's heading
  // 1.2° off). With this on, the floor obstacles that the prediction puts on a cell the matched
  // submap holds as occupied (structure seen at other heights: floor obstacles never enter it)
  // are matched as structure (AddFloorObstaclesOnMappedStructure), on every scan (also the few
  // far wall hits a walking humanoid's sway puts low; applied only where floor obstacles
  // outnumber the structure, the worst rotation rmse of team_two's and humanoid_explore's nao
  // was 0.09 and 0.05° larger). They are not mapped: they stay floor obstacles for the planner
  // map, and the map and its layers keep their labels.
  bool match_floor_obstacles_on_mapped_structure = true;
  // Paper §III-A: when more than this fraction of a scan's valid beams hit the floor, the
  // laser faces the floor: the scan is neither matched nor inserted (suspended) and the
  // caller's prediction (the EKF) carries the pose. 1 = never suspend.
  double suspend_floor_fraction = 0.2;
  // Paper §III-E: walls (cells hit at heights spanning grid.wall_min_height_span_meters: the
  // invariants of the 2.5D assumption) weigh more in matching: with matcher.wall_weight w > 1
  // every submap keeps the likelihood field of its wall cells (core/laser_map.h wall_field)
  // and the matcher's search scores a point L + (w - 1) L_wall wherever the candidate pose puts
  // it (frontends/scan_matcher.h; matcher.wall_weight_in_refinement for the refinement). Maps
  // without labels never hold a wall field: unchanged. Off (1) by default; see the README (map
  // semantics) for the measurements.
  // Degenerate scans (a corridor's two parallel walls, a tilted head seeing side walls only):
  // when the smaller eigenvalue of the match's translational information (J^T J of the scan
  // cost with the yaw marginalised out) is below this fraction of the larger, the pose keeps
  // the prediction along the weak direction and takes the match's correction only along the
  // strong one (solution remapping; there the score is flat and the matched position is
  // noise), then refines the pose across it and in yaw with the translation along it held
  // (ScanMatcher::RefineHoldingDirection). The direction held is the score profile's flattest
  // (below) whenever the match has one, also when this test fired: the information's weakest
  // eigenvector is mostly the noise of the hits (on a single wall 45 to 65 degrees off).
  // Applied only to external predictions that measure translation (odometry, the EKF with live
  // commands: see Prediction): the front end's own extrapolation, or the EKF on MARG rates
  // alone, carries no position information of its own. 0 = off.
  double degenerate_eigenvalue_ratio = 0.3;
  // ... or when the score is flat along its flattest direction (of 16): shifted 0.1 to 0.3 m
  // along it, the scan loses less than this fraction of what it loses along the steepest
  // (ScanMatchResult::weak_direction_score_drop, strong_direction_score_drop); that direction
  // is then the one held. The
  // information matrix of a featureless corridor's match is mostly the noise of the wall
  // hits: its eigenvalue ratio ranges from 0.05 to 0.6 from scan to scan (wheeled_corridor),
  // and so does the score's drop along the corridor (up to 0.04, against 0.3 to 0.5 across).
  // 0 = off.
  double degenerate_max_drop_ratio = 0.25;
  // End points of neighbouring beams closer than this are joined by points at the grid
  // resolution (0 = off): a wall seen at a grazing angle then is a line in the map, not a
  // dotted one whose gaps bias matching towards where the wall was mapped densely.
  double densify_max_gap_meters = 0.0;
  // The map's frontier (the ambiguity issue): a wall seen at a grazing angle is mapped up to
  // where the last scan reached, so a scan's far points on it score less when the scan moves
  // on (they leave the mapped wall) and the same when it moves back: the match is pulled back
  // along corridors. Matching points whose surface (core/laser_map.h EstimateScanLines with
  // frontier_lines), within this distance of where the prediction puts them, runs into
  // unobserved ground (an unknown
  // cell farther than the field's sigma from any mapped surface) carry no information the map
  // can score fairly: they are left out of the match (they are still mapped). Only for
  // external predictions that measure translation (see Prediction), which carry the motion
  // along the wall: without one,
  // those points are the only evidence of it (Intel: 0.0207 m → 0.0251 m on the relations with
  // the rule applied to every scan). 0 = off.
  double frontier_margin_meters = 0.3;
  ScanLineOptions frontier_lines;
  // See Prediction::covariance.
  double covariance_sigmas = 3.0;
  // With a prediction's covariance: a match scoring below this whose correction lies beyond
  // covariance_sigmas (Mahalanobis, the covariance widened by the grid resolution and the
  // matcher's largest yaw step) is a failed match: the scan goes in at the prediction. Measured
  // on team_two's drone (seed 2): a match at score 0.25 turned the pose 7° against a gyro-fed
  // prediction good to 0.36° (1 sigma), and the map kept that twist (ATE 0.184 m, 3.15°).
  // Matches score 0.8-0.9 on the shipped scenarios (p10 0.83). 0 = off.
  double outlier_max_score = 0.5;
  // kOdometry: the prediction's standard deviations are this fraction of the odometry
  // increment (translation; yaw: of the turn plus half of it per metre driven), so its search
  // windows are the narrow ones plus covariance_sigmas of that, with no wide fallback. 0: no
  // covariance (narrow, full and fallback windows as for the front end's own prediction).
  double odometry_noise_fraction = 0.1;
  // Motion filter (issue #15: no growth without new information): a scan is matched and goes
  // into the active submaps (each takes at most scans_per_submap such scans), but it is no
  // graph node and does not count towards a new or finished submap (LocalResult::filtered)
  // when, against the last scan that did, its pose (matched, or predicted when the match failed) moved less than
  // motion_filter_distance_meters (with the change of the body's height above the floor) and
  // turned less than motion_filter_angle_radians, its attitude (roll, pitch) changed less than
  // motion_filter_attitude_radians, and (when motion_filter_time_seconds > 0) it is less than
  // that much later. A robot standing still, or a humanoid's sway, then adds nothing; a
  // tilting head's new heights still go in. 0 distance = off (every scan is a node). The
  // default 1 cm and 0.5° let every scan of a moving robot in (of the four real logs only
  // FR079 filters, 396 of 4791 scans, at the same accuracy; the single-robot scenarios move by
  // up to 13 mm: wheeled_corridor, whose result depends on where its submaps begin, README) and
  // make a standing robot one node. It changes which of a humanoid's scans
  // become nodes, and on team_three that once let a map-overlap link put the nao in a
  // congruent room 20 m away; the team estimator now withdraws such a link when the joined
  // group's tags contradict it (merger/team_estimator.h). 0.05 m made 3-5x fewer nodes on the
  // humanoids, but Intel (1 of 910 scans filtered: 1.6 cm and 0.4° from the last) fell into a
  // front-end failure the graph does not recover from (README, "Motion filter").
  double motion_filter_distance_meters = 0.01;
  double motion_filter_angle_radians = 0.5 * M_PI / 180.0;
  double motion_filter_attitude_radians = 1.0 * M_PI / 180.0;
  double motion_filter_time_seconds = 0.0;

  // ScanMatcherOptions with a narrow first try of ±0.4 m, ±10° accepted from a score of 0.4:
  // scan-to-scan motion is far below the full windows on most logs.
  static ScanMatcherOptions DefaultFrontEndMatcherOptions();
  bool IsValid(std::string* error) const;
};


// The floor as one projected scan sees it: low floor obstacles stand above it
// (LocalSlamOptions::floor_obstacle_min_height_above_floor_meters), and its tilt is the
// attitude's error (FloorTiltError). A tilted scan's plane meets the floor in a line,
// so its floor hits lie on one line of the ground plane (their projected x, y), and their
// heights along it vary linearly (an attitude error tilts that line; a body height error lifts
// it): z = offset + slope · t, t = direction · (p - centre), robot frame.
struct FloorLine {
  Eigen::Vector2f centre = Eigen::Vector2f::Zero();
  Eigen::Vector2f direction = Eigen::Vector2f::UnitX();
  float offset = 0.f;
  float slope = 0.f;
  float rms = 0.f;   // of the inliers' height residuals
  int inliers = 0;
  float HeightAt(const Eigen::Vector2f& p) const { return offset + slope * direction.dot(p - centre); }
};
// Fits `line` to `points` (x, y, z of a scan's floor-band hits, robot frame): the direction is
// the principal axis of their x, y. The heights: a consensus start (the line through two of the
// points with the most points within 1 cm, weighed by how level it lies, no steeper than
// `max_tilt`, the tangent of the largest attitude error expected; a line with points well below
// it is refused: the floor is the lowest surface), then least squares five times over the
// points within 3 RMS (at least 1 cm) of the previous fit, so that the low obstacles and the low
// wall hits among them do not lift it.
// False, `line` untouched, with fewer than 20 points (or inliers), when they span less than
// 0.3 m along the axis, or when no line within `max_tilt` holds 20 of them.
bool FitFloorLine(const std::vector<Eigen::Vector3f>& points, double max_tilt, FloorLine* line);

// The laser's height above the floor: its mount turned by the attitude's roll and pitch, plus
// the body's height (BodyAttitude::base_height_meters).
double SensorHeight(const LaserScan& scan, const BodyAttitude& attitude);

// The body tilt the floor line says the projection got wrong, as the (roll, pitch) to add to
// the attitude (radians). Paper §III-A takes the attitude from a MARG filter; an accelerometer
// bias b tilts it by about b / g (0.3° for a MEMS part's 0.05 m/s²), and no gyro or
// accelerometer can tell that bias from a tilt. The floor can: when the projection's roll is
// ω_x and its pitch ω_y too small (small angles about the level robot frame's axes; pitch
// positive nose down), a floor hit projected to (x, y) from the body origin comes out at height
// z = ω_y x - ω_x y instead of 0. On the line z = offset + slope t at p = c + t d:
// ω_y c_x - ω_x c_y = offset and ω_y d_x - ω_x d_y = slope. The two are independent when the
// line passes away from the body origin: false when that distance, |c × d|, is under
// `min_distance_meters`. A body height error h lifts every line alike and reads as a tilt of
// h / |c × d| on a line that far. False too when the line is farther than
// `max_distance_meters`: there the beams meet the floor at a grazing angle (and a level laser's
// low hits on distant walls fall in the floor band).
bool FloorTiltError(const FloorLine& line, double min_distance_meters, double max_distance_meters,
                    Eigen::Vector2d* roll_pitch_radians);

// A scan's valid end points in the robot frame within max_point_range_meters (for the map),
// one label (core/laser_scan.h PointLabel, kept in the map's label layer) and one height each,
// and their voxel-thinned subset (for matching) with a matching
// weight each. With an attitude: the 2.5D projection, floor hits removed (counted); without,
// the scan is taken as level (height 0).
struct ScanPoints {
  std::vector<Eigen::Vector2f> all;
  std::vector<PointLabel> labels;    // one per point of `all`
  std::vector<float> heights_meters; // one per point of `all`: height above the floor
  bool projected = false;            // 2.5D projection with an attitude (heights meaningful)
  int valid_points = 0;              // valid beams of the scan
  int floor_points = 0;              // removed as floor hits (with the low floor obstacles)
  std::vector<Eigen::Vector2f> floor_obstacles;  // robot frame; not in `all`
  std::vector<Eigen::Vector2f> matching;
  // The refinement's points (LocalSlamOptions::refine_on_voxel_ends: the voxels of `matching`,
  // each by its first and last point; refine_on_middle_beams: each by its middle point;
  // refine_on_all_points: the points `matching` was thinned from); empty = `matching`'s.
  std::vector<Eigen::Vector2f> refinement;
  BodyAttitude attitude;             // of the projection (all 0 when not projected)
  // The floor this scan saw (FitFloorLine on its floor-band hits), when it could be fitted.
  std::optional<FloorLine> floor_line;
  // Scan matcher weights, one per point of `matching`; empty = every weight 1.
  std::vector<float> matching_weights;
  Eigen::Vector2d sensor_robot = Eigen::Vector2d::Zero();  // sensor origin, robot frame
};

ScanPoints PrepareScanPoints(const LocalSlamOptions& options, const LaserScan& scan,
                             const std::optional<BodyAttitude>& attitude = std::nullopt);

// Paper §III-A/E: whether the laser faces the floor (more than suspend_floor_fraction of the
// scan's valid beams hit it): then matching and map updates stop (LocalResult::suspended).
bool FacesFloor(const LocalSlamOptions& options, const ScanPoints& points);

// The next pose predicted from the trajectory so far (and, for kOdometry, the odometry
// increment from `last_motion` at the last pose to `motion` now; without both, the last pose).
// Identity for an empty trajectory.
Pose2 PredictNextPose(const LocalSlamOptions& options, const std::vector<StampedPose2>& trajectory,
                      const std::optional<Pose2>& last_motion, const std::optional<Pose2>& motion);

// Whether the front end may try the matcher's narrow windows first (external predictions
// always, see Prediction); otherwise when the last scan-to-scan motion was at most half the narrow
// windows (then the constant-velocity prediction is close). False when the narrow try is off.
bool NarrowSearchTrusted(const LocalSlamOptions& options, const std::vector<StampedPose2>& trajectory);

// Whether the surface `line` of a point `p_robot` placed by `world_T_robot` (both in the map's
// frame) runs, within `margin_meters` of it, into ground the map never observed and farther
// than the field's sigma from any mapped surface (see frontier_margin_meters). False for a
// point without a line.
bool RunsIntoUnobservedGround(const LaserMap& map, const Pose2& world_T_robot, const Eigen::Vector2f& p_robot,
                              const ScanLine& line, double margin_meters);

// Leaves out of points->matching (and points->refinement, when set; both rebuilt from
// points->all) the points whose surface RunsIntoUnobservedGround of `map` where `predicted`
// (map frame) puts them; returns how many of points->all were left out. Nothing is left out
// (0) when the option is off, the map is empty, or fewer than options.min_points points or
// half the matching points would remain.
int LeaveOutFrontierPoints(const LocalSlamOptions& options, const LaserMap& map, const Pose2& predicted,
                           ScanPoints* points);

// Adds to points->matching (after its points, voxel-thinned with them: only voxels it does not
// hold yet; to points->refinement likewise, when set) the floor obstacles of `points` that
// `predicted` (the map's frame) puts on a cell `map` holds as occupied (see
// match_floor_obstacles_on_mapped_structure); returns how many floor obstacles lie there.
// points->all and points->floor_obstacles do not change. Nothing is added (0) when the option
// is off, the map is empty, or the scan carries matching weights (one per matching point: the
// added points would have none).
int AddFloorObstaclesOnMappedStructure(const LocalSlamOptions& options, const LaserMap& map, const Pose2& predicted,
                                       ScanPoints* points);

// The matched pose with the correction from `predicted` removed along a degenerate direction
// (see degenerate_eigenvalue_ratio and degenerate_max_drop_ratio); `match.pose` itself when the
// match constrains both directions, both criteria are off or the match carries no information
// matrix. Both poses in the frame the match was made in. `*degenerate` (optional) tells
// whether a direction was held.
// `*weak_direction` (optional) receives the held direction (unit, the match's frame) when one was held.
Pose2 DegeneracyAwarePose(const LocalSlamOptions& options, const Pose2& predicted, const ScanMatchResult& match,
                          bool* degenerate = nullptr, Eigen::Vector2d* weak_direction = nullptr);

// An active submap: its map and where it sits. The map is shared copy-on-write: copying the
// state (a particle of frontends/particle_filter.h) shares it, and AddScan copies it before
// the first insertion that would change a shared map.
struct ActiveSubmap {
  int index = 0;          // this robot's submap number, in creation order
  Pose2 local_T_submap;   // front end frame
  std::shared_ptr<LaserMap> map;  // in the submap frame; never null
  int num_scans = 0;
  int num_filtered = 0;  // scans the motion filter let into it (not counted in num_scans)
};

// The last scan the motion filter let in (see LocalSlamOptions::motion_filter_distance_meters).
struct InsertedScan {
  double stamp_seconds = 0.0;
  Pose2 local_pose;
  BodyAttitude attitude;
};

// Everything AddScan changes: one value, cheap to copy (the maps are shared until written).
struct LocalSlamState {
  std::vector<ActiveSubmap> active;           // oldest first
  std::vector<StampedPose2> recent;           // the last (up to) three matched local poses
  std::optional<Pose2> last_odometry;         // odometry pose at the last matched scan
  std::optional<InsertedScan> last_inserted;
  int next_submap_index = 0;
  int num_inserted = 0;
};

struct LocalResult {
  double stamp_seconds = 0.0;
  bool inserted = false;       // a graph node now; false: too few points, suspended, filtered or awaiting insertion (see those)
  bool suspended = false;      // the laser faced the floor: not matched, not inserted (nothing else below is set)
  // Nothing new (the motion filter, LocalSlamOptions::motion_filter_distance_meters): matched
  // (local_pose, match and the fields below are set) and inserted into the active submaps, but
  // no graph node (inserted is false, `insertions` empty) and no step towards a new or
  // finished submap.
  bool filtered = false;
  // Matched (local_pose, match and the fields below are set) but not yet inserted: from
  // LocalSlam::Match, until LocalSlam::Insert (a particle filter inserts its particles' scans
  // when it collapses to one).
  bool awaiting_insertion = false;
  Pose2 predicted;             // local frame
  Pose2 local_pose;            // local frame, after matching
  bool matched = false;        // a match was tried (not on the first scan)
  bool degenerate = false;     // the weak direction kept the prediction
  Eigen::Vector2d weak_direction = Eigen::Vector2d::Zero();  // local frame, unit, when degenerate
  int frontier_points = 0;     // points left out of the match (frontier_margin_meters)
  // Floor obstacles on the map's structure, matched as structure (match_floor_obstacles_on_mapped_structure).
  int structure_floor_obstacles = 0;
  double match_seconds = 0.0;   // wall time of the match (frontier rule, search, refinement)
  double insert_seconds = 0.0;  // wall time of the insertion into the active submaps
  ScanMatchResult match;
  ScanPoints points;
  // Submaps this scan started (their local pose) and went into (with its pose in each).
  struct NewSubmap {
    int index = 0;
    Pose2 local_T_submap;
  };
  std::vector<NewSubmap> new_submaps;
  struct Insertion {
    int submap = 0;
    Pose2 submap_T_node;
  };
  std::vector<Insertion> insertions;
  // A submap that this scan completed: frozen, no longer active.
  struct FinishedSubmap {
    int index = 0;
    std::shared_ptr<const LaserMap> map;
  };
  std::optional<FinishedSubmap> finished;
};

// A scan's predicted pose (local frame). `external`: it comes from a motion source (odometry,
// the EKF with commands or MARG rates): then the narrow first search is always tried and, when
// it measures translation, a degenerate match keeps it along the weak direction (see
// degenerate_eigenvalue_ratio); otherwise it is the front end's own extrapolation. `motion`: the odometry pose at the scan
// when the prediction is kOdometry (kept for the next prediction).
// `covariance`: of (x, y, yaw) in the local frame, when the source knows it (the EKF; odometry
// through odometry_noise_fraction): the
// search windows are then sized by it (covariance_sigmas standard deviations beyond the
// matcher's narrow windows, at most the full windows) and there is no wider fallback: a motion
// source with a gyro does not turn 90° between two scans, and a corridor's corner matched
// against a half-built map can score best there.
// `measures_translation`: the source measures how far the robot went (odometry, the EKF with
// live commands); the EKF on MARG rates alone knows the heading but only extrapolates the
// position, so then no weak direction is held to it and no frontier point is left out.
struct Prediction {
  Pose2 pose;
  bool external = false;
  bool measures_translation = true;
  std::optional<Pose2> motion;
  std::optional<Eigen::Matrix3d> covariance;
};

class LocalSlam {
 public:
  // CHECK-fails on invalid options (validate user input with IsValid first).
  explicit LocalSlam(const LocalSlamOptions& options);

  // The front end's own prediction for a scan now (options.prediction), given the odometry
  // pose at the scan for kOdometry (without one: the last pose).
  Prediction Predict(const std::optional<Pose2>& odometry) const;
  // The same from another state (a particle's).
  Prediction PredictFrom(const LocalSlamState& state, const std::optional<Pose2>& odometry) const;
  // Matches and inserts one prepared scan. `motion_filter` false: inserted even when the
  // motion filter would leave it out (a particle filter with several particles, whose
  // particles must all insert the same scans).
  LocalResult AddScan(double stamp_seconds, ScanPoints points, const Prediction& prediction, bool motion_filter = true);
  // AddScan in two steps. Match: the match and the pose (the state's recent poses and odometry
  // move on; the submaps do not), result.awaiting_insertion when the scan is to be inserted
  // (not suspended, enough points). Insert: that result into the active submaps, as AddScan
  // would have (with the state's submaps as they are now).
  LocalResult Match(double stamp_seconds, ScanPoints points, const Prediction& prediction);
  void Insert(LocalResult* result, bool motion_filter = true);

  const LocalSlamState& state() const { return state_; }
  void set_state(LocalSlamState state) { state_ = std::move(state); }
  // For a particle filter that swaps its particles' states through one LocalSlam.
  LocalSlamState* mutable_state() { return &state_; }
  const LocalSlamOptions& options() const { return options_; }

 private:
  // The motion filter's verdict on a scan at `local_pose` with `attitude`.
  bool NothingNew(const LocalSlamState& state, double stamp_seconds, const Pose2& local_pose,
                  const BodyAttitude& attitude) const;

  LocalSlamOptions options_;
  ScanMatcher matcher_;
  LocalSlamState state_;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_LOCAL_SLAM_H_
