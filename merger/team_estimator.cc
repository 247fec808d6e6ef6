#include "merger/team_estimator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <sstream>

#include "Eigen/Eigenvalues"
#include "frontends/loop_closer.h"
#include "glog/logging.h"
#include "opencv2/imgcodecs.hpp"

namespace hetslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

std::string Text(const Pose2& p) {
  std::ostringstream out;
  out.precision(3);
  out << std::fixed << "(" << p.x() << ", " << p.y() << ", " << p.theta() / kDeg << " deg)";
  return out.str();
}

// Uniform in [0, 1) from 53 random bits: the same numbers on every platform.
double Uniform(std::mt19937_64* rng) { return static_cast<double>((*rng)() >> 11) * 0x1.0p-53; }

// Smaller over larger eigenvalue of a scan match's translational information (J^T J of the scan
// cost with the yaw marginalised out): near 0 when the scan constrains one direction only.
double TranslationalInformationRatio(const Eigen::Matrix3d& information) {
  if (!(information(2, 2) > 0)) return 0.0;
  const Eigen::Matrix2d translational = information.topLeftCorner<2, 2>() -
                                        information.topRightCorner<2, 1>() * information.bottomLeftCorner<1, 2>() /
                                            information(2, 2);
  const Eigen::Vector2d values = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(translational).eigenvalues();
  return values(1) > 0 ? std::max(0.0, values(0)) / values(1) : 0.0;
}

// A record of a constraint between robots a and b measuring a_T_b; `match` (optional) the scan
// match it comes from.
TeamConstraintRecord MakeRecord(double stamp_seconds, int a, int b, TeamConstraintKind kind, int tag_id,
                                const Pose2& a_T_b, const ConstraintCandidate* match) {
  TeamConstraintRecord record;
  record.stamp_seconds = stamp_seconds;
  record.robot_a = a;
  record.robot_b = b;
  record.kind = kind;
  record.tag_id = tag_id;
  record.a_T_b = a_T_b;
  if (match != nullptr) {
    record.submap = match->submap;
    record.node = match->node;
    record.submap_T_node = match->submap_T_node;
    record.score = match->score;
  }
  return record;
}

// The share of `points` (robot frame) that `pose` puts on known cells of `grid`.
double KnownFraction(const OccupancyGrid& grid, const Pose2& pose, const std::vector<Eigen::Vector2f>& points) {
  if (points.empty()) return 0.0;
  int known = 0;
  for (const Eigen::Vector2f& q : points) {
    const CellIndex c = grid.geometry().WorldToCell(pose * q.cast<double>());
    if (grid.geometry().Contains(c) && grid.State(c) != CellState::kUnknown) ++known;
  }
  return static_cast<double>(known) / static_cast<double>(points.size());
}

// An inter-robot scan match as a graph constraint (robust loss).
ConstraintCandidate InterRobotCandidate(const SubmapId& submap, const NodeId& node, const Pose2& submap_T_node,
                                        double score) {
  ConstraintCandidate candidate;
  candidate.submap = submap;
  candidate.node = node;
  candidate.submap_T_node = submap_T_node;
  candidate.score = score;
  candidate.robust = true;
  return candidate;
}

bool Contains(const std::vector<int>& robots, int robot) {
  return std::find(robots.begin(), robots.end(), robot) != robots.end();
}

// Whether robots x and y are on different sides (one in each of `a`, `b`).
bool OnDifferentSides(const std::vector<int>& a, const std::vector<int>& b, int x, int y) {
  return (Contains(a, x) && Contains(b, y)) || (Contains(b, x) && Contains(a, y));
}

bool Within(const Pose2& difference, double meters, double radians) {
  return difference.translation().norm() <= meters && std::abs(difference.theta()) <= radians;
}

}  // namespace

bool MatchSlides(const ScanMatchResult& match, double min_profile_drop_ratio) {
  return min_profile_drop_ratio > 0 && match.strong_direction_score_drop > 0 &&
         match.weak_direction_score_drop < min_profile_drop_ratio * match.strong_direction_score_drop;
}

bool InsideSearchWindow(const Pose2& correction, double linear_window, double angular_window, double cell_meters) {
  const double border = linear_window - std::min(0.5 * linear_window, cell_meters);
  return correction.translation().cwiseAbs().maxCoeff() <= border && std::abs(correction.theta()) <= angular_window;
}

const char* TeamConstraintKindName(TeamConstraintKind kind) {
  switch (kind) {
    case TeamConstraintKind::kTagRelativePose:
      return "tag_eq4";
    case TeamConstraintKind::kTagScanMatch:
      return "tag_scan_match";
    case TeamConstraintKind::kScanMatch:
      return "scan_match";
    case TeamConstraintKind::kMapOverlap:
      return "map_overlap";
  }
  return "unknown";
}

TagDetectorOptions TeamEstimatorOptions::DefaultTeamDetectorOptions() {
  TagDetectorOptions options;
  options.decimate = 1.5;
  options.sigma_pixels = 0.7;
  return options;
}

ScanMatcherOptions TeamEstimatorOptions::DefaultTeamMatcherOptions() {
  ScanMatcherOptions options = LoopCloserOptions::DefaultMatcherOptions();
  // The window is set per search from what is known about the relative pose; no motion prior
  // inside it (the estimate is not a prediction of a moving robot).
  options.translation_penalty_per_square_meter = 0.0;
  options.rotation_penalty_per_square_radian = 0.0;
  return options;
}

ScanMatcherOptions TeamEstimatorOptions::DefaultOverlapMatcherOptions() {
  // The loop closer's wide search: no motion prior, a deeper branch-and-bound tree for windows
  // of several metres and every heading; and the best other mode (half a metre or 10 degrees
  // away), to refuse a scan that fits two places about equally.
  ScanMatcherOptions options = LoopCloserOptions::DefaultWideMatcherOptions();
  options.second_mode_exclusion_meters = 0.5;
  options.second_mode_exclusion_radians = 10.0 * M_PI / 180.0;
  return options;
}

bool TeamEstimatorOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  std::string sub;
  if (!graph.IsValid(&sub)) msg << "graph: " << sub;
  if (!detector.IsValid(&sub)) msg << "detector: " << sub;
  if (!sighting.IsValid(&sub)) msg << "sighting: " << sub;
  if (!places.IsValid(&sub)) msg << "places: " << sub;
  if (!matcher.IsValid(&sub)) msg << "matcher: " << sub;
  for (const auto& [id, size] : tag_sizes_meters) {
    if (!(size > 0)) msg << "tag " << id << " size must be > 0; ";
  }
  if (!std::isfinite(wall_seen_through_meters)) msg << "wall_seen_through_meters must be finite; ";
  if (!(attitude_max_age_seconds >= 0 && min_image_interval_seconds >= 0 && skip_image_within_meters >= 0 &&
        skip_image_within_radians >= 0))
    msg << "attitude age, image interval and skip bounds must be >= 0; ";
  if (!(link_min_score >= 0 && link_min_score < 1 && inter_min_score >= 0 && inter_min_score < 1))
    msg << "link_min_score and inter_min_score must be in [0, 1); ";
  if (link_min_matches < 1 || link_max_nodes_per_robot < 1) msg << "link_min_matches and link_max_nodes_per_robot must be >= 1; ";
  if (!(link_node_radius_meters >= 0 && link_node_spacing_meters >= 0)) msg << "link node radius and spacing must be >= 0; ";
  if (!(link_agreement_meters > 0 && link_agreement_radians > 0 && tag_agreement_meters > 0 && tag_agreement_radians > 0))
    msg << "agreement bounds must be > 0; ";
  if (!(tag_min_separation_meters >= 0 && tag_min_separation_meters <= tag_agreement_meters))
    msg << "tag_min_separation_meters must be in [0, tag_agreement_meters]; ";
  if (!(link_window_min_meters > 0 && link_window_max_meters >= link_window_min_meters && link_window_min_radians > 0 &&
        link_window_max_radians >= link_window_min_radians))
    msg << "link windows must satisfy 0 < min <= max; ";
  if (!(link_retry_seconds >= 0)) msg << "link_retry_seconds must be >= 0; ";
  if (!(inter_search_travel_meters >= 0 && inter_search_turn_radians >= 0 && inter_window_meters > 0 &&
        inter_window_radians > 0 && inter_min_spacing_meters >= 0 && second_constraint_min_distance_meters >= 0 &&
        submap_margin_meters >= 0))
    msg << "inter-robot search windows must be > 0, travel, spacing and distances >= 0; ";
  if (!(min_submap_overlap >= 0 && min_submap_overlap <= 1) || max_submaps_per_match < 1)
    msg << "min_submap_overlap must be in [0, 1], max_submaps_per_match >= 1; ";
  if (min_agreeing_submaps < 1 || min_agreeing_submaps > max_submaps_per_match)
    msg << "min_agreeing_submaps must be in [1, max_submaps_per_match]; ";
  if (!(submap_agreement_meters > 0 && submap_agreement_radians > 0 && min_information_ratio >= 0 &&
        min_information_ratio <= 1 && min_profile_drop_ratio >= 0 && min_profile_drop_ratio <= 1))
    msg << "submap agreement bounds must be > 0, min_information_ratio and min_profile_drop_ratio in [0, 1]; ";
  if (!overlap_matcher.IsValid(&sub)) msg << "overlap_matcher: " << sub;
  if (!(overlap_node_spacing_meters > 0 && overlap_submap_spacing_meters >= 0 && overlap_max_window_meters > 0 &&
        overlap_max_window_meters <= 50 && overlap_agreement_meters > 0 && overlap_agreement_radians > 0 &&
        overlap_retry_seconds >= 0))
    msg << "overlap spacings, windows (<= 50 m), agreement bounds must be > 0, retry >= 0; ";
  if (!(overlap_min_score >= 0 && overlap_min_score < 1 && overlap_max_conflict >= 0 && overlap_max_conflict <= 1))
    msg << "overlap_min_score must be in [0, 1), overlap_max_conflict in [0, 1]; ";
  if (!(overlap_min_mode_margin >= 0)) msg << "overlap_min_mode_margin must be >= 0; ";
  if (std::isnan(overlap_height_margin_meters))
    msg << "overlap_height_margin_meters must be a number (negative: off); ";
  if (!(overlap_confirm_seconds >= 0) || overlap_confirm_new_nodes < 0)
    msg << "overlap_confirm_seconds and overlap_confirm_new_nodes must be >= 0; ";
  if (overlap_min_matches < 2 || overlap_max_matches_per_attempt < 1 || overlap_min_agreeing_cells < 1)
    msg << "overlap_min_matches must be >= 2, overlap_max_matches_per_attempt and overlap_min_agreeing_cells >= 1; ";
  if (max_iterations_per_solve < 1 || max_iterations_final < 1) msg << "solver iteration limits must be >= 1; ";
  if (!(wrong_tag_id_rate >= 0 && wrong_tag_id_rate <= 1)) msg << "wrong_tag_id_rate must be in [0, 1]; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

