#include "frontends/local_slam.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "Eigen/Eigenvalues"
#include "core/euler.h"
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

ScanMatcherOptions LocalSlamOptions::DefaultFrontEndMatcherOptions() {
  ScanMatcherOptions options;
  options.narrow_linear_search_window_meters = 0.4;
  options.narrow_angular_search_window_radians = 10.0 * M_PI / 180.0;
  options.narrow_accept_score = 0.4;
  return options;
}

bool LocalSlamOptions::IsValid(std::string* error) const {
  std::string sub;
  std::ostringstream msg;
  if (!grid.IsValid(&sub)) msg << "grid: " << sub;
  if (!field.IsValid(&sub)) msg << "field: " << sub;
  if (!matcher.IsValid(&sub)) msg << "matcher: " << sub;
  if (!(velocity_fraction >= 0 && velocity_fraction <= 1.5))
    msg << "velocity_fraction must be in [0, 1.5] (got " << velocity_fraction << "); ";
  if (!(angular_velocity_fraction >= 0 && angular_velocity_fraction <= 1.5))
    msg << "angular_velocity_fraction must be in [0, 1.5] (got " << angular_velocity_fraction << "); ";
  if (!(max_point_range_meters > 0 && max_point_range_meters <= 1e4))
    msg << "max_point_range_meters must be in (0, 1e4] (got " << max_point_range_meters << "); ";
  if (!std::isfinite(floor_max_height_meters)) msg << "floor_max_height_meters must be finite; ";
  if (!(odometry_noise_fraction >= 0 && odometry_noise_fraction <= 1)) msg << "odometry_noise_fraction must be in [0, 1]; ";
  if (!(motion_filter_distance_meters >= 0 && motion_filter_distance_meters <= 100))
    msg << "motion_filter_distance_meters must be in [0, 100]; ";
  if (!(motion_filter_angle_radians >= 0 && motion_filter_angle_radians <= M_PI))
    msg << "motion_filter_angle_radians must be in [0, pi]; ";
  if (!(motion_filter_attitude_radians >= 0 && motion_filter_attitude_radians <= M_PI))
    msg << "motion_filter_attitude_radians must be in [0, pi]; ";
  if (!(motion_filter_time_seconds >= 0 && motion_filter_time_seconds <= 1e9))
    msg << "motion_filter_time_seconds must be in [0, 1e9]; ";
  if (!(covariance_sigmas > 0 && covariance_sigmas <= 10)) msg << "covariance_sigmas must be in (0, 10]; ";
  if (!frontier_lines.IsValid(&sub)) msg << "frontier_lines: " << sub;
  if (!(frontier_margin_meters >= 0 && frontier_margin_meters <= 10)) msg << "frontier_margin_meters must be in [0, 10]; ";
  if (!(densify_max_gap_meters >= 0 && densify_max_gap_meters <= 10))
    msg << "densify_max_gap_meters must be in [0, 10] (got " << densify_max_gap_meters << "); ";
  if (!(floor_attitude_tolerance_radians >= 0 && floor_attitude_tolerance_radians < 0.5))
    msg << "floor_attitude_tolerance_radians must be in [0, 0.5); ";
  if (!(floor_obstacle_max_height_meters >= 0 && floor_obstacle_min_drop_meters >= 0))
    msg << "floor obstacle height and drop must be >= 0; ";
  if (!(floor_obstacle_min_height_above_floor_meters >= 0 && floor_obstacle_min_height_above_floor_meters <= 1))
    msg << "floor_obstacle_min_height_above_floor_meters must be in [0, 1]; ";
  if (!(suspend_floor_fraction > 0 && suspend_floor_fraction <= 1)) msg << "suspend_floor_fraction must be in (0, 1]; ";
  if (!(degenerate_eigenvalue_ratio >= 0 && degenerate_eigenvalue_ratio < 1))
    msg << "degenerate_eigenvalue_ratio must be in [0, 1); ";
  if (!(outlier_max_score >= 0 && outlier_max_score <= 1)) msg << "outlier_max_score must be in [0, 1]; ";
  if (!(degenerate_max_drop_ratio >= 0 && degenerate_max_drop_ratio < 1))
    msg << "degenerate_max_drop_ratio must be in [0, 1); ";
  if (!(matching_voxel_meters == 0 || (matching_voxel_meters >= 1e-3 && matching_voxel_meters <= 10)))
    msg << "matching_voxel_meters must be 0 or in [0.001, 10] (got " << matching_voxel_meters << "); ";
  if (min_points < 1) msg << "min_points must be >= 1; ";
  if (scans_per_submap != 0 && scans_per_submap < 2) msg << "scans_per_submap must be 0 or >= 2; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

Pose2 PredictNextPose(const LocalSlamOptions& options, const std::vector<StampedPose2>& trajectory,
                      const std::optional<Pose2>& last_motion, const std::optional<Pose2>& motion) {
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
      if (!last_motion.has_value() || !motion.has_value()) return last;
      return last * Between(*last_motion, *motion);
  }
  return last;
}

