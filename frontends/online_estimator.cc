#include "frontends/online_estimator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "Eigen/Geometry"
#include "core/text_fields.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

bool Finite(const Pose2& pose) { return std::isfinite(pose.x()) && std::isfinite(pose.y()) && std::isfinite(pose.theta()); }

std::string StampText(double stamp_seconds) {
  std::ostringstream out;
  out.precision(17);
  out << stamp_seconds;
  return out.str();
}

// "line N: " when the measurement came from a file line.
std::string Where(int line_number) { return line_number > 0 ? "line " + std::to_string(line_number) + ": " : ""; }

// The latest element of a stamp-ordered deque at or before `stamp`, if any.
template <typename T>
const T* LatestAtOrBefore(const std::deque<T>& history, double stamp_seconds) {
  auto it = std::upper_bound(history.begin(), history.end(), stamp_seconds,
                             [](double stamp, const T& item) { return stamp < item.stamp_seconds; });
  return it == history.begin() ? nullptr : &*(it - 1);
}

}  // namespace

Status ApplyLogParams(const std::map<std::string, std::string>& params, OnlineEstimatorOptions* options) {
  const auto it = params.find("command_response_seconds");
  if (it == params.end()) return Status::Ok();
  double seconds = 0.0;
  const bool number = text_fields::ParseFiniteDouble(it->second, &seconds);
  EkfStateUpdaterOptions ekf = options->ekf;
  ekf.command_response_seconds = seconds;
  std::string why;
  if (!number || !ekf.IsValid(&why)) {
    return Status::Error("PARAM command_response_seconds '" + it->second +
                         "': " + (why.empty() ? std::string("not a number") : why));
  }
  options->ekf = ekf;
  return Status::Ok();
}

bool ParseAttitudeSource(const std::string& name, AttitudeSource* source) {
  if (name == "level") {
    *source = AttitudeSource::kLevel;
  } else if (name == "marg") {
    *source = AttitudeSource::kMargFilter;
  } else if (name == "logged") {
    *source = AttitudeSource::kLogged;
  } else {
    return false;
  }
  return true;
}

bool OnlineEstimatorOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  std::string sub;
  if (!local.IsValid(&sub)) msg << "local: " << sub;
  if (!loop.IsValid(&sub)) msg << "loop: " << sub;
  if (!graph.IsValid(&sub)) msg << "graph: " << sub;
  if (!marg.IsValid(&sub)) msg << "marg: " << sub << "; ";
  if (!ekf.IsValid(&sub)) msg << "ekf: " << sub << "; ";
  if (!particles.IsValid(&sub)) msg << "particles: " << sub;
  if (loop_closure && local.scans_per_submap < 2)
    msg << "loop closure needs local.scans_per_submap >= 2 (got " << local.scans_per_submap << "); ";
  if (solve_every_n_loop_closures < 1) msg << "solve_every_n_loop_closures must be >= 1; ";
  if (solve_min_new_nodes < 0) msg << "solve_min_new_nodes must be >= 0; ";
  if (!(solve_min_new_node_share >= 0 && solve_min_new_node_share <= 1))
    msg << "solve_min_new_node_share must be in [0, 1], got " << solve_min_new_node_share << "; ";
  if (max_iterations_per_solve < 1 || max_iterations_final < 1) msg << "solver iteration limits must be >= 1; ";
  if (!(attitude_max_age_seconds >= 0 && altitude_max_age_seconds >= 0 && odometry_max_age_seconds >= 0))
    msg << "attitude, altitude and odometry ages must be >= 0; ";
  if (!(degenerate_sigma_meters > 0 && degenerate_sigma_meters <= 1e3)) msg << "degenerate_sigma_meters must be in (0, 1000]; ";
  if (!(max_scan_jump_meters > 0)) msg << "max_scan_jump_meters must be > 0; ";
  if (!(floor_tilt_gain >= 0 && floor_tilt_gain <= 1))
    msg << "floor_tilt_gain must be in [0, 1] (0 = off), got " << floor_tilt_gain << "; ";
  if (!(floor_tilt_min_line_distance_meters > 0 && floor_tilt_max_rms_meters > 0 && floor_tilt_max_error_radians > 0))
    msg << "floor_tilt_min_line_distance_meters, floor_tilt_max_rms_meters and floor_tilt_max_error_radians must be > 0; ";
  if (!(floor_tilt_min_depression_radians > 0 && floor_tilt_min_depression_radians < M_PI / 2))
    msg << "floor_tilt_min_depression_radians must be in (0, pi/2); ";
  if (!(floor_tilt_max_correction_radians >= 0 && floor_tilt_max_correction_radians < M_PI / 4))
    msg << "floor_tilt_max_correction_radians must be in [0, pi/4); ";
  if (!(min_well_constrained_fraction >= 0 && min_well_constrained_fraction <= 1))
    msg << "min_well_constrained_fraction must be in [0, 1]; ";
  if (!(retire_revisited_share >= 0 && retire_revisited_share <= 1))
    msg << "retire_revisited_share must be in [0, 1] (0 = off), got " << retire_revisited_share << "; ";
  if (!(scan_match_translation_sigma_meters > 0 && scan_match_rotation_sigma_radians > 0))
    msg << "scan-match sigmas must be > 0; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