TeamEstimator::TeamEstimator(const TeamEstimatorOptions& options)
    : options_(options),
      graph_(std::make_unique<SubmapGraph>(options.graph)),
      detector_(options.detector),
      matcher_(options.matcher),
      overlap_matcher_(options.overlap_matcher),
      fault_rng_(options.fault_seed) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid TeamEstimatorOptions: " << error;
  for (const auto& [id, size] : options_.tag_sizes_meters) known_tag_ids_.push_back(id);
}

TeamEstimator::~TeamEstimator() = default;

Status TeamEstimator::AddRobot(const TeamRobotOptions& robot_options, int* index) {
  if (started_) return Status::Error("AddRobot after the first measurement");
  OnlineEstimatorOptions estimator_options = robot_options.estimator;
  estimator_options.robot = num_robots();
  std::string error;
  if (!estimator_options.IsValid(&error)) {
    return Status::Error("robot '" + robot_options.name + "': invalid estimator options: " + error);
  }
  if (robot_options.has_camera) {
    const CameraIntrinsics& k = robot_options.intrinsics;
    if (!(k.fx > 0 && k.fy > 0 && k.width > 0 && k.height > 0)) {
      return Status::Error("robot '" + robot_options.name + "': camera intrinsics need fx, fy, width, height > 0");
    }
  }
  Robot robot;
  robot.name = robot_options.name;
  robot.estimator = std::make_unique<OnlineEstimator>(estimator_options, graph_.get());
  robot.has_camera = robot_options.has_camera;
  robot.intrinsics = robot_options.intrinsics;
  robot.laser_T_camera = robot_options.laser_T_camera;
  robots_.push_back(std::move(robot));
  parent_.push_back(num_robots() - 1);
  *index = num_robots() - 1;
  return Status::Ok();
}

const std::string& TeamEstimator::robot_name(int robot) const { return robots_.at(robot).name; }

const OnlineEstimator& TeamEstimator::estimator(int robot) const { return *robots_.at(robot).estimator; }

Status TeamEstimator::Add(int robot_index, const Measurement& measurement) {
  if (robot_index < 0 || robot_index >= num_robots()) {
    return Status::Error("measurement for unknown robot " + std::to_string(robot_index));
  }
  if (finished_) return Status::Error("TeamEstimator::Add after Finish()");
  started_ = true;
  Robot& robot = robots_[robot_index];
  const double stamp = StampOf(measurement);
  if (const auto* image = std::get_if<CameraImage>(&measurement)) return AddImage(robot_index, *image);
  if (const auto* attitude = std::get_if<AttitudeReading>(&measurement)) {
    robot.attitudes.push_back(*attitude);
    while (robot.attitudes.size() > 2 && robot.attitudes[1].stamp_seconds < stamp - 2.0) robot.attitudes.pop_front();
  }
  const auto* laser = std::get_if<LaserReading>(&measurement);
  if (laser != nullptr) robot.body_T_laser = laser->scan.robot_T_sensor;
  const Status status = robot.estimator->Add(measurement);
  if (laser != nullptr && status.ok()) AfterScan(robot_index, stamp);
  return status;
}

void TeamEstimator::AfterScan(int robot_index, double stamp_seconds) {
  Robot& robot = robots_[robot_index];
  const int nodes = graph_->num_nodes(robot_index);
  if (nodes == robot.nodes_seen) return;
  robot.nodes_seen = nodes;
  if (options_.overlap_search) {
    UpdateOverlapTargets(robot_index);
    CheckGroupTags(stamp_seconds);
    TryOverlapLinks(stamp_seconds);
  }
  // Links waiting for a finished submap.
  for (const auto& [key, state] : link_states_) {
    if (stamp_seconds >= state.next_attempt_stamp && Root(std::get<0>(key)) != Root(std::get<1>(key))) {
      TryLinks(stamp_seconds);
      break;
    }
  }
  if (!options_.search_more_constraints || Group(robot_index).size() < 2) return;
  const NodeId node{robot_index, nodes - 1};
  const Pose2 pose = graph_->NodePose(node);
  if (robot.last_search_pose.has_value()) {
    const Pose2 moved = Between(*robot.last_search_pose, pose);
    if (moved.translation().norm() < options_.inter_search_travel_meters &&
        std::abs(moved.theta()) < options_.inter_search_turn_radians) {
      return;
    }
  }
  robot.last_search_pose = pose;
  SearchInterRobot(stamp_seconds, node);
}

Status TeamEstimator::AddImage(int robot_index, const CameraImage& image) {
  Robot& robot = robots_[robot_index];
  ++stats_.images;
  if (!robot.has_camera || known_tag_ids_.empty()) return Status::Ok();
  if (graph_->num_nodes(robot_index) == 0) return Status::Ok();  // no pose to see from yet
  const double stamp = image.stamp_seconds;
  Pose2 robot_T_body;
  HETSLAM_RETURN_IF_ERROR(robot.estimator->PoseAt(stamp, &robot_T_body));
  if (robot.last_detected_image_stamp.has_value() && !robot.tag_in_view) {
    if (stamp - *robot.last_detected_image_stamp < options_.min_image_interval_seconds) return Status::Ok();
    const Pose2 moved = Between(*robot.last_detected_image_pose, robot_T_body);
    if (moved.translation().norm() < options_.skip_image_within_meters &&
        std::abs(moved.theta()) < options_.skip_image_within_radians) {
      return Status::Ok();
    }
  }
  const auto start = std::chrono::steady_clock::now();
  const cv::Mat gray = cv::imread(image.path, cv::IMREAD_GRAYSCALE);
  if (gray.empty()) {
    return Status::Error((image.line_number > 0 ? "line " + std::to_string(image.line_number) + ": " : std::string()) +
                         "cannot read image '" + image.path + "'");
  }
  // Detected with a unit tag: a pinhole pose's translation scales with the tag's size, its
  // rotation does not, so each tag's own size is applied afterwards.
  std::vector<TagDetection> detections;
  const Status detected = detector_.Detect(gray, robot.intrinsics, 1.0, &detections);
  stats_.detect_seconds += Seconds(start);
  if (!detected.ok()) return Status::Error("image '" + image.path + "': " + detected.message());
  ++stats_.images_detected;
  robot.last_detected_image_stamp = stamp;
  robot.last_detected_image_pose = robot_T_body;
  robot.tag_in_view = std::any_of(detections.begin(), detections.end(), [&](const TagDetection& d) {
    return options_.tag_sizes_meters.count(d.id) > 0;
  });

  double roll = 0.0, pitch = 0.0;
  if (options_.use_attitude) {
    for (auto it = robot.attitudes.rbegin(); it != robot.attitudes.rend(); ++it) {
      if (it->stamp_seconds > stamp) continue;
      if (stamp - it->stamp_seconds <= options_.attitude_max_age_seconds) {
        roll = it->roll_radians;
        pitch = it->pitch_radians;
      }
      break;
    }
  }
  const Eigen::Isometry3d body_T_camera = robot.body_T_laser * robot.laser_T_camera;
  for (TagDetection& detection : detections) {
    auto size = options_.tag_sizes_meters.find(detection.id);
    if (size == options_.tag_sizes_meters.end()) continue;
    ++stats_.detections;
    if (options_.wrong_tag_id_rate > 0 && known_tag_ids_.size() >= 2 &&
        Uniform(&fault_rng_) < options_.wrong_tag_id_rate) {
      // Another known id, uniformly.
      std::vector<int> others;
      for (int id : known_tag_ids_) {
        if (id != detection.id) others.push_back(id);
      }
      const int pick = std::min(static_cast<int>(others.size()) - 1,
                                static_cast<int>(Uniform(&fault_rng_) * static_cast<double>(others.size())));
      detection.id = others[pick];
      ++stats_.detections_relabelled;
    }
    Eigen::Isometry3d camera_T_tag = detection.camera_T_tag;
    camera_T_tag.translation() *= size->second;
    PlanarTagSighting sighting;
    if (!PlanarTagPose(body_T_camera, camera_T_tag, roll, pitch, options_.sighting, &sighting).ok()) {
      ++stats_.sightings_refused;
      continue;
    }
    HETSLAM_RETURN_IF_ERROR(AddTagSighting(robot_index, stamp, detection.id, sighting));
  }
  return Status::Ok();
}