bool NarrowSearchTrusted(const LocalSlamOptions& options, const std::vector<StampedPose2>& trajectory) {
  const ScanMatcherOptions& m = options.matcher;
  if (m.narrow_linear_search_window_meters <= 0.0 || m.narrow_angular_search_window_radians <= 0.0) return false;
  if (trajectory.size() < 2) return false;
  const Pose2 delta = Between(trajectory[trajectory.size() - 2].pose, trajectory.back().pose);
  return delta.translation().norm() <= 0.5 * m.narrow_linear_search_window_meters &&
         std::abs(delta.theta()) <= 0.5 * m.narrow_angular_search_window_radians;
}

bool RunsIntoUnobservedGround(const LaserMap& map, const Pose2& world_T_robot, const Eigen::Vector2f& p_robot,
                              const ScanLine& line, double margin_meters) {
  if (!(line.half_length > 0.f)) return false;
  const GridGeometry& geometry = map.grid().geometry();
  const float near_surface = std::exp(-1.f);  // within sigma of a mapped surface
  for (const float side : {-1.f, 1.f}) {
    const Eigen::Vector2f q = p_robot + side * static_cast<float>(margin_meters) * line.direction;
    const CellIndex c = geometry.WorldToCell(world_T_robot * q.cast<double>());
    if (!geometry.Contains(c)) return true;
    if (map.grid().State(c) == CellState::kUnknown && map.field().Value(c) < near_surface) return true;
  }
  return false;
}

// The refinement's points from the points the matching ones were thinned from
// (LocalSlamOptions::refine_on_all_points: all of them; refine_on_voxel_ends: each matching
// voxel's first and last point; refine_on_middle_beams: its middle point).
std::vector<Eigen::Vector2f> RefinementPoints(const LocalSlamOptions& options, std::vector<Eigen::Vector2f> points) {
  if (options.refine_on_all_points) return points;
  return VoxelFilter(points, static_cast<float>(options.matching_voxel_meters),
                     options.refine_on_voxel_ends ? VoxelPoint::kFirstAndLast : VoxelPoint::kMiddle);
}

int LeaveOutFrontierPoints(const LocalSlamOptions& options, const LaserMap& map, const Pose2& predicted,
                           ScanPoints* points) {
  if (options.frontier_margin_meters <= 0 || map.num_scans_inserted() == 0) return 0;
  const std::vector<ScanLine> lines = EstimateScanLines(options.frontier_lines, points->all);
  std::vector<Eigen::Vector2f> kept;
  kept.reserve(points->all.size());
  for (size_t k = 0; k < points->all.size(); ++k) {
    if (!RunsIntoUnobservedGround(map, predicted, points->all[k], lines[k], options.frontier_margin_meters)) {
      kept.push_back(points->all[k]);
    }
  }
  const int left_out = static_cast<int>(points->all.size() - kept.size());
  if (left_out == 0 || static_cast<int>(kept.size()) < options.min_points) return 0;
  std::vector<Eigen::Vector2f> matching =
      options.matching_voxel_meters > 0 ? VoxelFilter(kept, static_cast<float>(options.matching_voxel_meters)) : kept;
  // Most of a scan beyond the frontier (a robot turning into unexplored space): the few points
  // left (fewer than half the matching points) could not place it; the whole scan is matched.
  if (2 * matching.size() < points->matching.size()) return 0;
  points->matching = std::move(matching);
  if (!points->refinement.empty()) {
    points->refinement = RefinementPoints(options, std::move(kept));
  }
  return left_out;
}