OnlineEstimator::OnlineEstimator(const OnlineEstimatorOptions& options)
    : OnlineEstimator(options, nullptr) {}

OnlineEstimator::OnlineEstimator(const OnlineEstimatorOptions& options, SubmapGraph* team_graph)
    : options_(options),
      local_(options.local, options.particles),
      owned_graph_(team_graph == nullptr ? std::make_unique<SubmapGraph>(options.graph) : nullptr),
      graph_(team_graph == nullptr ? owned_graph_.get() : team_graph),
      loop_(options.loop),
      marg_filter_(options.marg),
      ekf_(options.ekf) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid OnlineEstimatorOptions: " << error;
}

OnlineEstimator::~OnlineEstimator() = default;

Status OnlineEstimator::Add(const Measurement& measurement) {
  if (finished_) return Status::Error("OnlineEstimator::Add after Finish()");
  const double stamp = StampOf(measurement);
  if (!std::isfinite(stamp)) {
    return Status::Error(Where(LineOf(measurement)) + MeasurementKindName(measurement) + " stamp is not finite");
  }
  // The EKF runs in the local frame from the first measurement it uses.
  const bool ekf_input = std::holds_alternative<LaserReading>(measurement) ||
                         std::holds_alternative<MargSample>(measurement) ||
                         (options_.use_commands && std::holds_alternative<VelocityCommand>(measurement)) ||
                         std::holds_alternative<AltitudeReading>(measurement);
  if (ekf_input && !ekf_.initialized()) {
    StateEstimate initial;
    initial.stamp_seconds = stamp;
    initial.covariance = EkfMatrix::Identity();
    for (int i : {kX, kY, kZ, kYaw}) initial.covariance(i, i) = 1e-6;
    ekf_.Initialize(initial);
  }
  Status status;
  if (const auto* laser = std::get_if<LaserReading>(&measurement)) {
    status = AddScan(*laser);
  } else if (const auto* marg = std::get_if<MargSample>(&measurement)) {
    status = AddMarg(*marg);
  } else if (const auto* command = std::get_if<VelocityCommand>(&measurement)) {
    if (options_.use_commands) {
      if (!first_motion_stamp_.has_value() || stamp < *first_motion_stamp_) first_motion_stamp_ = stamp;
      if (!last_command_stamp_.has_value() || stamp > *last_command_stamp_) last_command_stamp_ = stamp;
      status = ekf_.AddCommand(*command);
      if (!status.ok()) ++stats_.ekf_errors;
    }
  } else if (const auto* attitude = std::get_if<AttitudeReading>(&measurement)) {
    if (!(std::isfinite(attitude->roll_radians) && std::isfinite(attitude->pitch_radians))) {
      return Status::Error(Where(attitude->line_number) + "attitude is not finite");
    }
    if (!logged_attitudes_.empty() && stamp < logged_attitudes_.back().stamp_seconds) {
      return Status::Error(Where(attitude->line_number) + "attitude stamp " + StampText(stamp) +
                           " is before the previous one");
    }
    logged_attitudes_.push_back(*attitude);
  } else if (const auto* altitude = std::get_if<AltitudeReading>(&measurement)) {
    if (!std::isfinite(altitude->height_meters)) {
      return Status::Error(Where(altitude->line_number) + "altitude is not finite");
    }
    if (!altitudes_.empty() && stamp < altitudes_.back().stamp_seconds) {
      return Status::Error(Where(altitude->line_number) + "altitude stamp " + StampText(stamp) +
                           " is before the previous one");
    }
    altitudes_.push_back(*altitude);
    status = ekf_.AddAltitude({stamp, altitude->height_meters, 1e-4});
    if (!status.ok()) ++stats_.ekf_errors;
  } else if (const auto* odometry = std::get_if<OdometryReading>(&measurement)) {
    if (!options_.use_odometry) return Status::Ok();
    if (!Finite(odometry->pose)) return Status::Error(Where(odometry->line_number) + "odometry pose is not finite");
    if (!odometry_.empty() && stamp < odometry_.back().stamp_seconds) {
      return Status::Error(Where(odometry->line_number) + "odometry stamp " + StampText(stamp) +
                           " is before the previous one");
    }
    odometry_.push_back(*odometry);
  }
  // Camera images: the team merger's (tag sightings); nothing for a single robot's SLAM.
  if (status.ok()) Prune(stamp);
  return status;
}