Status TeamEstimator::AddTagSighting(int robot_index, double stamp_seconds, int tag_id,
                                     const PlanarTagSighting& sighting) {
  if (robot_index < 0 || robot_index >= num_robots()) {
    return Status::Error("tag sighting for unknown robot " + std::to_string(robot_index));
  }
  if (finished_) return Status::Error("TeamEstimator::AddTagSighting after Finish()");
  started_ = true;
  Robot& robot = robots_[robot_index];
  const int nodes = graph_->num_nodes(robot_index);
  if (nodes == 0) {
    ++stats_.sightings_refused;
    return Status::Ok();
  }
  Pose2 robot_T_body;
  HETSLAM_RETURN_IF_ERROR(robot.estimator->PoseAt(stamp_seconds, &robot_T_body));
  // Tied to the newest node: the sighting then moves with it when the graph is re-optimised.
  Sighting s;
  s.tag_id = tag_id;
  s.stamp_seconds = stamp_seconds;
  s.node = {robot_index, nodes - 1};
  const Pose2 node_T_body = Between(graph_->NodePose(s.node), robot_T_body);
  s.node_T_tag = node_T_body * sighting.body_T_tag;
  s.covariance = RotateCovariance(node_T_body, sighting.covariance);
  s.range_meters = sighting.range_meters;
  robot.sightings.push_back(s);
  ++stats_.sightings;
  TryLinks(stamp_seconds);
  return Status::Ok();
}

std::vector<TagPlace> TeamEstimator::Places(int robot_index) const {
  std::vector<PlacedTagSighting> placed;
  for (const Sighting& s : robots_[robot_index].sightings) {
    const Pose2 robot_T_node = graph_->NodePose(s.node);
    placed.push_back({s.tag_id, robot_T_node * s.node_T_tag, RotateCovariance(robot_T_node, s.covariance)});
  }
  return GroupTagSightings(placed, options_.places);
}

void TeamEstimator::TryLinks(double stamp_seconds) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::vector<TagPlace>> places(num_robots());
  for (int r = 0; r < num_robots(); ++r) places[r] = Places(r);
  for (int a = 0; a < num_robots(); ++a) {
    for (int b = a + 1; b < num_robots(); ++b) {
      if (Root(a) == Root(b)) continue;
      for (const TagPlace& place_a : places[a]) {
        if (!place_a.confirmed || place_a.ambiguous) continue;
        const TagPlace* place_b = FindTagPlace(places[b], place_a.tag_id);
        if (place_b == nullptr) continue;
        LinkState& state = link_states_[{a, b, place_a.tag_id}];
        if (stamp_seconds < state.next_attempt_stamp) continue;
        state.next_attempt_stamp = stamp_seconds + options_.link_retry_seconds;
        if (TryLink(stamp_seconds, a, b, place_a.tag_id, place_a, *place_b)) break;
      }
    }
  }
  stats_.link_seconds += Seconds(start);
}

bool TeamEstimator::TryLink(double stamp_seconds, int a, int b, int tag_id, const TagPlace& place_a,
                            const TagPlace& place_b) {
  ++stats_.link_attempts;
  LinkState& state = link_states_[{a, b, tag_id}];
  const RelativePoseEstimate tag_estimate =
      RelativePoseFromLandmark(place_a.robot_T_tag, place_a.covariance, place_b.robot_T_tag, place_b.covariance);
  TeamConstraintRecord tag_record = MakeRecord(stamp_seconds, a, b, TeamConstraintKind::kTagRelativePose, tag_id,
                                               tag_estimate.robot1_T_robot2, nullptr);
  auto finish = [&](bool accepted, const std::string& reason, std::vector<TeamConstraintRecord> matches) {
    // Record an attempt only when its outcome differs from the previous attempt's.
    if (!accepted && reason == state.last_outcome) return accepted;
    state.last_outcome = reason;
    tag_record.accepted = accepted;
    tag_record.reason = reason;
    Record(tag_record);
    for (TeamConstraintRecord& m : matches) Record(std::move(m));
    return accepted;
  };

  // Every other tag both robots have placed must tell the same relative pose (compared at the
  // tag, where the two estimates are measured, not at the frames' origins).
  const std::vector<TagPlace> places_a = Places(a), places_b = Places(b);
  for (const TagPlace& other_a : places_a) {
    if (!other_a.confirmed || other_a.ambiguous || other_a.tag_id == tag_id) continue;
    const TagPlace* other_b = FindTagPlace(places_b, other_a.tag_id);
    if (other_b == nullptr) continue;
    const Pose2 other_a_T_b = other_a.robot_T_tag * other_b->robot_T_tag.inverse();
    const Pose2 at_other_tag = Between(tag_estimate.robot1_T_robot2 * other_b->robot_T_tag, other_a.robot_T_tag);
    if (!Within(at_other_tag, options_.tag_agreement_meters, options_.tag_agreement_radians)) {
      std::ostringstream reason;
      reason << "rejected: tag " << other_a.tag_id << " gives " << Text(other_a_T_b) << ", " << at_other_tag.translation().norm()
             << " m / " << std::abs(at_other_tag.theta()) / kDeg << " deg from tag " << tag_id
             << " (a wrong id or a wrong place)";
      return finish(false, reason.str(), {});
    }
  }

  // Scan-match refinement: sighting nodes of each robot against the other's finished submaps,
  // each predicted through the two tag places (the node's own eq. 4 estimate and covariance).
  struct Match {
    ConstraintCandidate candidate;
    Pose2 a_T_b;    // implied relative pose of the frames
    Pose2 a_T_tag;  // where it puts b's tag place in a's frame
  };
  std::vector<Match> matches;
  bool any_submap = false;
  for (const int seer : {b, a}) {
    const int other = seer == b ? a : b;
    const TagPlace& seer_place = seer == b ? place_b : place_a;
    const TagPlace& other_place = seer == b ? place_a : place_b;
    // Its sighting nodes, best seen first, then its other nodes near the tag, nearest first;
    // nodes closer than link_node_spacing_meters to one already chosen are passed over.
    std::vector<std::pair<double, int>> sighting_nodes, near_nodes;  // (range or distance, node index)
    for (int i : seer_place.members) {
      const Sighting& s = robots_[seer].sightings[i];
      if (s.tag_id == tag_id) sighting_nodes.emplace_back(s.range_meters, s.node.index);
    }
    std::sort(sighting_nodes.begin(), sighting_nodes.end());
    for (int i = 0; i < graph_->num_nodes(seer); ++i) {
      const double distance =
          (graph_->NodePose({seer, i}).translation() - seer_place.robot_T_tag.translation()).norm();
      if (distance <= options_.link_node_radius_meters) near_nodes.emplace_back(distance, i);
    }
    std::sort(near_nodes.begin(), near_nodes.end());
    sighting_nodes.insert(sighting_nodes.end(), near_nodes.begin(), near_nodes.end());
    std::vector<int> chosen;
    for (const auto& [unused, index] : sighting_nodes) {
      if (static_cast<int>(chosen.size()) >= options_.link_max_nodes_per_robot) break;
      const Eigen::Vector2d p = graph_->NodePose({seer, index}).translation();
      if (std::any_of(chosen.begin(), chosen.end(), [&](int c) {
            return (graph_->NodePose({seer, c}).translation() - p).norm() < options_.link_node_spacing_meters;
          })) {
        continue;
      }
      chosen.push_back(index);
    }
    for (const int index : chosen) {
      const NodeId node{seer, index};
      const Pose2 seer_T_node = graph_->NodePose(node);
      const Pose2 robot_T_node = seer_T_node;
      const Pose2 node_T_tag = robot_T_node.inverse() * seer_place.robot_T_tag;
      const RelativePoseEstimate predicted =
          RelativePoseFromLandmark(other_place.robot_T_tag, other_place.covariance, node_T_tag,
                                   RotateCovariance(robot_T_node.inverse(), seer_place.covariance));
      const double sigma_xy = std::sqrt(std::max(predicted.covariance(0, 0), predicted.covariance(1, 1)));
      const double linear = std::clamp(3.0 * sigma_xy, options_.link_window_min_meters, options_.link_window_max_meters);
      const double angular = std::clamp(3.0 * std::sqrt(predicted.covariance(2, 2)), options_.link_window_min_radians,
                                        options_.link_window_max_radians);
      bool covered = false;
      const std::optional<ConstraintCandidate> found =
          MatchNodeAgainstRobot(node, other, predicted.robot1_T_robot2, linear, angular, options_.link_min_score, &covered);
      any_submap = any_submap || covered;
      // A match that slides places the node anywhere along its flat direction: it cannot
      // confirm the tag's relative pose there.
      if (!found.has_value() || found->weak_direction.squaredNorm() > 0) continue;
      // other_T_seer implied by the match.
      const Pose2 other_T_seer = graph_->SubmapPose(found->submap) * found->submap_T_node * seer_T_node.inverse();
      Match match;
      match.candidate = *found;
      match.a_T_b = seer == b ? other_T_seer : other_T_seer.inverse();
      match.a_T_tag = match.a_T_b * place_b.robot_T_tag;
      matches.push_back(match);
    }
  }
  std::vector<TeamConstraintRecord> match_records;
  for (const Match& m : matches) {
    match_records.push_back(
        MakeRecord(stamp_seconds, a, b, TeamConstraintKind::kTagScanMatch, tag_id, m.a_T_b, &m.candidate));
  }
  if (matches.empty()) {
    const std::string reason = any_submap ? "rejected: no scan match around the tag estimate scores >= " +
                                                std::to_string(options_.link_min_score)
                                          : "waiting: no finished submap covers the sightings yet";
    return finish(false, reason, {});
  }
  // The largest set of matches that agree with each other (at the tag): the first one found
  // with the most agreeing, ties broken by total score.
  std::vector<int> best_set;
  double best_score = -1.0;
  for (size_t i = 0; i < matches.size(); ++i) {
    std::vector<int> set;
    double score = 0.0;
    for (size_t j = 0; j < matches.size(); ++j) {
      if (Within(Between(matches[i].a_T_tag, matches[j].a_T_tag), options_.link_agreement_meters,
                 options_.link_agreement_radians)) {
        set.push_back(static_cast<int>(j));
        score += matches[j].candidate.score;
      }
    }
    if (set.size() > best_set.size() || (set.size() == best_set.size() && score > best_score)) {
      best_set = set;
      best_score = score;
    }
  }
  if (static_cast<int>(best_set.size()) < options_.link_min_matches) {
    std::ostringstream reason;
    reason << "rejected: " << matches.size() << " scan matches, at most " << best_set.size() << " agreeing (need "
           << options_.link_min_matches << ")";
    for (TeamConstraintRecord& r : match_records) r.reason = "not enough agreeing matches";
    return finish(false, reason.str(), match_records);
  }

  // Accepted. The refined estimate: the best-scoring agreeing match.
  int best = best_set.front();
  for (int i : best_set) {
    if (matches[i].candidate.score > matches[best].candidate.score) best = i;
  }
  std::vector<ConstraintCandidate> agreeing;
  for (int i : best_set) agreeing.push_back(matches[i].candidate);
  std::vector<bool> added;
  const bool linked = JoinGroups(a, b, matches[best].a_T_b, agreeing, &added);
  for (size_t k = 0; k < best_set.size(); ++k) {
    if (!added[k]) continue;
    match_records[best_set[k]].accepted = true;
    match_records[best_set[k]].reason = "first constraint";
  }
  for (TeamConstraintRecord& r : match_records) {
    if (!r.accepted && r.reason.empty()) r.reason = "disagrees with the agreeing matches";
  }
  std::ostringstream reason;
  reason << (linked ? "accepted" : "rejected after the solve (the graph's consistency check removed it)") << ": tag "
         << tag_id << " refined by " << best_set.size() << " of " << matches.size() << " scan matches";
  finish(linked, reason.str(), match_records);
  if (!linked) return false;
  ++stats_.links;
  // The first constraint is where the shared tag is (robot a's frame); the second must be far from it.
  first_link_places_[{a, b}] = {place_a.robot_T_tag.translation()};
  TeamMergeEvent event;
  event.kind = TeamMergeEvent::Kind::kFirstLink;
  event.stamp_seconds = stamp_seconds;
  event.robot_a = a;
  event.robot_b = b;
  std::ostringstream description;
  description << "tag " << tag_id << " (eq. 4 " << Text(tag_estimate.robot1_T_robot2) << ") refined by "
              << best_set.size() << " scan matches";
  event.description = description.str();
  event.after = GroupPairPoses(a);
  events_.push_back(event);
  SearchRetrospectively(stamp_seconds, a);
  return true;
}