int AddFloorObstaclesOnMappedStructure(const LocalSlamOptions& options, const LaserMap& map, const Pose2& predicted,
                                       ScanPoints* points) {
  if (!options.match_floor_obstacles_on_mapped_structure || map.num_scans_inserted() == 0 ||
      points->floor_obstacles.empty() || !points->matching_weights.empty()) {
    return 0;
  }
  std::vector<Eigen::Vector2f> on_structure;
  for (const Eigen::Vector2f& p : points->floor_obstacles) {
    if (map.grid().StateAt(predicted * p.cast<double>()) == CellState::kOccupied) on_structure.push_back(p);
  }
  if (on_structure.empty()) return 0;
  // The matching points first: a voxel they hold keeps its point.
  std::vector<Eigen::Vector2f> matching = points->matching;
  matching.insert(matching.end(), on_structure.begin(), on_structure.end());
  points->matching = options.matching_voxel_meters > 0
                         ? VoxelFilter(matching, static_cast<float>(options.matching_voxel_meters))
                         : std::move(matching);
  if (!points->refinement.empty()) {
    std::vector<Eigen::Vector2f> refinement = std::move(points->refinement);
    refinement.insert(refinement.end(), on_structure.begin(), on_structure.end());
    points->refinement = RefinementPoints(options, std::move(refinement));
  }
  return static_cast<int>(on_structure.size());
}

Pose2 DegeneracyAwarePose(const LocalSlamOptions& options, const Pose2& predicted, const ScanMatchResult& match,
                          bool* degenerate, Eigen::Vector2d* weak_direction) {
  if (degenerate != nullptr) *degenerate = false;
  const Eigen::Matrix3d& info = match.information;
  const bool use_ratio = options.degenerate_eigenvalue_ratio > 0;
  const bool use_drop = options.degenerate_max_drop_ratio > 0 && match.weak_direction.squaredNorm() > 0;
  Eigen::Vector2d weak = Eigen::Vector2d::Zero();
  if (use_drop && match.weak_direction_score_drop < options.degenerate_max_drop_ratio * match.strong_direction_score_drop) {
    weak = match.weak_direction;  // the score is flat along it
  } else if (use_ratio && info(2, 2) > 0) {
    // Translational information with the yaw marginalised out (Schur complement).
    const Eigen::Matrix2d translational =
        info.topLeftCorner<2, 2>() - info.topRightCorner<2, 1>() * info.bottomLeftCorner<1, 2>() / info(2, 2);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(translational);
    const Eigen::Vector2d values = eigen.eigenvalues();  // ascending
    if (values(1) > 0 && values(0) < options.degenerate_eigenvalue_ratio * values(1)) {
      // The score profile's flattest direction, when there is one: the information's weakest
      // eigenvector is mostly the noise of the hits (on a single wall 45 to 65 degrees off
      // it, against 1 to 6 for the profile's), and holding a wrong direction moves the pose
      // across the wall by the search's pull along it.
      weak = match.weak_direction.squaredNorm() > 0 ? Eigen::Vector2d(match.weak_direction.normalized())
                                                    : Eigen::Vector2d(eigen.eigenvectors().col(0).normalized());
    }
  }
  if (weak.squaredNorm() == 0) return match.pose;
  const Eigen::Vector2d strong(-weak.y(), weak.x());
  const Eigen::Vector2d correction = match.pose.translation() - predicted.translation();
  if (degenerate != nullptr) *degenerate = true;
  if (weak_direction != nullptr) *weak_direction = weak;
  return Pose2(predicted.translation() + strong.dot(correction) * strong, match.pose.theta());
}

bool FacesFloor(const LocalSlamOptions& options, const ScanPoints& points) {
  return points.valid_points > 0 && options.suspend_floor_fraction < 1.0 &&
         points.floor_points > options.suspend_floor_fraction * points.valid_points;
}