void OnlineEstimator::Prune(double newest_stamp_seconds) {
  const double keep_after = newest_stamp_seconds - options_.ekf.history_window_seconds - 1.0;
  auto prune = [keep_after](auto* history) {
    // Keep the newest entry before the window too: it is "the latest at or before" for a scan
    // at the window's start.
    while (history->size() > 1 && (*history)[1].stamp_seconds < keep_after) history->pop_front();
  };
  prune(&marg_attitudes_);
  prune(&logged_attitudes_);
  prune(&altitudes_);
  prune(&odometry_);
}

Status OnlineEstimator::AddMarg(const MargSample& sample) {
  ++stats_.marg_samples;
  MargAttitude attitude;
  if (!marg_attitudes_.empty() && !(sample.stamp_seconds > marg_attitudes_.back().stamp_seconds)) {
    ++stats_.marg_errors;
    return Status::Error(Where(sample.line_number) + "MARG sample at " + StampText(sample.stamp_seconds) +
                         " is not after the previous one (refused)");
  }
  const bool finite = std::isfinite(sample.stamp_seconds) && sample.gyro_radps.allFinite() &&
                      sample.accel_mps2.allFinite() && (!sample.has_magnetometer || sample.magnetometer.allFinite());
  if (finite && !marg_attitudes_.empty() &&
      sample.stamp_seconds - marg_attitudes_.back().stamp_seconds > options_.marg.max_sample_gap_seconds) {
    // A gap in the stream (a sensor that stopped and came back): the filter starts afresh
    // from this sample rather than refusing every later one.
    marg_filter_.Reset();
    ++stats_.marg_restarts;
  }
  const Status status = marg_filter_.Add(sample, &attitude);
  if (!status.ok()) {
    ++stats_.marg_errors;
    return Status::Error(Where(sample.line_number) + status.message());
  }
  if (!first_motion_stamp_.has_value() || sample.stamp_seconds < *first_motion_stamp_) {
    first_motion_stamp_ = sample.stamp_seconds;
  }
  marg_attitudes_.push_back(attitude);
  const Status ekf = ekf_.AddMarg(MargMeasurementFromAttitude(attitude, /*use_heading=*/false, 0.0));
  if (!ekf.ok()) {
    ++stats_.ekf_errors;
    return Status::Error(Where(sample.line_number) + ekf.message());
  }
  return Status::Ok();
}

std::optional<BodyAttitude> OnlineEstimator::AttitudeAt(double stamp_seconds) const {
  BodyAttitude attitude;
  switch (options_.attitude_source) {
    case AttitudeSource::kLevel:
      return std::nullopt;
    case AttitudeSource::kMargFilter: {
      const MargAttitude* latest = LatestAtOrBefore(marg_attitudes_, stamp_seconds);
      if (latest == nullptr || stamp_seconds - latest->stamp_seconds > options_.attitude_max_age_seconds) {
        return std::nullopt;
      }
      // Carried to the scan's stamp with the filter's Euler rates (at most one sample period).
      const double dt = stamp_seconds - latest->stamp_seconds;
      attitude.roll_radians = latest->roll_radians + dt * latest->euler_rates_radps.x();
      attitude.pitch_radians = latest->pitch_radians + dt * latest->euler_rates_radps.y();
      break;
    }
    case AttitudeSource::kLogged: {
      const AttitudeReading* latest = LatestAtOrBefore(logged_attitudes_, stamp_seconds);
      if (latest == nullptr || stamp_seconds - latest->stamp_seconds > options_.attitude_max_age_seconds) {
        return std::nullopt;
      }
      attitude.roll_radians = latest->roll_radians;
      attitude.pitch_radians = latest->pitch_radians;
      break;
    }
  }
  attitude.roll_radians += floor_tilt_radians_.x();
  attitude.pitch_radians += floor_tilt_radians_.y();
  const AltitudeReading* altitude = LatestAtOrBefore(altitudes_, stamp_seconds);
  if (altitude != nullptr && stamp_seconds - altitude->stamp_seconds <= options_.altitude_max_age_seconds) {
    attitude.base_height_meters = altitude->height_meters;
  }
  return attitude;
}