bool TeamEstimator::JoinGroups(int a, int b, const Pose2& a_T_b, const std::vector<ConstraintCandidate>& matches,
                               std::vector<bool>* added) {
  // Anchors: the group that does not hold the world's anchor moves onto the other.
  const int world = graph_->world_robot();
  const bool move_b = Root(b) != Root(world);
  const int fixed_robot = move_b ? a : b, moving_robot = move_b ? b : a;
  const Pose2 fixed_T_moving = move_b ? a_T_b : a_T_b.inverse();
  const Pose2 world_T_moving_new = graph_->Anchor(fixed_robot) * fixed_T_moving;
  const Pose2 world_T_moving_old = graph_->Anchor(moving_robot);
  for (int q : Group(moving_robot)) {
    graph_->SetAnchorEstimate(q, world_T_moving_new * Between(world_T_moving_old, graph_->Anchor(q)));
  }
  added->assign(matches.size(), false);
  for (size_t i = 0; i < matches.size(); ++i) {
    const ConstraintCandidate& c = matches[i];
    if (!graph_->AddConstraint(c)) continue;
    inter_constraints_.push_back({c.submap.robot, c.node.robot, c.submap, c.node, true});
    (*added)[i] = true;
    ++stats_.inter_constraints;
  }
  parent_[Root(moving_robot)] = Root(fixed_robot);
  Solve(options_.max_iterations_final);
  return Root(a) == Root(b);
}

void TeamEstimator::SearchRetrospectively(double stamp_seconds, int a) {
  // Every robot of the joined group against its teammates (paper §V-B, "we look
  // retrospectively for a new constraint").
  if (!options_.search_more_constraints) return;
  for (int q : Group(a)) {
    std::optional<Pose2> last;
    for (int i = 0; i < graph_->num_nodes(q); ++i) {
      const NodeId node{q, i};
      const Pose2 pose = graph_->NodePose(node);
      if (last.has_value()) {
        const Pose2 moved = Between(*last, pose);
        if (moved.translation().norm() < options_.inter_search_travel_meters &&
            std::abs(moved.theta()) < options_.inter_search_turn_radians) {
          continue;
        }
      }
      last = pose;
      SearchInterRobot(stamp_seconds, node);
    }
    robots_[q].last_search_pose = last;
  }
}

std::optional<ConstraintCandidate> TeamEstimator::MatchNodeAgainstRobot(const NodeId& node, int submap_robot,
                                                                        const Pose2& submap_robot_T_node,
                                                                        double linear_window, double angular_window,
                                                                        double min_score, bool* covered) {
  const SubmapGraph::MatchingPoints matching = graph_->NodeMatchingPoints(node, options_.refine_on_all_points);
  if (matching.points.empty()) return std::nullopt;
  // Candidate submaps: finished, near (the box of their nodes grown by submap_margin_meters), and
  // seeing most of what the node sees (the share of its points on known cells at the estimate).
  std::vector<std::pair<double, int>> candidates;  // (-overlap, submap index): best first
  for (int s = 0; s < graph_->num_submaps(submap_robot); ++s) {
    const SubmapId submap{submap_robot, s};
    const LaserMap* map = graph_->FinishedSubmapMap(submap);
    if (map == nullptr) continue;
    const Pose2 predicted = graph_->SubmapPose(submap).inverse() * submap_robot_T_node;
    Eigen::Vector2d box_min, box_max;
    graph_->SubmapBox(submap, &box_min, &box_max);
    const Eigen::Vector2d p = predicted.translation();
    const double margin = options_.submap_margin_meters;
    if ((p.array() < box_min.array() - margin).any() || (p.array() > box_max.array() + margin).any()) continue;
    const double overlap = KnownFraction(map->grid(), predicted, matching.points);
    if (overlap >= options_.min_submap_overlap) candidates.emplace_back(-overlap, s);
  }
  std::sort(candidates.begin(), candidates.end());
  if (static_cast<int>(candidates.size()) > options_.max_submaps_per_match) candidates.resize(options_.max_submaps_per_match);
  if (covered != nullptr && !candidates.empty()) *covered = true;
  std::vector<ConstraintCandidate> found;
  std::vector<Pose2> robot_T_matched;  // each match's node pose in the submap robot's frame
  for (const auto& [negative_overlap, s] : candidates) {
    const SubmapId submap{submap_robot, s};
    const Pose2 predicted = graph_->SubmapPose(submap).inverse() * submap_robot_T_node;
    const ScanMatchResult match =
        matcher_.MatchWithinWindow(*graph_->FinishedSubmapMap(submap), predicted, matching.points, linear_window,
                                   angular_window, matching.weights, 0.0, matching.all.empty() ? nullptr : &matching.all);
    const double ratio = TranslationalInformationRatio(match.information);
    VLOG(2) << "match robot " << node.robot << " node " << node.index << " in robot " << submap_robot << " submap " << s
            << " (overlap " << -negative_overlap << "): converged " << match.converged << " score " << match.score
            << " information ratio " << ratio << " correction " << Between(predicted, match.pose);
    if (!match.converged || match.score < min_score) continue;
    // A scan that pins the pose in one direction only (one wall, a corridor) slides along the other.
    if (ratio < options_.min_information_ratio) continue;
    // One that passes that test may still slide (a door, a corridor: J^T J holds mostly the
    // walls' noise); its score profile says so.
    const bool slides = MatchSlides(match, options_.min_profile_drop_ratio);
    // The window's border: the peak may lie outside it (team_three seed 3: rover nodes matched
    // 0.30 m off in a 0.30 m window, against five agreeing constraints, pulled the drone 2 cm).
    if (!InsideSearchWindow(Between(predicted, match.pose), linear_window, angular_window,
                            graph_->FinishedSubmapMap(submap)->field().geometry().resolution_meters())) {
      continue;
    }
    found.push_back(InterRobotCandidate(submap, node, match.pose, match.score));
    if (slides) {
      // Kept, but weighed little along the flat direction (as the loop closer's degenerate
      // closures: SubmapGraph), continuous at the threshold.
      found.back().weak_direction = match.weak_direction;
      found.back().weak_information_fraction = std::max(0.0, match.weak_direction_score_drop) /
                                                (options_.min_profile_drop_ratio * match.strong_direction_score_drop);
    }
    robot_T_matched.push_back(graph_->SubmapPose(submap) * match.pose);
  }
  // A well-constrained scan lands at the same place in every submap of the teammate that sees
  // it; one that slides (a wall, a corridor, a half-seen room) lands wherever each submap's
  // partial view pulls it.
  if (static_cast<int>(found.size()) < options_.min_agreeing_submaps) return std::nullopt;
  for (size_t i = 0; i < found.size(); ++i) {
    for (size_t j = i + 1; j < found.size(); ++j) {
      if (!Within(Between(robot_T_matched[i], robot_T_matched[j]), options_.submap_agreement_meters,
                  options_.submap_agreement_radians)) {
        return std::nullopt;
      }
    }
  }
  return *std::max_element(found.begin(), found.end(), [](const ConstraintCandidate& x, const ConstraintCandidate& y) {
    return x.score < y.score;
  });
}