bool FitFloorLine(const std::vector<Eigen::Vector3f>& points, double max_tilt, FloorLine* line) {
  constexpr int kMinPoints = 20;
  constexpr double kMinSpanMeters = 0.3;
  if (static_cast<int>(points.size()) < kMinPoints) return false;
  FloorLine fit;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3f& p : points) centre += p.head<2>().cast<double>();
  centre /= static_cast<double>(points.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector2d d = p.head<2>().cast<double>() - centre;
    scatter += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> axes(scatter);
  fit.centre = centre.cast<float>();
  fit.direction = axes.eigenvectors().col(1).cast<float>();  // the larger eigenvalue's
  // Each point's position along the line and its height, computed once (HeightAt at point k
  // is offset + slope * t[k]).
  const int count = static_cast<int>(points.size());
  std::vector<float> t(count), z(count);
  for (int k = 0; k < count; ++k) {
    t[k] = fit.direction.dot(points[k].head<2>() - fit.centre);
    z[k] = points[k].z();
  }
  if (*std::max_element(t.begin(), t.end()) - *std::min_element(t.begin(), t.end()) < kMinSpanMeters) return false;
  // The start: among the lines through two of ~32 points spread over the list, no steeper than
  // max_tilt, the one with the most points within 1 cm of it, each count weighed by how level
  // the line lies. A tilted scan also puts low wall hits in the floor band, often more of them
  // than floor hits (a wall seen along it, a room's corner at the laser's range); a
  // least-squares start over every point (or a median-based one, when the floor is not the
  // majority) is pulled up by them, and trimming about it then keeps them. What tells the floor:
  // - projected with an attitude error below max_tilt, the floor lies on the plane through the
  //   body z = ω_y x − ω_x y (FloorTiltError), so a floor point's |z| / (its distance) is at
  //   most the error, where a wall's low hits stand higher: the weight is a normal density of
  //   the line's largest such ratio (and of its slope) with max_tilt as two standard deviations;
  // - the floor is the lowest surface the beams reach: a line with more than a tenth as many
  //   points 2 cm or more below it as within 1 cm of it is a wall's low hits.
  constexpr float kConsensusMeters = 0.01f;
  const float tilt_sigma = 0.5f * static_cast<float>(max_tilt);
  const int stride = std::max(1, count / 32);
  auto level = [&](const Eigen::Vector3f& p) { return std::abs(p.z()) / std::max(0.3f, p.head<2>().norm()); };
  int best_support = 0;
  float best_score = 0.f;
  for (int i = 0; i < count; i += stride) {
    for (int j = i + stride; j < count; j += stride) {
      if (!(std::abs(t[j] - t[i]) >= 0.1f * kMinSpanMeters)) continue;
      const float slope = (z[j] - z[i]) / (t[j] - t[i]);
      if (!(std::abs(slope) <= max_tilt)) continue;
      const float u = std::max({std::abs(slope), level(points[i]), level(points[j])}) / tilt_sigma;
      const float weight = std::exp(-0.5f * u * u);
      if (static_cast<float>(count) * weight <= best_score) continue;  // cannot win with every point
      const float offset = z[i] - slope * t[i];
      int support = 0, below = 0;
      for (int k = 0; k < count; ++k) {
        const float residual = z[k] - (offset + slope * t[k]);
        support += std::abs(residual) <= kConsensusMeters;
        below += residual < -2.f * kConsensusMeters;
      }
      if (10 * below > support) continue;
      const float score = static_cast<float>(support) * weight;
      if (score > best_score) {
        best_score = score;
        best_support = support;
        fit.offset = offset;
        fit.slope = slope;
      }
    }
  }
  if (best_support < kMinPoints) return false;
  // Then least squares, five rounds, each over the points within 3 RMS (at least 1 cm) of the
  // previous line: the low obstacles on the floor, all on one side, stay out.
  float keep_within = kConsensusMeters;
  for (int round = 0; round < 5; ++round) {
    double n = 0, st = 0, sz = 0, stt = 0, stz = 0;
    for (int k = 0; k < count; ++k) {
      if (std::abs(z[k] - (fit.offset + fit.slope * t[k])) > keep_within) continue;
      const double tk = t[k];
      n += 1;
      st += tk;
      sz += z[k];
      stt += tk * tk;
      stz += tk * z[k];
    }
    const double denominator = n * stt - st * st;
    if (n < kMinPoints || denominator <= 0.0) return false;
    FloorLine next = fit;
    next.slope = static_cast<float>((n * stz - st * sz) / denominator);
    next.offset = static_cast<float>((sz - next.slope * st) / n);
    double sum_sq = 0.0;
    for (int k = 0; k < count; ++k) {
      if (std::abs(z[k] - (fit.offset + fit.slope * t[k])) > keep_within) continue;
      const double residual = z[k] - (next.offset + next.slope * t[k]);
      sum_sq += residual * residual;
    }
    next.inliers = static_cast<int>(n);
    next.rms = static_cast<float>(std::sqrt(sum_sq / n));
    fit = next;
    keep_within = std::max(kConsensusMeters, 3.f * fit.rms);
  }
  if (!(std::abs(fit.slope) <= max_tilt)) return false;
  *line = fit;
  return true;
}

double SensorHeight(const LaserScan& scan, const BodyAttitude& attitude) {
  return (RotationFromRollPitchYaw(attitude.roll_radians, attitude.pitch_radians, 0.0) * scan.robot_T_sensor.translation())
             .z() +
         attitude.base_height_meters;
}

