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
// map), and their voxel-thinned subset (for matching).
struct ScanPoints {
  std::vector<Eigen::Vector2f> all;
  std::vector<Eigen::Vector2f> matching;
  Eigen::Vector2d sensor_robot = Eigen::Vector2d::Zero();  // sensor origin, robot frame
};
// Whether the front end may try the matcher's narrow windows first: with odometry always;
// otherwise when the last scan-to-scan motion was at most half the narrow windows (then the
// constant-velocity prediction is close). False when the narrow try is off.
bool NarrowSearchTrusted(const ScanMatchingSlamOptions& options, const std::vector<StampedPose2>& trajectory);

ScanPoints PrepareScanPoints(const ScanMatchingSlamOptions& options, const LaserScan& scan);

struct ScanMatchingSlamStats {
  int scans = 0;
  int skipped_too_few_points = 0;
  int match_failures = 0;        // inserted at the prediction
  int timestamps_backwards = 0;
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
  // frame), required when the prediction is kOdometry and ignored otherwise.
  ScanResult AddScan(const LaserScan& scan, const std::optional<Pose2>& odometry_pose = std::nullopt);

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