void TeamEstimator::UpdateOverlapTargets(int robot_index) {
  Robot& robot = robots_[robot_index];
  // Query nodes: one per overlap_node_spacing_meters of travel.
  const NodeId newest{robot_index, graph_->num_nodes(robot_index) - 1};
  const Pose2 pose = graph_->NodePose(newest);
  if ((!robot.last_overlap_pose.has_value() ||
       (pose.translation() - robot.last_overlap_pose->translation()).norm() >= options_.overlap_node_spacing_meters) &&
      !graph_->NodeMatchingPoints(newest).points.empty()) {
    robot.overlap_nodes.push_back(newest.index);
    robot.last_overlap_pose = pose;
  }
  // Target submaps: the finished ones, in order, spread out (consecutive submaps see the same place).
  const auto centre = [&](int index) {
    Eigen::Vector2d lo = Eigen::Vector2d::Zero(), hi = Eigen::Vector2d::Zero();
    graph_->SubmapBox({robot_index, index}, &lo, &hi);  // submap frame
    return Eigen::Vector2d(graph_->SubmapPose({robot_index, index}) * Eigen::Vector2d(0.5 * (lo + hi)));
  };
  while (robot.overlap_submaps_seen < graph_->num_submaps(robot_index)) {
    const int index = robot.overlap_submaps_seen;
    if (!graph_->SubmapFinished({robot_index, index})) break;
    ++robot.overlap_submaps_seen;
    const Eigen::Vector2d c = centre(index);
    if (std::none_of(robot.overlap_submaps.begin(), robot.overlap_submaps.end(),
                     [&](int s) { return (centre(s) - c).norm() < options_.overlap_submap_spacing_meters; })) {
      robot.overlap_submaps.push_back(index);
    }
  }
}

void TeamEstimator::TryOverlapLinks(double stamp_seconds) {
  if (stamp_seconds < next_overlap_attempt_stamp_) return;
  next_overlap_attempt_stamp_ = stamp_seconds + options_.overlap_retry_seconds;
  const auto start = std::chrono::steady_clock::now();
  // New wide matches between every two robots of different groups.
  for (int a = 0; a < num_robots(); ++a) {
    for (int b = a + 1; b < num_robots(); ++b) {
      if (Root(a) != Root(b)) MatchOverlaps(a, b);
    }
  }
  // Then a link between every two groups (by their roots), from all their members' matches.
  for (int a = 0; a < num_robots(); ++a) {
    for (int b = a + 1; b < num_robots(); ++b) {
      if (Root(a) == a && Root(b) == b) TryOverlapLink(stamp_seconds, a, b);
    }
  }
  stats_.overlap_seconds += Seconds(start);
}

void TeamEstimator::MatchOverlaps(int a, int b) {
  OverlapState& state = overlap_states_[{a, b}];
  // (query node, target submap) pairs not matched yet, both ways, within the budget.
  int budget = options_.overlap_max_matches_per_attempt;
  for (const int q : {a, b}) {
    const int p = q == a ? b : a;
    for (const int node_index : robots_[q].overlap_nodes) {
      for (const int submap_index : robots_[p].overlap_submaps) {
        if (budget == 0) return;
        if (!state.tried.insert({q, node_index, p, submap_index}).second) continue;
        --budget;
        ++stats_.overlap_matches;
        const NodeId node{q, node_index};
        const SubmapId submap{p, submap_index};
        const SubmapGraph::MatchingPoints matching = graph_->NodeMatchingPoints(node, options_.refine_on_all_points);
        const LaserMap* evictable = graph_->FinishedSubmapMap(submap);
        if (evictable == nullptr) continue;  // evicted from a bounded map store
        const LaserMap& map = *evictable;
        // The whole submap: its observed box (submap frame), every heading.
        const OccupancyGrid& grid = map.grid();
        const Eigen::Vector2d lo = grid.geometry().CellCenter(grid.observed_min());
        const Eigen::Vector2d hi = grid.geometry().CellCenter(grid.observed_max());
        const double window = std::min(options_.overlap_max_window_meters, 0.5 * (hi - lo).maxCoeff());
        if (!(window > 0)) continue;
        const ScanMatchResult match =
            overlap_matcher_.MatchWithinWindow(map, Pose2(0.5 * (lo + hi), 0.0), matching.points, window, M_PI,
                                               matching.weights, 0.0, matching.all.empty() ? nullptr : &matching.all);
        if (!match.converged || match.score < options_.overlap_min_score) continue;
        // A scan that fits elsewhere in the submap about as well (a symmetric room) says nothing.
        if (match.correlative_score - match.second_mode_correlative_score < options_.overlap_min_mode_margin) continue;
        if (TranslationalInformationRatio(match.information) < options_.min_information_ratio) continue;
        if (KnownFraction(grid, match.pose, matching.points) < options_.min_submap_overlap) continue;
        state.matches.push_back(InterRobotCandidate(submap, node, match.pose, match.score));
        ++stats_.overlap_kept;
        VLOG(1) << "overlap match: " << robots_[q].name << " node " << node_index << " in " << robots_[p].name
                << " submap " << submap_index << " score " << match.score << " margin "
                << match.correlative_score - match.second_mode_correlative_score;
      }
    }
  }
}

Pose2 TeamEstimator::OverlapRelativePose(int a, int b, const ConstraintCandidate& match) const {
  // The submap robot's frame to the node robot's, then between the groups' roots a and b.
  const int p = match.submap.robot, q = match.node.robot;
  const Pose2 p_T_q = graph_->SubmapPose(match.submap) * match.submap_T_node * graph_->NodePose(match.node).inverse();
  return Root(p) == Root(a) ? AnchorRelative(a, p) * p_T_q * AnchorRelative(q, b)
                            : AnchorRelative(a, q) * p_T_q.inverse() * AnchorRelative(p, b);
}

std::unique_ptr<OccupancyGrid> TeamEstimator::RenderGroupMap(int root) const {
  std::unique_ptr<OccupancyGrid> map = robots_[root].estimator->RenderMap();
  for (int r : Group(root)) {
    if (r != root) MergeMapAsOneObservation(*robots_[r].estimator->RenderMap(), AnchorRelative(root, r), MapMergeOptions(), map.get());
  }
  return map;
}