bool FloorTiltError(const FloorLine& line, double min_distance_meters, double max_distance_meters,
                    Eigen::Vector2d* roll_pitch_radians) {
  const Eigen::Vector2d c = line.centre.cast<double>();
  const Eigen::Vector2d d = line.direction.cast<double>().normalized();
  // [-c_y  c_x] [ω_x]   [offset]
  // [-d_y  d_x] [ω_y] = [slope ]
  const double determinant = c.x() * d.y() - c.y() * d.x();
  if (!(min_distance_meters > 0.0) || !(std::abs(determinant) >= min_distance_meters) ||
      !(std::abs(determinant) <= max_distance_meters)) {
    return false;
  }
  const double offset = line.offset, slope = line.slope;
  *roll_pitch_radians = Eigen::Vector2d((offset * d.x() - c.x() * slope) / determinant,
                                        (d.y() * offset - c.y() * slope) / determinant);
  return true;
}

ScanPoints PrepareScanPoints(const LocalSlamOptions& options, const LaserScan& scan,
                             const std::optional<BodyAttitude>& attitude) {
  ScanPoints points;
  const float max_range = static_cast<float>(options.max_point_range_meters);
  const float floor_height = static_cast<float>(options.floor_max_height_meters);
  const float max_gap = static_cast<float>(options.densify_max_gap_meters);
  const float step = static_cast<float>(options.grid.resolution_meters);
  const BodyAttitude body = attitude.value_or(BodyAttitude());
  // Height of the sensor above the floor: a point well below it and low is a floor obstacle.
  const float sensor_height = static_cast<float>(SensorHeight(scan, body));
  const float obstacle_max_height = static_cast<float>(options.floor_obstacle_max_height_meters);
  const float floor_slope = static_cast<float>(std::tan(options.floor_attitude_tolerance_radians));
  const Eigen::Vector2f sensor_xy = (RotationFromRollPitchYaw(body.roll_radians, body.pitch_radians, 0.0) *
                                     scan.robot_T_sensor.translation()).head<2>().cast<float>();
  const float obstacle_min_drop = static_cast<float>(options.floor_obstacle_min_drop_meters);
  int previous_beam = -2;
  points.projected = attitude.has_value();
  const std::vector<ProjectedPoint> projected = ProjectScan(scan, body);
  // The floor's tolerance grows with the distance from the sensor: an attitude error of
  // floor_attitude_tolerance_radians lifts a far floor hit by distance * tan(error).
  auto in_floor_band = [&](const ProjectedPoint& p) {
    return attitude.has_value() && p.z_meters < floor_height + floor_slope * (p.p_robot - sensor_xy).norm();
  };
  auto low_obstacle_shape = [&](const ProjectedPoint& p) {
    return obstacle_max_height > 0 && p.z_meters <= obstacle_max_height &&
           p.z_meters < sensor_height - obstacle_min_drop && p.p_robot.norm() <= max_range;
  };
  // The floor this scan sees (FitFloorLine): low floor obstacles stand above it, and its tilt
  // is the attitude's error (FloorTiltError; ScanPoints::floor_line).
  std::optional<FloorLine> floor_line;
  const float min_above_floor = static_cast<float>(options.floor_obstacle_min_height_above_floor_meters);
  if (attitude.has_value()) {
    std::vector<Eigen::Vector3f> floor_hits;
    for (const ProjectedPoint& p : projected) {
      if (in_floor_band(p)) floor_hits.emplace_back(p.p_robot.x(), p.p_robot.y(), p.z_meters);
    }
    FloorLine line;
    if (FitFloorLine(floor_hits, floor_slope, &line)) floor_line = line;
  }
  const float above_floor = floor_line.has_value() ? std::max(min_above_floor, 4.f * floor_line->rms) : 0.f;
  for (const ProjectedPoint& p : projected) {
    ++points.valid_points;
    if (in_floor_band(p)) {
      ++points.floor_points;
      if (min_above_floor > 0 && floor_line.has_value() && p.z_meters - floor_line->HeightAt(p.p_robot) >= above_floor &&
          low_obstacle_shape(p)) {
        points.floor_obstacles.push_back(p.p_robot);
      }
      continue;
    }
    if (p.p_robot.norm() > max_range) continue;
    if (attitude.has_value() && obstacle_max_height > 0 && p.z_meters <= obstacle_max_height &&
        p.z_meters < sensor_height - obstacle_min_drop) {
      // Paper §III-E: above the floor but low, seen by a beam tilted down: an object on the floor
      // that breaks the 2.5D assumption. Kept for planners, never matched or mapped as structure.
      points.floor_obstacles.push_back(p.p_robot);
      continue;
    }
    if (max_gap > 0 && p.beam_index == previous_beam + 1) {
      // Neighbouring beams on one surface: fill the gap at the grid resolution.
      const Eigen::Vector2f from = points.all.back();
      const float from_z = points.heights_meters.back();
      const float gap = (p.p_robot - from).norm();
      if (gap > step && gap <= max_gap) {
        const int n = static_cast<int>(gap / step);
        for (int k = 1; k <= n; ++k) {
          const float f = static_cast<float>(k) / (n + 1);
          points.all.push_back(from + (p.p_robot - from) * f);
          points.heights_meters.push_back(from_z + (p.z_meters - from_z) * f);
          points.labels.push_back(PointLabel::kStructure);
        }
      }
    }
    points.all.push_back(p.p_robot);
    points.heights_meters.push_back(attitude.has_value() ? p.z_meters : 0.0f);
    points.labels.push_back(PointLabel::kStructure);
    previous_beam = p.beam_index;
  }
  points.matching = options.matching_voxel_meters > 0
                        ? VoxelFilter(points.all, static_cast<float>(options.matching_voxel_meters))
                        : points.all;
  if ((options.refine_on_all_points || options.refine_on_voxel_ends || options.refine_on_middle_beams) &&
      options.matching_voxel_meters > 0 &&
      !points.matching.empty()) {
    points.refinement = RefinementPoints(options, points.all);
  }
  points.sensor_robot = scan.robot_T_sensor.translation().head<2>();
  points.attitude = body;
  points.floor_line = floor_line;
  return points;
}


