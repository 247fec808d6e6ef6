// Single-robot scan-matching front end: predict, match against the map, insert.
//
// Each scan is projected to the robot's ground plane (core/laser_scan.h), matched against
// the likelihood field of everything inserted so far (frontends/scan_matcher.h) starting
// from a motion prediction, and inserted at the matched pose. Without odometry (the
// default) the prediction extrapolates a fraction of the last scan-to-scan motion; with
// odometry it applies the odometry increment. No loop closure here: the pose-graph back end
// consumes this front end's poses and information matrices.
#ifndef HETSLAM_FRONTENDS_SCAN_MATCHING_SLAM_H_
#define HETSLAM_FRONTENDS_SCAN_MATCHING_SLAM_H_

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
  kOdometry,          // last pose ∘ odometry increment (needs odometry with every scan)
};

// Parses "stationary", "constant_velocity", "odometry"; false on anything else.
bool ParseMotionPrediction(const std::string& name, MotionPrediction* prediction);

struct ScanMatchingSlamOptions {
  OccupancyGridOptions grid;
  LikelihoodFieldOptions field;
  ScanMatcherOptions matcher = DefaultFrontEndMatcherOptions();
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
  // Scans with fewer valid points are not matched or inserted (counted as skipped).
  int min_points = 20;
  // With a known body attitude (AddScan's `attitude`: a tilting head, a UAV), the scan is
  // projected under the 2.5D assumption (core/laser_scan.h ProjectScan, paper §III-D) and
  // end points lower than this above the floor are floor hits: neither matched nor mapped
  // (walls are vertical, so a wall hit at any other height projects onto the wall).
  double floor_max_height_meters = 0.08;
  // Degenerate scans (a corridor's two parallel walls, a tilted head seeing side walls only):
  // when the smaller eigenvalue of the match's translational information (J^T J of the scan
  // cost with the yaw marginalised out) is below this fraction of the larger, the pose keeps
  // the prediction along the weak direction and takes the match's correction only along the
  // strong one (solution remapping; there the score is flat and the matched position is
  // noise). 0 = always take the whole match.
  double degenerate_eigenvalue_ratio = 0.0;
  // End points of neighbouring beams closer than this are joined by points at the grid
  // resolution (0 = off): a wall seen at a grazing angle then is a line in the map, not a
  // dotted one whose gaps bias matching towards where the wall was mapped densely.
  double densify_max_gap_meters = 0.0;

  // ScanMatcherOptions with a narrow first try of ±0.4 m, ±10° accepted from a score of 0.4:
  // scan-to-scan motion is far below the full windows on most logs.
  static ScanMatcherOptions DefaultFrontEndMatcherOptions();
  bool IsValid(std::string* error) const;
};

// The next pose predicted from the trajectory so far (and the odometry increment when the
// prediction is kOdometry: `last_odometry` at the last pose, `odometry` now). Identity for an
// empty trajectory.
Pose2 PredictNextPose(const ScanMatchingSlamOptions& options, const std::vector<StampedPose2>& trajectory,
                      const std::optional<Pose2>& last_odometry, const std::optional<Pose2>& odometry);

// The scan's valid end points in the robot frame within max_point_range_meters (for the
// map), and their voxel-thinned subset (for matching). With an attitude, the 2.5D projection
// and floor hits removed (see floor_max_height_meters); without, the scan is taken as level.
struct ScanPoints {
  std::vector<Eigen::Vector2f> all;
  int floor_points = 0;  // removed as floor hits
  std::vector<Eigen::Vector2f> matching;
  Eigen::Vector2d sensor_robot = Eigen::Vector2d::Zero();  // sensor origin, robot frame
};
// Whether the front end may try the matcher's narrow windows first: with odometry always;
// otherwise when the last scan-to-scan motion was at most half the narrow windows (then the
// constant-velocity prediction is close). False when the narrow try is off.
bool NarrowSearchTrusted(const ScanMatchingSlamOptions& options, const std::vector<StampedPose2>& trajectory);

// The matched pose with the correction from `predicted` removed along a degenerate direction
// (see degenerate_eigenvalue_ratio); `match.pose` itself when the match constrains both
// directions, the ratio is 0 or the match carries no information matrix. Both poses in the
// frame the match was made in. `*degenerate` (optional) tells whether a direction was held.
Pose2 DegeneracyAwarePose(const ScanMatchingSlamOptions& options, const Pose2& predicted, const ScanMatchResult& match,
                          bool* degenerate = nullptr);

ScanPoints PrepareScanPoints(const ScanMatchingSlamOptions& options, const LaserScan& scan,
                             const std::optional<BodyAttitude>& attitude = std::nullopt);

struct ScanMatchingSlamStats {
  int scans = 0;
  int skipped_too_few_points = 0;
  int match_failures = 0;        // inserted at the prediction
  int timestamps_backwards = 0;
  long long floor_points = 0;    // end points removed as floor hits (scans with an attitude)
  int degenerate_matches = 0;    // matches whose weak direction kept the prediction
};

struct ScanResult {
  double stamp_seconds = 0.0;
  Pose2 predicted;
  Pose2 pose;                    // world_T_robot after matching
  ScanMatchResult match;
  bool inserted = false;
};

class ScanMatchingSlam {
 public:
  explicit ScanMatchingSlam(const ScanMatchingSlamOptions& options);

  // Processes one scan. `odometry_pose` is the odometry reading at the scan (any fixed
  // frame), required when the prediction is kOdometry and ignored otherwise. `attitude`: the
  // body's roll, pitch and height above the floor at the scan, when known (else level).
  ScanResult AddScan(const LaserScan& scan, const std::optional<Pose2>& odometry_pose = std::nullopt,
                     const std::optional<BodyAttitude>& attitude = std::nullopt);

  const LaserMap& map() const { return map_; }
  const std::vector<StampedPose2>& trajectory() const { return trajectory_; }
  const ScanMatchingSlamStats& stats() const { return stats_; }
  const ScanMatchingSlamOptions& options() const { return options_; }

 private:
  ScanMatchingSlamOptions options_;
  ScanMatcher matcher_;
  LaserMap map_;
  std::vector<StampedPose2> trajectory_;
  std::optional<Pose2> last_odometry_;
  ScanMatchingSlamStats stats_;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_SCAN_MATCHING_SLAM_H_