void TeamEstimator::TryOverlapLink(double stamp_seconds, int a, int b) {
  ++stats_.overlap_attempts;
  // Hypotheses a_T_b (a and b the groups' roots) of every kept match between their members,
  // clustered by agreement at the query nodes (each compared where it acts: the node it places).
  std::vector<const ConstraintCandidate*> matches;
  for (const auto& [pair, state] : overlap_states_) {
    const int ra = Root(pair.first), rb = Root(pair.second);
    if (!((ra == a && rb == b) || (ra == b && rb == a))) continue;
    for (const ConstraintCandidate& m : state.matches) matches.push_back(&m);
  }
  const int n = static_cast<int>(matches.size());
  std::vector<Pose2> a_T_b(n), node_in_group(n);
  for (int i = 0; i < n; ++i) {
    a_T_b[i] = OverlapRelativePose(a, b, *matches[i]);
    const NodeId& node = matches[i]->node;
    node_in_group[i] = AnchorRelative(Root(node.robot), node.robot) * graph_->NodePose(node);
  }
  const auto agree = [&](int i, int j) {
    const bool in_b = Root(matches[j]->node.robot) == b;
    const Pose2 x_i = in_b ? a_T_b[i] * node_in_group[j] : a_T_b[i].inverse() * node_in_group[j];
    const Pose2 x_j = in_b ? a_T_b[j] * node_in_group[j] : a_T_b[j].inverse() * node_in_group[j];
    return Within(Between(x_i, x_j), options_.overlap_agreement_meters, options_.overlap_agreement_radians);
  };
  struct Cluster {
    int best = 0;  // its best-scoring member: the hypothesis checked
    std::vector<int> members;
    int nodes = 0;  // distinct query nodes among them
    double score = 0.0;
  };
  std::vector<Cluster> clusters;
  for (int i = 0; i < n; ++i) {
    Cluster cluster;
    cluster.best = i;
    std::set<std::pair<int, int>> nodes;
    for (int j = 0; j < n; ++j) {
      if (!(agree(i, j) && agree(j, i))) continue;
      cluster.members.push_back(j);
      nodes.insert({matches[j]->node.robot, matches[j]->node.index});
      cluster.score += matches[j]->score;
      if (matches[j]->score > matches[cluster.best]->score) cluster.best = j;
    }
    cluster.nodes = static_cast<int>(nodes.size());
    clusters.push_back(std::move(cluster));
  }
  std::stable_sort(clusters.begin(), clusters.end(), [](const Cluster& x, const Cluster& y) {
    return x.nodes != y.nodes ? x.nodes > y.nodes : x.score > y.score;
  });
  // Distinct hypotheses with enough support (one cluster per hypothesis).
  std::vector<Cluster> candidates;
  for (const Cluster& c : clusters) {
    if (c.nodes < options_.overlap_min_matches) break;
    if (std::any_of(candidates.begin(), candidates.end(), [&](const Cluster& k) { return agree(k.best, c.best); })) {
      continue;
    }
    candidates.push_back(c);
  }
  if (candidates.empty()) return;  // waiting: not enough agreeing matches yet

  // Each hypothesis against both groups' whole maps, and against their tags: one id placed by
  // both groups at places apart contradicts it (a building with two congruent rooms). Places of
  // at least two sightings count, confirmed or not: a merge refused is the safe side.
  const std::unique_ptr<OccupancyGrid> map_a = RenderGroupMap(a);
  const std::unique_ptr<OccupancyGrid> map_b = RenderGroupMap(b);
  struct GroupTag {
    int id;
    Pose2 root_T_tag;
    bool confirmed;  // a confirmed, unambiguous place (TagPlace)
  };
  const auto group_tags = [&](int root) {
    std::vector<GroupTag> tags;
    for (int r : Group(root)) {
      for (const TagPlace& place : Places(r)) {
        if (place.votes >= 2) {
          tags.push_back({place.tag_id, AnchorRelative(root, r) * place.robot_T_tag,
                          place.confirmed && !place.ambiguous});
        }
      }
    }
    return tags;
  };
  const std::vector<GroupTag> tags_a = group_tags(a), tags_b = group_tags(b);
  // The groups' lowest rays: where a surface's hits all lie lower, the other group's lasers may
  // have passed over it.
  const auto lowest_ray = [&](int root) -> std::optional<double> {
    std::optional<double> lowest;
    for (int r : Group(root)) {
      const std::optional<double>& ray = robots_[r].estimator->stats().lowest_ray_height_meters;
      if (!ray.has_value()) return std::nullopt;
      lowest = std::min(lowest.value_or(*ray), *ray);
    }
    return lowest;
  };
  MapHeights heights;
  if (options_.overlap_height_margin_meters >= 0) {
    heights.a_lowest_ray_meters = lowest_ray(a);
    heights.b_lowest_ray_meters = lowest_ray(b);
    heights.margin_meters = options_.overlap_height_margin_meters;
  }
  std::vector<int> passing;
  std::vector<std::string> outcomes;
  // Per candidate: a tag id both groups have a confirmed place of, which the pose puts at one
  // place (within tag_agreement_*); -1 when none.
  std::vector<int> corroborating_tag(candidates.size(), -1);
  for (size_t k = 0; k < candidates.size(); ++k) {
    ++stats_.overlap_map_checks;
    const Pose2& hypothesis = a_T_b[candidates[k].best];
    const MapAgreement agreement = CompareMaps(*map_a, *map_b, hypothesis, 1, heights);
    std::ostringstream outcome;
    outcome.precision(3);
    outcome << Text(hypothesis) << " from " << candidates[k].nodes << " query nodes (" << candidates[k].members.size()
            << " matches): " << agreement.agreeing << " map cells agree, " << agreement.conflicting << " conflict ("
            << 100.0 * agreement.ConflictFraction() << "%)";
    if (agreement.passed_over > 0) outcome << ", " << agreement.passed_over << " under the other's lasers";
    bool tags_agree = true;
    for (const GroupTag& tag_a : tags_a) {
      for (const GroupTag& tag_b : tags_b) {
        const Pose2 a_T_tag_b = hypothesis * tag_b.root_T_tag;
        const std::string contradiction = TagsContradict(tag_a.id, tag_a.root_T_tag, tag_b.id, a_T_tag_b);
        if (contradiction.empty()) {
          if (tag_a.id == tag_b.id && tag_a.confirmed && tag_b.confirmed && corroborating_tag[k] < 0 &&
              Within(Between(tag_a.root_T_tag, a_T_tag_b), options_.tag_agreement_meters,
                     options_.tag_agreement_radians)) {
            corroborating_tag[k] = tag_a.id;
          }
          continue;
        }
        if (tags_agree) outcome << "; " << contradiction;
        tags_agree = false;
      }
    }
    if (agreement.agreeing >= options_.overlap_min_agreeing_cells &&
        agreement.ConflictFraction() <= options_.overlap_max_conflict && tags_agree) {
      passing.push_back(static_cast<int>(k));
    }
    outcomes.push_back(outcome.str());
  }
  std::string& last_outcome = overlap_outcomes_[{a, b}];
  const auto record = [&](int k, bool accepted, const std::string& reason) {
    TeamConstraintRecord r = MakeRecord(stamp_seconds, a, b, TeamConstraintKind::kMapOverlap, -1,
                                        a_T_b[candidates[k].best], matches[candidates[k].best]);
    r.accepted = accepted;
    r.reason = reason;
    Record(std::move(r));
  };
  if (passing.size() != 1) {
    // A held pose that no longer passes alone failed its re-confirmation.
    if (overlap_held_.erase({a, b}) > 0) ++stats_.overlap_held_dropped;
    std::ostringstream summary;
    summary << (passing.empty() ? "rejected: " : "ambiguous: ") << passing.size() << " of " << candidates.size()
            << " hypotheses pass the map check (" << options_.overlap_min_agreeing_cells << " agreeing cells, at most "
            << 100.0 * options_.overlap_max_conflict << "% conflicting)";
    if (summary.str() == last_outcome) return;  // recorded already
    last_outcome = summary.str();
    for (size_t k = 0; k < candidates.size(); ++k) record(static_cast<int>(k), false, summary.str() + "; " + outcomes[k]);
    return;
  }
  const Cluster& chosen = candidates[passing.front()];
  std::set<std::pair<int, int>> chosen_nodes;
  for (int j : chosen.members) chosen_nodes.insert({matches[j]->node.robot, matches[j]->node.index});
  std::string confirmation;
  if (corroborating_tag[passing.front()] >= 0) {
    // A tag both groups placed where the pose puts it tells congruent places apart: no hold.
    confirmation = "; corroborated by tag " + std::to_string(corroborating_tag[passing.front()]);
    overlap_held_.erase({a, b});
  } else if (options_.overlap_confirm_seconds > 0 || options_.overlap_confirm_new_nodes > 0) {
    // Held until re-confirmed (see the options): the same pose (compared where it acts, at the
    // chosen match's node), the same groups, later and with new query nodes.
    const std::vector<int> side_a = Group(a), side_b = Group(b);
    const auto held = overlap_held_.find({a, b});
    const int k = chosen.best;
    const bool in_b = Root(matches[k]->node.robot) == b;
    const auto at_node = [&](const Pose2& pose) {
      return in_b ? pose * node_in_group[k] : pose.inverse() * node_in_group[k];
    };
    const bool same = held != overlap_held_.end() && held->second.side_a == side_a && held->second.side_b == side_b &&
                      Within(Between(at_node(held->second.a_T_b), at_node(a_T_b[k])),
                             options_.overlap_agreement_meters, options_.overlap_agreement_radians);
    if (!same) {
      if (held != overlap_held_.end()) ++stats_.overlap_held_dropped;
      overlap_held_[{a, b}] = HeldOverlap{stamp_seconds, side_a, side_b, a_T_b[k], chosen_nodes};
      ++stats_.overlap_held;
      std::ostringstream reason;
      reason << "held: map overlap " << outcomes[passing.front()] << "; to be re-confirmed after "
             << options_.overlap_confirm_seconds << " s by " << options_.overlap_confirm_new_nodes
             << " new query nodes";
      last_outcome = reason.str();
      record(passing.front(), false, reason.str());
      return;
    }
    int new_nodes = 0;
    for (const auto& node : chosen_nodes) new_nodes += held->second.nodes.count(node) == 0 ? 1 : 0;
    const double waited = stamp_seconds - held->second.stamp_seconds;
    if (stamp_seconds < held->second.stamp_seconds + options_.overlap_confirm_seconds ||
        new_nodes < options_.overlap_confirm_new_nodes) {
      return;  // waiting (recorded when it was held)
    }
    std::ostringstream text;
    text.precision(3);
    text << "; re-confirmed after " << waited << " s by " << new_nodes << " new query nodes";
    confirmation = text.str();
    overlap_held_.erase(held);
  }
  std::vector<ConstraintCandidate> agreeing;
  for (int j : chosen.members) agreeing.push_back(*matches[j]);
  std::vector<bool> added;
  OverlapLink link{stamp_seconds, a, b, Group(a), Group(b), false};
  const bool linked = JoinGroups(a, b, a_T_b[chosen.best], agreeing, &added);
  if (linked) overlap_links_.push_back(std::move(link));
  std::ostringstream reason;
  reason << (linked ? "accepted" : "rejected after the solve (the graph's consistency check removed it)")
         << ": map overlap " << outcomes[passing.front()] << confirmation;
  last_outcome = reason.str();
  record(passing.front(), linked, reason.str());
  if (!linked) return;
  ++stats_.links;
  ++stats_.overlap_links;
  // The first constraint is where the agreeing query nodes are (robot a's frame).
  std::vector<Eigen::Vector2d>& places = first_link_places_[{a, b}];
  places.clear();
  for (const ConstraintCandidate& c : agreeing) places.push_back(NodeInRobotFrame(c.node, a).translation());
  TeamMergeEvent event;
  event.kind = TeamMergeEvent::Kind::kFirstLink;
  event.stamp_seconds = stamp_seconds;
  event.robot_a = a;
  event.robot_b = b;
  event.description = "map overlap (no shared tag): " + outcomes[passing.front()] + confirmation;
  event.after = GroupPairPoses(a);
  events_.push_back(event);
  SearchRetrospectively(stamp_seconds, a);
}