LocalSlam::LocalSlam(const LocalSlamOptions& options) : options_(options), matcher_(options.matcher) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid LocalSlamOptions: " << error;
}

Prediction LocalSlam::Predict(const std::optional<Pose2>& odometry) const { return PredictFrom(state_, odometry); }

Prediction LocalSlam::PredictFrom(const LocalSlamState& state, const std::optional<Pose2>& odometry) const {
  Prediction prediction;
  prediction.pose = PredictNextPose(options_, state.recent, state.last_odometry, odometry);
  if (options_.prediction == MotionPrediction::kOdometry && odometry.has_value()) {
    prediction.external = true;
    prediction.motion = odometry;
    if (state.last_odometry.has_value() && options_.odometry_noise_fraction > 0) {
      // The increment's own size bounds its error (a wheel odometry's few per cent, ten here):
      // the search windows follow it (Prediction::covariance).
      const Pose2 increment = Between(*state.last_odometry, *odometry);
      const double f = options_.odometry_noise_fraction;
      const double translation = f * increment.translation().norm();
      const double yaw = f * std::abs(increment.theta()) + 0.5 * f * increment.translation().norm();
      prediction.covariance = Eigen::Vector3d(translation * translation, translation * translation, yaw * yaw).asDiagonal();
    }
  }
  return prediction;
}

bool LocalSlam::NothingNew(const LocalSlamState& state, double stamp_seconds, const Pose2& local_pose,
                           const BodyAttitude& attitude) const {
  if (options_.motion_filter_distance_meters <= 0 || !state.last_inserted.has_value()) return false;
  const InsertedScan& last = *state.last_inserted;
  const Pose2 moved = Between(last.local_pose, local_pose);
  const double height = attitude.base_height_meters - last.attitude.base_height_meters;
  return std::hypot(moved.translation().norm(), height) < options_.motion_filter_distance_meters &&
         std::abs(moved.theta()) < options_.motion_filter_angle_radians &&
         std::abs(attitude.roll_radians - last.attitude.roll_radians) < options_.motion_filter_attitude_radians &&
         std::abs(attitude.pitch_radians - last.attitude.pitch_radians) < options_.motion_filter_attitude_radians &&
         (options_.motion_filter_time_seconds <= 0 ||
          std::abs(stamp_seconds - last.stamp_seconds) < options_.motion_filter_time_seconds);
}

LocalResult LocalSlam::AddScan(double stamp_seconds, ScanPoints points, const Prediction& prediction,
                               bool motion_filter) {
  LocalResult result = Match(stamp_seconds, std::move(points), prediction);
  if (result.awaiting_insertion) Insert(&result, motion_filter);
  return result;
}