Status OnlineEstimator::AddScan(const LaserReading& reading) {
  const double stamp = reading.scan.stamp_seconds;
  ++stats_.scans;
  if (reading.scan.angles_radians.size() != reading.scan.ranges_meters.size()) {
    ++stats_.scans_refused;
    return Status::Error(Where(reading.line_number) + "scan has " + std::to_string(reading.scan.angles_radians.size()) +
                         " angles but " + std::to_string(reading.scan.ranges_meters.size()) + " ranges (refused)");
  }
  // A log's clock glitch (a scan stamped before its predecessor) is processed in arrival order
  // and counted: the file order is the order the scans were taken in.
  if (last_scan_stamp_.has_value() && stamp < *last_scan_stamp_) ++stats_.scans_stamped_backwards;
  // The EKF's estimate at the scan: from the measurements stamped at or before it.
  StateEstimate at_scan;
  const Status ekf_status = ekf_.EstimateAt(stamp, &at_scan);
  if (!ekf_status.ok()) {
    ++stats_.scans_refused;
    return Status::Error(Where(reading.line_number) + "scan at " + StampText(stamp) +
                         " arrived too late for the EKF history: " + ekf_status.message());
  }
  last_scan_stamp_ = last_scan_stamp_.has_value() ? std::max(*last_scan_stamp_, stamp) : stamp;

  const std::optional<BodyAttitude> attitude = AttitudeAt(stamp);
  if (!attitude.has_value() && (!marg_attitudes_.empty() || !logged_attitudes_.empty())) {
    ++stats_.scans_without_attitude;
  }
  const auto prepare_start = std::chrono::steady_clock::now();
  ScanPoints points = PrepareScanPoints(options_.local, reading.scan, attitude);
  stats_.prepare_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - prepare_start).count();
  stats_.floor_points += points.floor_points;
  stats_.projected_scans += points.projected;
  if (points.projected && attitude.has_value()) {
    double lowest = points.floor_points > 0 ? 0.0 : SensorHeight(reading.scan, *attitude);
    for (const float h : points.heights_meters) lowest = std::min(lowest, static_cast<double>(h));
    stats_.lowest_ray_height_meters = std::min(stats_.lowest_ray_height_meters.value_or(lowest), std::max(lowest, 0.0));
  }
  // The floor corrects the tilt of the attitude for the scans after this one.
  Eigen::Vector2d tilt_error;
  if (options_.floor_tilt_gain > 0 && attitude.has_value() && points.floor_line.has_value() &&
      points.floor_line->rms <= options_.floor_tilt_max_rms_meters &&
      FloorTiltError(*points.floor_line, options_.floor_tilt_min_line_distance_meters,
                     SensorHeight(reading.scan, *attitude) / std::tan(options_.floor_tilt_min_depression_radians),
                     &tilt_error) &&
      tilt_error.lpNorm<Eigen::Infinity>() <= options_.floor_tilt_max_error_radians) {
    const double bound = options_.floor_tilt_max_correction_radians;
    floor_tilt_radians_ = (floor_tilt_radians_ + options_.floor_tilt_gain * tilt_error).cwiseMax(-bound).cwiseMin(bound);
    stats_.floor_tilt_radians = floor_tilt_radians_;
    ++stats_.floor_tilt_updates;
  }

  // Prediction: odometry, else the EKF when motion inputs reach the scan, else extrapolation.
  std::optional<Pose2> odometry;
  if (options_.use_odometry) {
    if (reading.has_odometry_pose) {
      odometry = reading.odometry_pose;
    } else if (const OdometryReading* latest = LatestAtOrBefore(odometry_, stamp)) {
      if (stamp - latest->stamp_seconds <= options_.odometry_max_age_seconds) odometry = latest->pose;
    }
  }
  Prediction prediction = local_.Predict(odometry);
  if (!prediction.external && first_motion_stamp_.has_value() && *first_motion_stamp_ <= stamp) {
    prediction.pose = at_scan.pose();
    prediction.external = true;
    prediction.covariance = at_scan.pose_covariance();
    prediction.measures_translation =
        last_command_stamp_.has_value() && *last_command_stamp_ >= stamp - options_.ekf.command_timeout_seconds;
    ++stats_.ekf_predicted_scans;
  }
  const std::vector<StampedPose2>& last = local_.state().recent;
  if (!last.empty() && !((prediction.pose.translation() - last.back().pose.translation()).norm() <=
                         options_.max_scan_jump_meters)) {
    ++stats_.scans_refused;
    return Status::Error(Where(reading.line_number) + "scan at " + StampText(stamp) + " is predicted " +
                         StampText((prediction.pose.translation() - last.back().pose.translation()).norm()) +
                         " m from the last pose, over max_scan_jump_meters (refused)");
  }
  const long long floor_obstacle_points = static_cast<long long>(points.floor_obstacles.size());
  ParticleStep step = local_.AddScan(stamp, std::move(points), prediction, odometry, *graph_, options_.robot);
  const LocalResult& current = step.Current();
  const bool suspended = current.suspended;
  // Matched: a node now, left out by the motion filter, or deferred by the particle filter.
  const bool inserted = current.inserted || current.awaiting_insertion;
  const bool filtered = current.filtered;
  if (inserted || suspended) stats_.floor_obstacle_points += floor_obstacle_points;
  if (inserted || filtered) {
    if (current.matched && !current.match.converged) ++stats_.match_failures;
    if (current.match.converged) {
      match_scores_.push_back(current.match.score);
      // Flat or not, also where no motion source could hold the pose along the flat direction
      // (the degeneracy test alone: `predicted` is not used for it).
      bool flat = current.degenerate;
      if (!flat) DegeneracyAwarePose(options_.local, current.match.pose, current.match, &flat);
      ++(flat ? stats_.flat_matches : stats_.well_constrained_matches);
    }
    stats_.degenerate_matches += current.degenerate;
    stats_.frontier_scans += current.frontier_points > 0;
    stats_.frontier_points += current.frontier_points;
    // The match updates the EKF (the best particle's, while there are several).
    ScanMatchPose update;
    update.stamp_seconds = stamp;
    update.world_T_robot = current.local_pose;
    const double st = options_.scan_match_translation_sigma_meters, sr = options_.scan_match_rotation_sigma_radians;
    update.covariance = Eigen::Vector3d(st * st, st * st, sr * sr).asDiagonal();
    if (current.degenerate) {
      const Eigen::Vector2d& v = current.weak_direction;
      const double free = options_.degenerate_sigma_meters;
      update.covariance.topLeftCorner<2, 2>() += (free * free - st * st) * v * v.transpose();
    }
    if (!ekf_.AddScanMatchPose(update).ok()) ++stats_.ekf_errors;
  } else if (!suspended) {
    ++stats_.skipped_too_few_points;
  }
  stats_.filtered_scans += filtered;
  std::optional<LocalResult> this_scan = std::move(step.current);  // `current` may refer to it: not used below
  for (LocalResult& result : step.committed) AddNode(std::move(result));
  RecordParticleCount(stamp, step.particles);
  if (filtered) {
    // Nothing new for the map: the pose rides on the node before it. (Only with one particle,
    // so that node is this scan's predecessor.)
    const NodeId last{options_.robot, graph_->num_nodes(options_.robot) - 1};
    non_node_poses_.push_back({stamp, last, graph_->NodeLocalPose(last).inverse() * this_scan->local_pose});
  }
  if (suspended) {
    // The EKF carries the pose; floor obstacles seen meanwhile stay in the planner map, tied to
    // the last node so that the graph's corrections move them too.
    ++stats_.suspended_scans;
    const int nodes = graph_->num_nodes(options_.robot);
    if (nodes > 0) {
      const NodeId last{options_.robot, nodes - 1};
      const Pose2 node_T_scan = graph_->NodeLocalPose(last).inverse() * prediction.pose;
      non_node_poses_.push_back({stamp, last, node_T_scan});
      if (this_scan.has_value() && !this_scan->points.floor_obstacles.empty()) {
        suspended_obstacles_.push_back(
            {last, node_T_scan, std::move(this_scan->points.floor_obstacles)});
      }
    }
  }
  return Status::Ok();
}