std::string TeamEstimator::TagsContradict(int id_x, const Pose2& frame_T_x, int id_y, const Pose2& frame_T_y) const {
  const double apart = (frame_T_x.translation() - frame_T_y.translation()).norm();
  std::ostringstream text;
  text.precision(3);
  if (id_x == id_y && apart > options_.tag_agreement_meters) {
    text << "tag " << id_x << " placed " << apart << " m apart";
  } else if (id_x != id_y && apart < options_.tag_min_separation_meters &&
             std::abs(WrapAngle(frame_T_x.theta() - frame_T_y.theta())) < options_.tag_agreement_radians) {
    text << "tags " << std::min(id_x, id_y) << " and " << std::max(id_x, id_y) << " placed " << apart
         << " m apart, facing the same way";
  }
  return text.str();
}

void TeamEstimator::CheckGroupTags(double stamp_seconds) {
  if (overlap_links_.empty() || stamp_seconds < next_tag_check_stamp_) return;
  next_tag_check_stamp_ = stamp_seconds + options_.link_retry_seconds;
  // Each robot's places of at least two sightings, confirmed or not (as at link time: a
  // withdrawn overlap link is the safe side; with wrong ids injected, the one place that refutes
  // a wrong link may have two votes of three), in its group root's frame.
  struct Placed {
    int robot;
    int tag_id;
    Pose2 root_T_tag;
  };
  std::vector<Placed> placed;
  for (int r = 0; r < num_robots(); ++r) {
    if (Group(r).size() < 2) continue;
    for (const TagPlace& place : Places(r)) {
      if (place.votes >= 2) placed.push_back({r, place.tag_id, AnchorRelative(Root(r), r) * place.robot_T_tag});
    }
  }
  for (size_t i = 0; i < placed.size(); ++i) {
    for (size_t j = i + 1; j < placed.size(); ++j) {
      const Placed& x = placed[i];
      const Placed& y = placed[j];
      if (x.robot == y.robot || Root(x.robot) != Root(y.robot)) continue;
      const std::string contradiction = TagsContradict(x.tag_id, x.root_T_tag, y.tag_id, y.root_T_tag);
      if (contradiction.empty()) continue;
      // The newest map-overlap link with x and y on different sides made the contradiction
      // (a tag link has a tag of its own; two robots of one side were joined before it).
      for (auto link = overlap_links_.rbegin(); link != overlap_links_.rend(); ++link) {
        if (link->withdrawn || !OnDifferentSides(link->side_a, link->side_b, x.robot, y.robot)) continue;
        WithdrawOverlapLink(stamp_seconds, &*link,
                            contradiction + " by " + robots_[x.robot].name + " and " + robots_[y.robot].name);
        return;  // the groups changed: the rest is checked next time
      }
    }
  }
}

void TeamEstimator::WithdrawOverlapLink(double stamp_seconds, OverlapLink* link, const std::string& reason) {
  const Pose2 a_T_b = AnchorRelative(link->a, link->b);
  // Every inter-robot constraint across the link's two sides goes: the link's own and those
  // found through it (in a building of congruent rooms they agree with the wrong link).
  int removed = 0;
  const std::vector<bool> kept = InterConstraintsKept();
  for (size_t i = 0; i < inter_constraints_.size(); ++i) {
    const InterConstraint& c = inter_constraints_[i];
    if (kept[i] && OnDifferentSides(link->side_a, link->side_b, c.robot_a, c.robot_b) &&
        graph_->RemoveInterRobotConstraint(c.submap, c.node)) {
      ++removed;
    }
  }
  link->withdrawn = true;
  ++stats_.overlap_links_withdrawn;
  for (int x : link->side_a) {
    for (int y : link->side_b) {
      const std::pair<int, int> pair{std::min(x, y), std::max(x, y)};
      first_link_places_.erase(pair);
      has_second_constraint_.erase(pair);
    }
  }
  overlap_outcomes_.clear();
  Solve(options_.max_iterations_final);
  TeamConstraintRecord record =
      MakeRecord(stamp_seconds, link->a, link->b, TeamConstraintKind::kMapOverlap, -1, a_T_b, nullptr);
  record.accepted = false;
  std::ostringstream text;
  text << "withdrawn: the map-overlap link of t=" << link->stamp_seconds << " s (" << removed
       << " constraints across it removed): " << reason;
  record.reason = text.str();
  Record(record);
  TeamMergeEvent event;
  event.kind = TeamMergeEvent::Kind::kWithdrawn;
  event.stamp_seconds = stamp_seconds;
  event.robot_a = link->a;
  event.robot_b = link->b;
  event.description = record.reason;
  events_.push_back(event);
  LOG(WARNING) << "team: " << robots_[link->a].name << "-" << robots_[link->b].name << " " << record.reason;
}

void TeamEstimator::SearchInterRobot(double stamp_seconds, const NodeId& node) {
  const auto start = std::chrono::steady_clock::now();
  const int q = node.robot;
  bool added = false;
  for (int a : Group(q)) {
    if (a == q) continue;
    const Pose2 a_T_node = NodeInRobotFrame(node, a);
    // Spread out: not next to an earlier constraint of this pair.
    bool near_existing = false;
    for (const InterConstraint& c : inter_constraints_) {
      if (!((c.robot_a == a && c.robot_b == q) || (c.robot_a == q && c.robot_b == a))) continue;
      if ((NodeInRobotFrame(c.node, a).translation() - a_T_node.translation()).norm() < options_.inter_min_spacing_meters) {
        near_existing = true;
        break;
      }
    }
    VLOG(2) << "inter search robot " << q << " node " << node.index << " in robot " << a << " at " << a_T_node
            << (near_existing ? " (near an existing constraint)" : "");
    if (near_existing) continue;
    ++stats_.inter_searches;
    const std::optional<ConstraintCandidate> found = MatchNodeAgainstRobot(
        node, a, a_T_node, options_.inter_window_meters, options_.inter_window_radians, options_.inter_min_score, nullptr);
    if (!found.has_value()) continue;
    const std::pair<int, int> pair{std::min(a, q), std::max(a, q)};
    const Pose2 a_T_q = graph_->SubmapPose(found->submap) * found->submap_T_node * graph_->NodePose(node).inverse();
    TeamConstraintRecord record = MakeRecord(stamp_seconds, pair.first, pair.second, TeamConstraintKind::kScanMatch,
                                             -1, a == pair.first ? a_T_q : a_T_q.inverse(), &*found);
    if (!graph_->AddConstraint(*found)) continue;
    inter_constraints_.push_back({a, q, found->submap, found->node, false});
    ++stats_.inter_constraints;
    // The pair's second constraint: far from where its first link was made.
    bool second = false;
    if (has_second_constraint_.count(pair) == 0) {
      const auto first = first_link_places_.find(pair);
      double distance = INFINITY;
      if (first != first_link_places_.end()) {
        const Eigen::Vector2d here = NodeInRobotFrame(node, pair.first).translation();
        for (const Eigen::Vector2d& p : first->second) distance = std::min(distance, (p - here).norm());
      }
      second = distance >= options_.second_constraint_min_distance_meters;
    }
    if (second) {
      has_second_constraint_.insert(pair);
      TeamMergeEvent event;
      event.kind = TeamMergeEvent::Kind::kSecondConstraint;
      event.stamp_seconds = stamp_seconds;
      event.robot_a = pair.first;
      event.robot_b = pair.second;
      std::ostringstream description;
      description << "scan match of " << robots_[q].name << " node " << node.index << " in " << robots_[a].name
                  << " submap " << found->submap.index << " (score " << found->score << ")";
      event.description = description.str();
      event.before = GroupPairPoses(q);
      Solve(options_.max_iterations_final);  // batch re-optimisation
      event.after = GroupPairPoses(q);
      events_.push_back(event);
      record.reason = "second constraint";
    } else {
      record.reason = "further constraint";
    }
    record.accepted = true;
    Record(record);
    added = true;
  }
  if (added) Solve(options_.max_iterations_per_solve);
  stats_.inter_search_seconds += Seconds(start);
}