LocalResult LocalSlam::Match(double stamp_seconds, ScanPoints points, const Prediction& prediction) {
  LocalResult result;
  result.stamp_seconds = stamp_seconds;
  result.predicted = prediction.pose;
  result.local_pose = prediction.pose;
  // Paper §III-A/E: while the laser faces the floor, matching and map updates stop; the caller's
  // prediction (the EKF) carries the pose until walls come back.
  if (FacesFloor(options_, points)) {
    result.suspended = true;
    result.points = std::move(points);
    return result;
  }
  if (static_cast<int>(points.all.size()) < options_.min_points) return result;
  LocalSlamState& state = state_;
  const auto match_start = std::chrono::steady_clock::now();
  // Match against the oldest active submap, in its frame.
  if (!state.active.empty() && state.active.front().num_scans > 0) {
    // (A map shared with another particle is updated in place: both hold the same scans.)
    state.active.front().map->UpdateField();
    const ActiveSubmap& target = state.active.front();
    const Pose2 predicted_submap = target.local_T_submap.inverse() * prediction.pose;
    result.matched = true;
    // Only with a motion source (see frontier_margin_meters): without one, the frontier points
    // are the only evidence of the motion along a wall.
    if (prediction.external && prediction.measures_translation) {
      result.frontier_points = LeaveOutFrontierPoints(options_, *target.map, predicted_submap, &points);
    }
    result.structure_floor_obstacles =
        AddFloorObstaclesOnMappedStructure(options_, *target.map, predicted_submap, &points);
    // The refinement's own points (refine_on_voxel_ends, ...), for a scan without matching weights.
    const std::vector<Eigen::Vector2f>* refinement =
        points.refinement.empty() || !points.matching_weights.empty() ? nullptr : &points.refinement;
    if (prediction.covariance.has_value()) {
      const ScanMatcherOptions& m = options_.matcher;
      const Eigen::Matrix3d& covariance = *prediction.covariance;
      const double translation_sigma =
          std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(covariance.topLeftCorner<2, 2>())
                                      .eigenvalues()(1)));
      const double yaw_sigma = std::sqrt(std::max(0.0, covariance(2, 2)));
      const double linear = std::min(m.linear_search_window_meters,
                                     m.narrow_linear_search_window_meters + options_.covariance_sigmas * translation_sigma);
      const double angular = std::min(m.angular_search_window_radians,
                                      m.narrow_angular_search_window_radians + options_.covariance_sigmas * yaw_sigma);
      result.match = matcher_.MatchWithinWindow(*target.map, predicted_submap, points.matching, linear, angular,
                                                points.matching_weights, 0.0, refinement);
      if (result.match.converged && result.match.score < options_.outlier_max_score) {
        // A poor fit far outside the prediction's own uncertainty: the motion source (a gyro,
        // odometry) is the better estimate. Mahalanobis distance of the correction, the
        // prediction's covariance widened by the matcher's resolution.
        const Pose2 correction = Between(predicted_submap, result.match.pose);
        Eigen::Vector3d c;
        c << target.local_T_submap.rotation() * predicted_submap.rotation() * correction.translation(), correction.theta();
        const double r = options_.grid.resolution_meters;
        const Eigen::Matrix3d widened =
            covariance +
            Eigen::Matrix3d(Eigen::Vector3d(r * r, r * r, m.max_angular_step_radians * m.max_angular_step_radians).asDiagonal());
        if (c.dot(widened.ldlt().solve(c)) > options_.covariance_sigmas * options_.covariance_sigmas) {
          result.match.converged = false;
          result.match.message = "a poor fit (score " + std::to_string(result.match.score) +
                                 ") outside the prediction's covariance";
        }
      }
    } else {
      result.match = matcher_.Match(*target.map, predicted_submap, points.matching, points.matching_weights,
                                    prediction.external || NarrowSearchTrusted(options_, state.recent), refinement);
    }
    if (result.match.converged) {
      // Along a flat direction the prediction is kept, when it measures the motion there; the
      // scan then places the pose across that direction and in yaw from there, so the search's
      // pull along it (a sparsely mapped wall's dots fit best where earlier scans were taken)
      // does not leak into the other two.
      Eigen::Vector2d weak_direction = Eigen::Vector2d::Zero();
      Pose2 submap_T_robot =
          prediction.external && prediction.measures_translation
              ? DegeneracyAwarePose(options_, predicted_submap, result.match, &result.degenerate, &weak_direction)
              : result.match.pose;
      if (result.degenerate) {
        submap_T_robot = matcher_.RefineHoldingDirection(*target.map, submap_T_robot, weak_direction,
                                                         refinement != nullptr ? *refinement : points.matching,
                                                         points.matching_weights);
      }
      result.local_pose = target.local_T_submap * submap_T_robot;
      result.weak_direction = target.local_T_submap.rotation() * weak_direction;
    }
  }
  result.match_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - match_start).count();
  if (prediction.motion.has_value()) state.last_odometry = prediction.motion;
  state.recent.push_back({stamp_seconds, result.local_pose});
  if (state.recent.size() > 3) state.recent.erase(state.recent.begin());
  // The refinement's points served the match only (insertion and the graph's nodes take `all`
  // and `matching`); with refine_on_all_points they are a copy of the whole scan, which a
  // particle's deferred results would otherwise hold until it collapses.
  points.refinement = std::vector<Eigen::Vector2f>();
  result.points = std::move(points);
  result.awaiting_insertion = true;
  return result;
}