ScanConfidence OnlineEstimator::Confidence() const {
  ScanConfidence c;
  c.scans = stats_.scans;
  c.well_constrained = stats_.well_constrained_matches;
  c.flat = stats_.flat_matches;
  c.failed = stats_.match_failures;
  c.refused = stats_.scans_refused;
  // The rest: inserted without a match (the first scan), skipped (too few points), suspended.
  c.unmatched = c.scans - c.refused - c.well_constrained - c.flat - c.failed;
  c.well_constrained_fraction = c.scans > 0 ? static_cast<double>(c.well_constrained) / c.scans : 0.0;
  c.low = c.scans == 0 || c.well_constrained_fraction < options_.min_well_constrained_fraction;
  return c;
}

void OnlineEstimator::RecordParticleCount(double stamp_seconds, int particles) {
  if (particle_counts_.empty() || particle_counts_.back().particles != particles) {
    particle_counts_.push_back({stamp_seconds, particles});
  }
}

void OnlineEstimator::AddNode(LocalResult result) {
  // Travel since the previous node (its local pose), for the loop closer's drift bound.
  const int nodes = graph_->num_nodes(options_.robot);
  const double step =
      nodes > 0 ? (result.local_pose.translation() - graph_->NodeLocalPose({options_.robot, nodes - 1}).translation()).norm()
                : 0.0;
  const auto add_start = std::chrono::steady_clock::now();
  const bool finishes_a_submap = result.finished.has_value();
  const int finished_index = finishes_a_submap ? result.finished->index : -1;
  const NodeId node = graph_->AddNode(options_.robot, std::move(result));
  if (finishes_a_submap && finished_index == 0 && options_.rematch_first_node) RematchFirstNode();
  if (finishes_a_submap && options_.loop_closure && options_.retire_revisited_share > 0.0) {
    RetireIfRevisited(finished_index, /*recheck_after_solve=*/true);
  }
  if (finishes_a_submap && options_.max_map_store_bytes > 0) EnforceMapStoreBound();
  stats_.add_node_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - add_start).count();
  if (!options_.loop_closure) return;
  loop_.AddTravel(step);
  const LoopSearchResult found = loop_.Search(*graph_, node);
  for (const ConstraintCandidate& closure : found.closures) {
    if (graph_->AddConstraint(closure)) ++loop_closures_since_solve_;
  }
  if (found.solve_now) Solve(options_.max_iterations_final);
  ++nodes_since_solve_;
  // The solves' spacing grows with the graph (solve_min_new_node_share), so that their total
  // cost grows with the run's length, not with its square.
  const int min_new_nodes = std::max(
      options_.solve_min_new_nodes,
      static_cast<int>(std::ceil(options_.solve_min_new_node_share * graph_->num_nodes(options_.robot))));
  if (loop_closures_since_solve_ >= options_.solve_every_n_loop_closures && nodes_since_solve_ >= min_new_nodes) {
    Solve(options_.max_iterations_per_solve);
  }
}