int TeamEstimator::Root(int robot) const {
  if (robot < 0 || robot >= num_robots()) return robot;
  while (parent_[robot] != robot) robot = parent_[robot];
  return robot;
}

std::vector<int> TeamEstimator::Group(int robot) const {
  std::vector<int> group;
  for (int r = 0; r < num_robots(); ++r) {
    if (Root(r) == Root(robot)) group.push_back(r);
  }
  return group;
}

void TeamEstimator::Solve(int max_iterations) {
  // The search tables are not read by a solve: kept as OnlineEstimator::Solve keeps them when
  // every robot's options keep them (the robots' front ends and this share them).
  bool keep_tables = true;
  for (const Robot& robot : robots_) keep_tables = keep_tables && robot.estimator->options().keep_search_tables_over_solves;
  ScanMatcher::ShrinkScratchForSolve(keep_tables);
  graph_->Solve(max_iterations).ok();  // an unusable solution keeps the poses (counted by the graph)
  // Groups follow the inter-robot constraints the graph kept.
  const std::vector<bool> kept = InterConstraintsKept();
  std::iota(parent_.begin(), parent_.end(), 0);
  for (size_t i = 0; i < inter_constraints_.size(); ++i) {
    if (!kept[i]) continue;
    const int ra = Root(inter_constraints_[i].robot_a), rb = Root(inter_constraints_[i].robot_b);
    if (ra != rb) parent_[std::max(ra, rb)] = std::min(ra, rb);
  }
}

std::vector<bool> TeamEstimator::InterConstraintsKept() const {
  std::vector<std::pair<SubmapId, NodeId>> removed;
  for (const LoopClosureReport& report : graph_->LoopClosures()) {
    if (report.kind == EdgeKind::kInterRobot && report.removed) removed.emplace_back(report.submap, report.node);
  }
  std::vector<bool> kept;
  for (const InterConstraint& c : inter_constraints_) {
    kept.push_back(std::none_of(removed.begin(), removed.end(),
                                [&](const auto& r) { return r.first == c.submap && r.second == c.node; }));
  }
  return kept;
}

Pose2 TeamEstimator::AnchorRelative(int a, int b) const { return Between(graph_->Anchor(a), graph_->Anchor(b)); }

Pose2 TeamEstimator::NodeInRobotFrame(const NodeId& node, int frame_robot) const {
  return AnchorRelative(frame_robot, node.robot) * graph_->NodePose(node);
}

std::vector<RobotPairPose> TeamEstimator::GroupPairPoses(int robot) const {
  std::vector<RobotPairPose> poses;
  const std::vector<int> group = Group(robot);
  for (size_t i = 0; i < group.size(); ++i) {
    for (size_t j = i + 1; j < group.size(); ++j) poses.push_back({group[i], group[j], AnchorRelative(group[i], group[j])});
  }
  return poses;
}

void TeamEstimator::Record(TeamConstraintRecord record) { records_.push_back(std::move(record)); }

void TeamEstimator::Finish() {
  if (finished_) return;
  for (Robot& robot : robots_) robot.estimator->Finish();
  Solve(options_.max_iterations_final);
  finished_ = true;
}

bool TeamEstimator::InCommonFrame(int robot) const { return num_robots() > 0 && Root(robot) == Root(0); }

Pose2 TeamEstimator::CommonTRobot(int robot) const {
  return InCommonFrame(robot) ? AnchorRelative(0, robot) : Pose2::Identity();
}

bool TeamEstimator::RelativePose(int robot_i, int robot_j, Pose2* i_T_j) const {
  if (Root(robot_i) != Root(robot_j)) return false;
  *i_T_j = AnchorRelative(robot_i, robot_j);
  return true;
}

std::vector<StampedPose2> TeamEstimator::CommonTrajectory(int robot) const {
  std::vector<StampedPose2> trajectory = robots_.at(robot).estimator->Trajectory();
  const Pose2 common_T_robot = CommonTRobot(robot);
  for (StampedPose2& p : trajectory) p.pose = common_T_robot * p.pose;
  return trajectory;
}

std::unique_ptr<OccupancyGrid> TeamEstimator::RenderRobotMapInCommonFrame(int robot) const {
  return robots_.at(robot).estimator->RenderMap(SubmapGraph::Layer::kStructure, CommonTRobot(robot));
}

std::unique_ptr<OccupancyGrid> TeamEstimator::RenderRobotWallsInCommonFrame(int robot, int* seen_through) const {
  // Rendered where the robot's map goes (the common frame, or its own), its teammates' maps
  // there too: every grid on that frame's cells, the hit points where the scans put them.
  const Pose2 frame_T_robot = CommonTRobot(robot);
  std::unique_ptr<OccupancyGrid> walls = robots_.at(robot).estimator->RenderMap(SubmapGraph::Layer::kWalls, frame_T_robot);
  int dropped = 0;
  if (options_.wall_seen_through_meters >= 0) {
    for (const int teammate : Group(robot)) {
      Pose2 robot_T_teammate;
      if (teammate == robot || !RelativePose(robot, teammate, &robot_T_teammate)) continue;
      const std::unique_ptr<OccupancyGrid> seen =
          robots_[teammate].estimator->RenderMap(SubmapGraph::Layer::kStructure, frame_T_robot * robot_T_teammate);
      dropped += DropWallsSeenThrough(*seen, Pose2::Identity(), options_.wall_seen_through_meters, walls.get());
    }
    if (dropped > 0) {
      walls->DropSmallOccupiedPieces(graph_->options().wall_min_length_meters, SubmapGraph::kWallPieceLinkCells);
    }
  }
  if (seen_through != nullptr) *seen_through = dropped;
  return walls;
}

std::unique_ptr<OccupancyGrid> TeamEstimator::RenderMergedMap(const MapMergeOptions& merge) const {
  std::unique_ptr<OccupancyGrid> merged = robots_.at(0).estimator->RenderMap();
  for (int r = 1; r < num_robots(); ++r) {
    if (!InCommonFrame(r)) continue;
    // Rendered in the common frame, on its cells: merged cell for cell.
    MergeMapAsOneObservation(*robots_[r].estimator->RenderMap(SubmapGraph::Layer::kStructure, CommonTRobot(r)),
                             Pose2::Identity(), merge, merged.get());
  }
  return merged;
}

std::vector<TeamTagPlace> TeamEstimator::TagPlaces() const {
  std::vector<TeamTagPlace> all;
  for (int r = 0; r < num_robots(); ++r) {
    for (TagPlace& place : Places(r)) all.push_back({r, std::move(place)});
  }
  return all;
}


void TeamEstimator::PictureContents(std::vector<MapPictureTrajectory>* trajectories,
                                    std::vector<MapPictureMarker>* markers) const {
  for (int r = 0; r < num_robots(); ++r) {
    if (!InCommonFrame(r)) continue;
    MapPictureTrajectory trajectory;
    trajectory.name = robots_[r].name;
    for (const StampedPose2& p : CommonTrajectory(r)) trajectory.poses.push_back(p.pose);
    trajectories->push_back(std::move(trajectory));
  }
  for (const TeamTagPlace& tag : TagPlaces()) {
    if (!tag.place.confirmed || !InCommonFrame(tag.robot)) continue;
    MapPictureMarker marker;
    marker.kind = MapPictureMarker::Kind::kTag;
    marker.world = (CommonTRobot(tag.robot) * tag.place.robot_T_tag).translation();
    marker.label = "tag " + std::to_string(tag.place.tag_id) + " (" + robots_[tag.robot].name + ")";
    markers->push_back(marker);
  }
  const std::vector<bool> kept = InterConstraintsKept();
  for (size_t i = 0; i < inter_constraints_.size(); ++i) {
    const InterConstraint& c = inter_constraints_[i];
    if (!kept[i] || !InCommonFrame(c.robot_a) || !InCommonFrame(c.robot_b)) continue;
    MapPictureMarker marker;
    marker.kind = MapPictureMarker::Kind::kConstraint;
    marker.world = (CommonTRobot(c.node.robot) * graph_->NodePose(c.node)).translation();
    marker.line_to_world = (CommonTRobot(c.submap.robot) * graph_->SubmapPose(c.submap)).translation();
    if (c.first_link) marker.label = "link";
    markers->push_back(marker);
  }
}

}  // namespace hetslam