void LocalSlam::Insert(LocalResult* result_ptr, bool motion_filter) {
  LocalResult& result = *result_ptr;
  CHECK(result.awaiting_insertion) << "LocalSlam::Insert of a result that is not awaiting insertion";
  result.awaiting_insertion = false;
  const auto insert_start = std::chrono::steady_clock::now();
  LocalSlamState& state = state_;
  const double stamp_seconds = result.stamp_seconds;
  const ScanPoints& points = result.points;
  // Nothing new (the motion filter): the scan still goes into the active submaps (they see
  // every observation), but it is no node and no step towards a new or finished submap.
  result.filtered = motion_filter && NothingNew(state, stamp_seconds, result.local_pose, points.attitude);
  if (!result.filtered) {
    state.last_inserted = InsertedScan{stamp_seconds, result.local_pose, points.attitude};
    ++state.num_inserted;
  }

  // Submap bookkeeping: a new submap every scans_per_submap / 2 scans (one, ever, for 0).
  const int half = options_.scans_per_submap > 0 ? std::max(1, options_.scans_per_submap / 2) : 0;
  if (!result.filtered && (state.active.empty() || (half > 0 && state.active.back().num_scans >= half))) {
    ActiveSubmap submap{state.next_submap_index++, result.local_pose,
                        std::make_shared<LaserMap>(options_.grid, options_.field, options_.matcher.wall_weight != 1.0), 0};
    result.new_submaps.push_back({submap.index, submap.local_T_submap});
    state.active.push_back(std::move(submap));
  }
  for (ActiveSubmap& submap : state.active) {
    // A filtered scan refines the submap until it holds a submap's worth of them: a robot
    // standing still then stops changing its map, and a scan that cannot move along a wall
    // (laser only) does not sharpen the wall's end at the laser's range into a feature.
    if (result.filtered) {
      if (options_.scans_per_submap > 0 && submap.num_filtered >= options_.scans_per_submap) continue;
      ++submap.num_filtered;
    }
    const Pose2 submap_T_node = submap.local_T_submap.inverse() * result.local_pose;
    // Labels and heights (the label layer, walls) only for 2.5D-projected scans: a level
    // scan's points are all structure at one height.
    // Copy on write: another particle's state shares this map.
    if (submap.map.use_count() > 1) submap.map = std::make_shared<LaserMap>(*submap.map);
    // Only the submap matched against (the oldest) keeps its likelihood field up to date with
    // every scan; the others catch up when they become the oldest (LaserMap::UpdateField).
    submap.map->InsertScan(submap_T_node, points.sensor_robot, points.all, points.projected ? &points.labels : nullptr,
                          points.projected ? &points.heights_meters : nullptr, &submap == &state.active.front());
    if (result.filtered) continue;
    ++submap.num_scans;
    result.insertions.push_back({submap.index, submap_T_node});
  }
  if (!result.filtered && options_.scans_per_submap > 0 && state.active.front().num_scans >= options_.scans_per_submap) {
    ActiveSubmap& done = state.active.front();
    // Matched against only from now on. (Unshared: it just took this scan.)
    done.map->Freeze();
    result.finished = LocalResult::FinishedSubmap{done.index, std::move(done.map)};
    state.active.erase(state.active.begin());
  }
  result.inserted = !result.filtered;
  result.insert_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - insert_start).count();
}

}  // namespace hetslam