void OnlineEstimator::RematchFirstNode() {
  const NodeId first{options_.robot, 0};
  const SubmapId submap{options_.robot, 0};
  const LaserMap* map = graph_->FinishedSubmapMap(submap);
  Pose2 inserted;
  if (map == nullptr || !graph_->IntraSubmapPose(first, submap, &inserted)) return;
  const SubmapGraph::MatchingPoints matching = graph_->NodeMatchingPoints(first);
  const ScanMatcher matcher(options_.loop.matcher);
  const std::optional<Pose2> refined =
      matcher.Refine(*map, inserted, matching.points, matching.weights, options_.loop.matcher.max_angular_step_radians * 4);
  if (!refined.has_value()) return;
  // The heading alone: a heading error is what grows with distance (0.5° is 9 cm at 10 m),
  // while a single scan's position in a submap can be flat along a corridor (the refinement
  // then slides along it by centimetres).
  const Pose2 revised(inserted.translation(), refined->theta());
  VLOG(1) << "first node rematched in its finished submap: " << Between(inserted, revised).theta() * 180 / M_PI
          << " deg (the refinement's shift, not taken: " << Between(inserted, *refined).translation().transpose()
          << " m)";
  if (graph_->ReviseFirstNodeInFirstSubmap(options_.robot, revised)) {
    stats_.first_node_rematch_radians = Between(inserted, revised).theta();
  }
}

