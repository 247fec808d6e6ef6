#include "frontends/scan_matching_slam.h"

#include <cmath>
#include <sstream>

#include "Eigen/Eigenvalues"
#include "glog/logging.h"

namespace hetslam {

bool ParseMotionPrediction(const std::string& name, MotionPrediction* prediction) {
  if (name == "stationary") {
    *prediction = MotionPrediction::kStationary;
  } else if (name == "constant_velocity") {
    *prediction = MotionPrediction::kConstantVelocity;
  } else if (name == "odometry") {
    *prediction = MotionPrediction::kOdometry;
  } else {
    return false;
  }
  return true;
}

ScanMatcherOptions ScanMatchingSlamOptions::DefaultFrontEndMatcherOptions() {
  ScanMatcherOptions options;
  options.narrow_linear_search_window_meters = 0.4;
  options.narrow_angular_search_window_radians = 10.0 * M_PI / 180.0;
  options.narrow_accept_score = 0.4;
  return options;
}

bool ScanMatchingSlamOptions::IsValid(std::string* error) const {
  std::string sub;
  std::ostringstream msg;
  if (!grid.IsValid(&sub)) msg << "grid: " << sub;
  if (!field.IsValid(&sub)) msg << "field: " << sub;
  if (!matcher.IsValid(&sub)) msg << "matcher: " << sub;
  if (!(velocity_fraction >= 0 && velocity_fraction <= 1.5))
    msg << "velocity_fraction must be in [0, 1.5] (got " << velocity_fraction << "); ";
  if (!(angular_velocity_fraction >= 0 && angular_velocity_fraction <= 1.5))
    msg << "angular_velocity_fraction must be in [0, 1.5] (got " << angular_velocity_fraction << "); ";
  if (!(max_point_range_meters > 0)) msg << "max_point_range_meters must be > 0; ";
  if (!std::isfinite(floor_max_height_meters)) msg << "floor_max_height_meters must be finite; ";
  if (!(densify_max_gap_meters >= 0)) msg << "densify_max_gap_meters must be >= 0; ";
  if (!(degenerate_eigenvalue_ratio >= 0 && degenerate_eigenvalue_ratio < 1))
    msg << "degenerate_eigenvalue_ratio must be in [0, 1); ";
  if (!(matching_voxel_meters >= 0)) msg << "matching_voxel_meters must be >= 0; ";
  if (min_points < 1) msg << "min_points must be >= 1; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

ScanMatchingSlam::ScanMatchingSlam(const ScanMatchingSlamOptions& options)
    : options_(options), matcher_(options.matcher), map_(options.grid, options.field) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid ScanMatchingSlamOptions: " << error;
}

Pose2 PredictNextPose(const ScanMatchingSlamOptions& options, const std::vector<StampedPose2>& trajectory,
                      const std::optional<Pose2>& last_odometry, const std::optional<Pose2>& odometry) {
  if (trajectory.empty()) return Pose2::Identity();
  const Pose2& last = trajectory.back().pose;
  switch (options.prediction) {
    case MotionPrediction::kStationary:
      return last;
    case MotionPrediction::kConstantVelocity: {
      if (trajectory.size() < 2) return last;
      const Pose2 delta = Between(trajectory[trajectory.size() - 2].pose, last);
      return last * Pose2(options.velocity_fraction * delta.translation(),
                          options.angular_velocity_fraction * delta.theta());
    }
    case MotionPrediction::kOdometry:
      CHECK(odometry.has_value()) << "odometry prediction needs an odometry pose with every scan";
      if (!last_odometry.has_value()) return last;
      return last * Between(*last_odometry, *odometry);
  }
  return last;
}

bool NarrowSearchTrusted(const ScanMatchingSlamOptions& options, const std::vector<StampedPose2>& trajectory) {
  const ScanMatcherOptions& m = options.matcher;
  if (m.narrow_linear_search_window_meters <= 0.0 || m.narrow_angular_search_window_radians <= 0.0) return false;
  if (options.prediction == MotionPrediction::kOdometry) return true;
  if (trajectory.size() < 2) return false;
  const Pose2 delta = Between(trajectory[trajectory.size() - 2].pose, trajectory.back().pose);
  return delta.translation().norm() <= 0.5 * m.narrow_linear_search_window_meters &&
         std::abs(delta.theta()) <= 0.5 * m.narrow_angular_search_window_radians;
}

Pose2 DegeneracyAwarePose(const ScanMatchingSlamOptions& options, const Pose2& predicted, const ScanMatchResult& match,
                          bool* degenerate) {
  if (degenerate != nullptr) *degenerate = false;
  const Eigen::Matrix3d& info = match.information;
  if (options.degenerate_eigenvalue_ratio <= 0 || !(info(2, 2) > 0)) return match.pose;
  // Translational information with the yaw marginalised out (Schur complement).
  const Eigen::Matrix2d translational =
      info.topLeftCorner<2, 2>() - info.topRightCorner<2, 1>() * info.bottomLeftCorner<1, 2>() / info(2, 2);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(translational);
  const Eigen::Vector2d values = eigen.eigenvalues();  // ascending
  if (!(values(1) > 0) || values(0) >= options.degenerate_eigenvalue_ratio * values(1)) return match.pose;
  const Eigen::Vector2d strong = eigen.eigenvectors().col(1);
  const Eigen::Vector2d correction = match.pose.translation() - predicted.translation();
  if (degenerate != nullptr) *degenerate = true;
  return Pose2(predicted.translation() + strong.dot(correction) * strong, match.pose.theta());
}

ScanPoints PrepareScanPoints(const ScanMatchingSlamOptions& options, const LaserScan& scan,
                             const std::optional<BodyAttitude>& attitude) {
  ScanPoints points;
  const float max_range = static_cast<float>(options.max_point_range_meters);
  const float floor_height = static_cast<float>(options.floor_max_height_meters);
  const float max_gap = static_cast<float>(options.densify_max_gap_meters);
  const float step = static_cast<float>(options.grid.resolution_meters);
  int previous_beam = -2;
  for (const ProjectedPoint& p : ProjectScan(scan, attitude.value_or(BodyAttitude()))) {
    if (attitude.has_value() && p.z_meters < floor_height) {
      ++points.floor_points;
      continue;
    }
    if (p.p_robot.norm() > max_range) continue;
    if (max_gap > 0 && p.beam_index == previous_beam + 1) {
      // Neighbouring beams on one surface: fill the gap at the grid resolution.
      const Eigen::Vector2f from = points.all.back();
      const float gap = (p.p_robot - from).norm();
      if (gap > step && gap <= max_gap) {
        const int n = static_cast<int>(gap / step);
        for (int k = 1; k <= n; ++k) points.all.push_back(from + (p.p_robot - from) * (static_cast<float>(k) / (n + 1)));
      }
    }
    points.all.push_back(p.p_robot);
    previous_beam = p.beam_index;
  }
  points.matching = options.matching_voxel_meters > 0
                        ? VoxelFilter(points.all, static_cast<float>(options.matching_voxel_meters))
                        : points.all;
  points.sensor_robot = scan.robot_T_sensor.translation().head<2>();
  return points;
}

ScanResult ScanMatchingSlam::AddScan(const LaserScan& scan, const std::optional<Pose2>& odometry_pose,
                                     const std::optional<BodyAttitude>& attitude) {
  ScanResult result;
  result.stamp_seconds = scan.stamp_seconds;
  ++stats_.scans;
  if (!trajectory_.empty() && scan.stamp_seconds < trajectory_.back().stamp_seconds) ++stats_.timestamps_backwards;

  const ScanPoints points = PrepareScanPoints(options_, scan, attitude);
  stats_.floor_points += points.floor_points;
  result.predicted = PredictNextPose(options_, trajectory_, last_odometry_, odometry_pose);
  result.pose = result.predicted;
  if (static_cast<int>(points.all.size()) < options_.min_points) {
    ++stats_.skipped_too_few_points;
    return result;
  }
  if (map_.num_scans_inserted() > 0) {
    result.match = matcher_.Match(map_, result.predicted, points.matching, {},
                                  NarrowSearchTrusted(options_, trajectory_));
    if (result.match.converged) {
      bool degenerate = false;
      result.pose = DegeneracyAwarePose(options_, result.predicted, result.match, &degenerate);
      stats_.degenerate_matches += degenerate;
    } else {
      ++stats_.match_failures;
    }
  }
  map_.InsertScan(result.pose, points.sensor_robot, points.all);
  result.inserted = true;
  trajectory_.push_back({scan.stamp_seconds, result.pose});
  if (odometry_pose.has_value()) last_odometry_ = odometry_pose;
  return result;
}

}  // namespace hetslam