void OnlineEstimator::EnforceMapStoreBound() {
  const int robot = options_.robot;
  while (graph_->FinishedSubmapBytes(robot) > options_.max_map_store_bytes) {
    std::vector<SubmapId> kept;
    for (int s = 0; s < graph_->num_submaps(robot); ++s) {
      if (graph_->FinishedSubmapMap({robot, s}) != nullptr) kept.push_back({robot, s});
    }
    if (kept.size() < 2) return;  // the newest finished submap always stays
    // The most redundant kept submap but the newest: the largest share of its occupied cells
    // that another kept submap covers (every fourth cell checked: the share is the same to a
    // few percent at a quarter of the cost); ties the older; a submap without structure first.
    int victim = -1;
    double most_covered = -2.0;
    for (size_t k = 0; k + 1 < kept.size(); ++k) {
      double share = graph_->CoveredShare(kept[k], kept, /*sample_every=*/4);
      if (share < 0.0) share = 1.0;
      if (share > most_covered) {
        most_covered = share;
        victim = kept[k].index;
      }
    }
    graph_->EvictSubmapMap({robot, victim});
  }
}

void OnlineEstimator::RetireIfRevisited(int finished, bool recheck_after_solve) {
  const SubmapId submap{options_.robot, finished};
  // What a loop search of its nodes could have found: submaps finished at least
  // min_node_separation nodes before its first node (LoopCloserOptions).
  const int first_node = graph_->SubmapFirstNode(submap);
  std::vector<SubmapId> earlier;
  for (int s = 0; s < finished; ++s) {
    const SubmapId other{options_.robot, s};
    if (graph_->FinishedSubmapMap(other) == nullptr) continue;
    if (graph_->SubmapLastNode(other) + options_.loop.min_node_separation > first_node) continue;
    earlier.push_back(other);
  }
  if (earlier.empty()) return;
  const double share = graph_->CoveredShare(submap, earlier, /*sample_every=*/1);
  VLOG(1) << "submap " << finished << " (nodes " << first_node << "-" << graph_->SubmapLastNode(submap)
          << "): " << share << " of its occupied cells covered by " << earlier.size() << " earlier submaps";
  if (share >= options_.retire_revisited_share) {
    graph_->EvictSubmapMap(submap, SubmapGraph::EvictionReason::kRevisited);
  } else if (recheck_after_solve && share >= 0.0) {
    retire_recheck_.push_back(finished);
  }
}

void OnlineEstimator::Solve(int max_iterations) {
  loop_closures_since_solve_ = 0;
  nodes_since_solve_ = 0;
  // The estimate of new nodes is corrected from here on: drift is counted afresh. (Closures
  // accepted but not yet solved do not correct it, so the gate keeps growing until a solve.)
  loop_.OnSolve();
  // The search tables (the largest buffers besides the maps: FR079 0.8-2.5 MB resident between
  // solves) are not read by a solve. Kept whole over solves they would hold every page any
  // search ever wrote (FR079: 6.9 MB, its peak 29 -> 36 MiB); freed at every solve, the next
  // searches fault their pages in again (Intel: half of its 29 thousand page faults). So
  // they keep their pages up to the largest table the searches since the last solve asked for,
  // unless the process is within that of its memory peak (then the solver's scratch, 0-0.8 MB
  // above the freed tables on FR079, could raise the peak next to them) -- see
  // ScanMatcher::ShrinkScratchForSolve.
  ScanMatcher::ShrinkScratchForSolve(options_.keep_search_tables_over_solves);
  if (!graph_->Solve(max_iterations).ok()) ++stats_.loop_solves_failed;
  // Submaps that finished since the last solve at poses it had not corrected yet: once more.
  std::vector<int> recheck;
  recheck.swap(retire_recheck_);
  for (const int submap : recheck) RetireIfRevisited(submap, /*recheck_after_solve=*/false);
  if (options_.attach_revisits && options_.retire_revisited_share > 0.0) graph_->AttachRevisits(options_.robot);
}

void OnlineEstimator::Finish() {
  if (finished_) return;
  finished_ = true;
  // Particles still alive: the best one's deferred scans become nodes.
  for (LocalResult& result : local_.Collapse()) AddNode(std::move(result));
  if (options_.loop_closure && graph_->num_nodes(options_.robot) > 0) Solve(options_.max_iterations_final);
  for (const ActiveSubmap& submap : local_.state().active) stats_.active_submap_bytes_at_finish += submap.map->MemoryBytes();
  local_.ReleaseActiveSubmaps();
  ScanMatcher::ReleaseScratch();
}

Pose2 OnlineEstimator::CurrentPose() const {
  const int n = graph_->num_nodes(options_.robot);
  if (n == 0) return Pose2::Identity();
  if (ekf_.initialized()) return graph_->LocalToRobot(options_.robot) * ekf_.latest().pose();
  return graph_->NodePose({options_.robot, n - 1});
}

Status OnlineEstimator::PoseAt(double stamp_seconds, Pose2* pose) const {
  const int n = graph_->num_nodes(options_.robot);
  if (n == 0) return Status::Error("PoseAt: no scan inserted yet");
  StateEstimate estimate;
  if (ekf_.initialized() && ekf_.EstimateAt(stamp_seconds, &estimate).ok()) {
    *pose = graph_->LocalToRobot(options_.robot) * estimate.pose();
    return Status::Ok();
  }
  const std::vector<StampedPose2> trajectory = Trajectory();
  auto it = std::lower_bound(trajectory.begin(), trajectory.end(), stamp_seconds,
                             [](const StampedPose2& p, double t) { return p.stamp_seconds < t; });
  if (it == trajectory.begin()) {
    *pose = it->pose;
  } else if (it == trajectory.end()) {
    *pose = trajectory.back().pose;
  } else {
    const StampedPose2& a = *(it - 1);
    const StampedPose2& b = *it;
    const double f = b.stamp_seconds > a.stamp_seconds ? (stamp_seconds - a.stamp_seconds) / (b.stamp_seconds - a.stamp_seconds) : 0.0;
    const Pose2 delta = Between(a.pose, b.pose);
    *pose = a.pose * Pose2(f * delta.translation(), f * delta.theta());
  }
  return Status::Ok();
}

std::vector<StampedPose2> OnlineEstimator::AdvanceTo(double stamp_seconds) {
  std::vector<StampedPose2> poses;
  if (!ekf_.initialized()) return poses;
  const Pose2 robot_T_local = graph_->LocalToRobot(options_.robot);
  for (const StateEstimate& estimate : ekf_.AdvanceTo(stamp_seconds)) {
    poses.push_back({estimate.stamp_seconds, robot_T_local * estimate.pose()});
  }
  return poses;
}

std::vector<StampedPose2> OnlineEstimator::Trajectory() const {
  std::vector<StampedPose2> trajectory = graph_->Trajectory(options_.robot);
  // Scans the particle filter still defers: the best particle's poses.
  for (const StampedPose2& p : local_.DeferredPoses()) {
    trajectory.push_back({p.stamp_seconds, graph_->LocalToRobot(options_.robot) * p.pose});
  }
  if (non_node_poses_.empty()) return trajectory;
  // Scans that are not nodes, relative to the node before them.
  for (const NonNodePose& p : non_node_poses_) {
    trajectory.push_back({p.stamp_seconds, graph_->NodePose(p.node) * p.node_T_scan});
  }
  std::stable_sort(trajectory.begin(), trajectory.end(),
                   [](const StampedPose2& a, const StampedPose2& b) { return a.stamp_seconds < b.stamp_seconds; });
  return trajectory;
}

std::vector<StampedPose2> OnlineEstimator::LocalTrajectory() const {
  std::vector<StampedPose2> trajectory;
  const int n = graph_->num_nodes(options_.robot);
  trajectory.reserve(n);
  for (int i = 0; i < n; ++i) {
    const NodeId id{options_.robot, i};
    trajectory.push_back({graph_->NodeStamp(id), graph_->NodeLocalPose(id)});
  }
  const std::vector<StampedPose2> deferred = local_.DeferredPoses();
  trajectory.insert(trajectory.end(), deferred.begin(), deferred.end());
  if (non_node_poses_.empty()) return trajectory;
  for (const NonNodePose& p : non_node_poses_) {
    trajectory.push_back({p.stamp_seconds, graph_->NodeLocalPose(p.node) * p.node_T_scan});
  }
  std::stable_sort(trajectory.begin(), trajectory.end(),
                   [](const StampedPose2& a, const StampedPose2& b) { return a.stamp_seconds < b.stamp_seconds; });
  return trajectory;
}

std::unique_ptr<OccupancyGrid> OnlineEstimator::RenderMap(SubmapGraph::Layer layer, const Pose2& frame_T_robot) const {
  return graph_->RenderMap(options_.robot, WithFieldMargin(options_.local.grid, options_.local.field), layer,
                           suspended_obstacles_, frame_T_robot);
}

}  // namespace hetslam
