#include "frontends/submap_graph.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <sstream>

#include "Eigen/Geometry"
#include "core/likelihood_field.h"
#include "core/sparse_tiles.h"
#include "factors/sqrt_information.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

// Elimination groups: nodes first, then submaps and anchors (the graph is bipartite like a
// bundle adjustment, so eliminating the many nodes leaves a small sparse system).
constexpr int kNodeGroup = 0;
constexpr int kSubmapGroup = 1;
// Floor-obstacle points this close (cells) to mapped structure are left out of the obstacle layers.
constexpr int kStructureClearanceCells = 2;

// Square-root information of a loop closure submap_T_node (residual in the measured node's
// frame, factors/relative_pose_cost.h): the loop sigmas, and along a weak direction w (submap
// frame, zero: none) sigma_w = sigma / sqrt(fraction), capped:
// S = (I - w w^T) / sigma + w w^T / sigma_w for the translation.
// The covariance of a_T_b = a_T_n * (b_T_n)^-1 from a_T_n and b_T_n with covariances
// `covariance_a` and `covariance_b` (translation in the frame of a, resp. b, then yaw), to first
// order: J_a C_a J_a^T + J_b C_b J_b^T, the yaw errors moving the translation through the
// lever arm of n in b.
Eigen::Matrix3d ChainCovariance(const Pose2& a_T_n, const Eigen::Matrix3d& covariance_a, const Pose2& b_T_n,
                                const Eigen::Matrix3d& covariance_b) {
  const double yaw = a_T_n.theta() - b_T_n.theta();
  const Eigen::Matrix2d rotation = Eigen::Rotation2Dd(yaw).toRotationMatrix();
  const Eigen::Vector2d lever = rotation * Eigen::Vector2d(-b_T_n.y(), b_T_n.x());  // R S t_b
  Eigen::Matrix3d j_a = Eigen::Matrix3d::Identity();
  j_a.block<2, 1>(0, 2) = -lever;
  Eigen::Matrix3d j_b = Eigen::Matrix3d::Zero();
  j_b.block<2, 2>(0, 0) = -rotation;
  j_b.block<2, 1>(0, 2) = lever;
  j_b(2, 2) = -1.0;
  return j_a * covariance_a * j_a.transpose() + j_b * covariance_b * j_b.transpose();
}

// A covariance (or information) of [x, y, yaw] in the frame of a pose's child (a relative-pose
// residual's frame, factors/relative_pose_cost.h) expressed in the parent's: the translation
// block turned by parent_T_child's rotation.
Eigen::Matrix3d InParentFrame(const Pose2& parent_T_child, const Eigen::Matrix3d& covariance_child) {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  rotation.topLeftCorner<2, 2>() = parent_T_child.rotation();
  return rotation * covariance_child * rotation.transpose();
}

Eigen::Matrix3d LoopSqrtInformation(const SubmapGraphOptions& options, const Pose2& submap_T_node,
                                    const Eigen::Vector2d& weak_direction_submap, double weak_information_fraction) {
  const double sigma = options.loop_translation_sigma_meters;
  Eigen::Matrix3d sqrt_information = SqrtInformationFromStddev(sigma, sigma, options.loop_rotation_sigma_radians);
  if (weak_direction_submap.squaredNorm() == 0) return sqrt_information;
  const double weak_sigma =
      weak_information_fraction > 0
          ? std::min(options.loop_weak_translation_sigma_meters, sigma / std::sqrt(weak_information_fraction))
          : options.loop_weak_translation_sigma_meters;
  const Eigen::Vector2d w = (submap_T_node.rotation().transpose() * weak_direction_submap).normalized();
  const Eigen::Matrix2d along = w * w.transpose();
  sqrt_information.topLeftCorner<2, 2>() = (Eigen::Matrix2d::Identity() - along) / sigma + along / std::max(sigma, weak_sigma);
  return sqrt_information;
}

}  // namespace

bool ClosureAgrees(const LoopClosureReport& loop, double meters, double radians) {
  const Pose2 error = Between(loop.measured_submap_T_node, loop.estimated_submap_T_node);
  // The error's frame is the measured node's; along a weak direction the closure measured
  // nothing to disagree with.
  const Eigen::Vector2d weak = loop.measured_submap_T_node.rotation().transpose() * loop.weak_direction;
  const Eigen::Vector2d across = error.translation() - weak.dot(error.translation()) * weak;
  return across.norm() <= meters && std::abs(error.theta()) <= radians;
}

bool SubmapGraphOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  for (double sigma : {intra_translation_sigma_meters, intra_rotation_sigma_radians, loop_translation_sigma_meters,
                       loop_rotation_sigma_radians, loop_loss_scale}) {
    if (!(sigma > 0 && sigma <= 1e3)) {
      msg << "constraint sigmas (intra_*, loop_translation_*, loop_rotation_*) and loop_loss_scale must be in "
             "(0, 1000]; ";
      break;
    }
  }
  if (!(loop_consistency_translation_meters > 0 && loop_consistency_rotation_radians > 0))
    msg << "loop consistency bounds must be > 0; ";
  if (!(loop_weak_translation_sigma_meters > 0 && loop_weak_translation_sigma_meters <= 1e3))
    msg << "loop_weak_translation_sigma_meters must be in (0, 1000]; ";
  if (!(map_min_hit_share >= 0 && map_min_hit_share <= 1)) msg << "map_min_hit_share must be in [0, 1]; ";
  if (!(wall_min_length_meters >= 0 && wall_min_length_meters <= 100))
    msg << "wall_min_length_meters must be in [0, 100]; ";
  if (!(revisit_points_min_travel_meters >= 0 && revisit_points_min_travel_meters <= 1e3 &&
        revisit_points_min_turn_radians >= 0 && revisit_points_min_turn_radians <= 2 * M_PI))
    msg << "revisit_points_min_travel_meters must be in [0, 1000] and revisit_points_min_turn_radians in [0, 2 pi]; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

SubmapGraph::SubmapGraph(const SubmapGraphOptions& options) : options_(options) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid SubmapGraphOptions: " << error;
}

const std::vector<float>& SubmapGraph::NodeScan::NoFloats() {
  static const auto* none = new std::vector<float>();
  return *none;
}

const std::vector<Eigen::Vector2f>& SubmapGraph::NodeScan::NoPoints() {
  static const auto* none = new std::vector<Eigen::Vector2f>();
  return *none;
}

size_t SubmapGraph::NodeScan::ReleasePoints() {
  size_t bytes = packed.capacity() + all.capacity() * sizeof(Eigen::Vector2f) +
                 matching_mask.capacity() * sizeof(uint64_t);
  std::vector<uint8_t>().swap(packed);
  std::vector<Eigen::Vector2f>().swap(all);
  std::vector<uint64_t>().swap(matching_mask);
  num_packed = 0;
  labels_uniform = false;
  if (rare) {
    bytes += rare->labels.capacity() * sizeof(PointLabel) + rare->heights_meters.capacity() * sizeof(float) +
             rare->matching.capacity() * sizeof(Eigen::Vector2f) + rare->matching_weights.capacity() * sizeof(float);
    std::vector<PointLabel>().swap(rare->labels);
    std::vector<float>().swap(rare->heights_meters);
    std::vector<Eigen::Vector2f>().swap(rare->matching);
    std::vector<float>().swap(rare->matching_weights);
    if (rare->empty()) {
      bytes += sizeof(Rare);
      rare.reset();
    }
  }
  return bytes;
}

void SubmapGraph::NodeScan::DecodePoints(std::vector<Eigen::Vector2f>* out) const {
  out->clear();
  if (num_packed == 0) {
    *out = all;
    return;
  }
  out->reserve(num_packed);
  int x = 0, y = 0;
  for (size_t at = 0; out->size() < num_packed;) {
    if (packed[at] == kPackedEscape) {
      x = static_cast<int16_t>(static_cast<uint16_t>(packed[at + 1] | (packed[at + 2] << 8)));
      y = static_cast<int16_t>(static_cast<uint16_t>(packed[at + 3] | (packed[at + 4] << 8)));
      at += 5;
    } else {
      x += static_cast<int8_t>(packed[at]);
      y += static_cast<int8_t>(packed[at + 1]);
      at += 2;
    }
    out->emplace_back(x / kPointsPerMeter, y / kPointsPerMeter);
  }
}

NodeId SubmapGraph::AddNode(int robot_id, LocalResult result) {
  CHECK(result.inserted) << "SubmapGraph::AddNode with a scan that was not inserted";
  if (first_robot_ < 0) first_robot_ = robot_id;
  Robot& robot = robots_[robot_id];
  for (const LocalResult::NewSubmap& s : result.new_submaps) {
    CHECK(robot.submaps.count(s.index) == 0) << "submap " << s.index << " of robot " << robot_id << " added twice";
    Submap submap;
    submap.pose = problem_.AddPose(robot.robot_T_local * s.local_T_submap, kSubmapGroup);
    // Gauge: the robot's first submap fixes its frame.
    if (robot.submaps.empty()) problem_.SetConstant(submap.pose, true);
    robot.submaps[s.index] = submap;
    ++stats_.submaps;
  }
  const NodeId id{robot_id, static_cast<int>(robot.nodes.size())};
  Node node;
  node.stamp_seconds = result.stamp_seconds;
  node.local_pose = result.local_pose;
  node.pose = problem_.AddPose(robot.robot_T_local * result.local_pose, kNodeGroup);
  NodeScan& scan = node.scan;
  // Kept compactly (see NodeScan): what most scans lack in `rare`, the points packed.
  ScanPoints& points = result.points;
  scan.sensor_robot = points.sensor_robot;
  scan.projected = points.projected;
  auto rare = std::make_unique<NodeScan::Rare>();
  if (points.projected) rare->heights_meters = std::move(points.heights_meters);
  rare->floor_obstacles = std::move(points.floor_obstacles);
  rare->matching_weights = std::move(points.matching_weights);
  {
    // The matching points are points of `all` in its order: find each after the previous.
    std::vector<uint64_t> mask((points.all.size() + 63) / 64, 0);
    size_t k = 0, found = 0;
    for (const Eigen::Vector2f& p : points.matching) {
      while (k < points.all.size() && points.all[k] != p) ++k;
      if (k == points.all.size()) break;
      mask[k / 64] |= uint64_t{1} << (k % 64);
      ++k;
      ++found;
    }
    if (found == points.matching.size()) {
      scan.matching_mask = std::move(mask);
    } else {
      rare->matching = std::move(points.matching);
    }
  }
  if (std::all_of(points.labels.begin(), points.labels.end(), [&](PointLabel l) { return l == points.labels[0]; })) {
    scan.labels_uniform = true;  // also without labels: structure
    if (!points.labels.empty()) scan.uniform_label = points.labels[0];
  } else {
    rare->labels = std::move(points.labels);
  }
  // The points to the millimetre (after the matching indices, which compare them exactly).
  constexpr float kMaxMeters = std::numeric_limits<int16_t>::max() / kPointsPerMeter;
  if (!points.all.empty() && std::all_of(points.all.begin(), points.all.end(), [&](const Eigen::Vector2f& p) {
        return std::abs(p.x()) <= kMaxMeters && std::abs(p.y()) <= kMaxMeters;
      })) {
    std::vector<uint8_t>& packed = scan.packed;
    packed.reserve(3 * points.all.size());
    int previous_x = 0, previous_y = 0;
    for (const Eigen::Vector2f& p : points.all) {
      const int x = static_cast<int16_t>(std::lround(p.x() * kPointsPerMeter));
      const int y = static_cast<int16_t>(std::lround(p.y() * kPointsPerMeter));
      const int dx = x - previous_x, dy = y - previous_y;
      if (std::abs(dx) <= 127 && std::abs(dy) <= 127) {
        packed.push_back(static_cast<uint8_t>(static_cast<int8_t>(dx)));
        packed.push_back(static_cast<uint8_t>(static_cast<int8_t>(dy)));
      } else {
        packed.push_back(kPackedEscape);
        for (const int v : {x, y}) {
          const uint16_t bits = static_cast<uint16_t>(static_cast<int16_t>(v));
          packed.push_back(static_cast<uint8_t>(bits & 0xFFu));
          packed.push_back(static_cast<uint8_t>(bits >> 8));
        }
      }
      previous_x = x;
      previous_y = y;
    }
    packed.shrink_to_fit();
    scan.num_packed = static_cast<uint32_t>(points.all.size());
  } else {
    scan.all = std::move(points.all);
    scan.all.shrink_to_fit();
  }
  if (!rare->empty()) {  // without the slack of their growth
    rare->labels.shrink_to_fit();
    rare->heights_meters.shrink_to_fit();
    rare->floor_obstacles.shrink_to_fit();
    rare->matching.shrink_to_fit();
    rare->matching_weights.shrink_to_fit();
    scan.rare = std::move(rare);
  }
  robot.nodes.push_back(std::move(node));
  ++stats_.nodes;

  const Eigen::Matrix3d sqrt_information = SqrtInformationFromStddev(
      options_.intra_translation_sigma_meters, options_.intra_translation_sigma_meters,
      options_.intra_rotation_sigma_radians);
  for (const LocalResult::Insertion& insertion : result.insertions) {
    auto it = robot.submaps.find(insertion.submap);
    CHECK(it != robot.submaps.end()) << "scan inserted into unknown submap " << insertion.submap;
    Submap& submap = it->second;
    Constraint c;
    c.submap = {robot_id, insertion.submap};
    c.node = id;
    c.submap_T_node = insertion.submap_T_node;
    c.kind = EdgeKind::kSequential;
    c.edge = problem_.AddEdge(EdgeKind::kSequential, submap.pose, robot.nodes.back().pose, c.submap_T_node,
                              sqrt_information);
    StoreConstraint(c);
    if (submap.first_node < 0) submap.first_node = id.index;
    submap.last_node = id.index;
    submap.min_submap = submap.min_submap.cwiseMin(insertion.submap_T_node.translation());
    submap.max_submap = submap.max_submap.cwiseMax(insertion.submap_T_node.translation());
  }
  if (result.finished.has_value()) {
    auto it = robot.submaps.find(result.finished->index);
    CHECK(it != robot.submaps.end()) << "unknown finished submap " << result.finished->index;
    it->second.map = result.finished->map;
    it->second.finished = true;
  }
  return id;
}

int SubmapGraph::EnsureAnchor(int robot_id) {
  Robot& robot = robots_.at(robot_id);
  if (robot.anchor < 0) {
    robot.anchor = problem_.AddPose(Pose2::Identity(), kSubmapGroup);
    // Gauge: the first robot's frame is the team's world.
    if (robot_id == first_robot_) problem_.SetConstant(robot.anchor, true);
  }
  return robot.anchor;
}

bool SubmapGraph::AddConstraint(const ConstraintCandidate& candidate) {
  const auto submap_robot = robots_.find(candidate.submap.robot);
  const auto node_robot = robots_.find(candidate.node.robot);
  if (submap_robot == robots_.end() || node_robot == robots_.end()) return false;
  const auto submap = submap_robot->second.submaps.find(candidate.submap.index);
  if (submap == submap_robot->second.submaps.end()) return false;
  if (candidate.node.index < 0 || candidate.node.index >= static_cast<int>(node_robot->second.nodes.size())) {
    return false;
  }
  // An attached node is no longer a variable of the problem.
  if (node_robot->second.nodes[candidate.node.index].host >= 0) return false;
  const Eigen::Matrix3d sqrt_information =
      LoopSqrtInformation(options_, candidate.submap_T_node, candidate.weak_direction,
                          candidate.weak_information_fraction);
  const double loss = candidate.robust ? options_.loop_loss_scale : 0.0;
  const int node_pose = node_robot->second.nodes[candidate.node.index].pose;
  Constraint c;
  c.submap = candidate.submap;
  c.node = candidate.node;
  c.submap_T_node = candidate.submap_T_node;
  c.score = candidate.score;
  c.exempt_from_next_check = candidate.exempt_from_next_check;
  c.weak_direction = candidate.weak_direction;
  c.weak_information_fraction = candidate.weak_information_fraction;
  if (candidate.submap.robot == candidate.node.robot) {
    c.kind = EdgeKind::kLoopClosure;
    c.edge = problem_.AddEdge(EdgeKind::kLoopClosure, submap->second.pose, node_pose, c.submap_T_node,
                              sqrt_information, loss);
    ++stats_.loop_closures_accepted;
  } else {
    c.kind = EdgeKind::kInterRobot;
    const int anchor_a = EnsureAnchor(candidate.submap.robot);
    const int anchor_b = EnsureAnchor(candidate.node.robot);
    c.edge = problem_.AddAnchoredEdge(anchor_a, submap->second.pose, anchor_b, node_pose, c.submap_T_node,
                                      sqrt_information, loss);
    ++stats_.inter_robot_constraints;
  }
  StoreConstraint(c);
  return true;
}

void SubmapGraph::StoreConstraint(const Constraint& c) {
  if (released_constraints_.empty()) {
    constraints_.push_back(c);
    return;
  }
  constraints_[released_constraints_.back()] = c;
  released_constraints_.pop_back();
}

void SubmapGraph::ReleaseConstraint(int index) {
  Constraint& c = constraints_[index];
  if (c.edge < 0) return;
  problem_.ReleaseEdge(c.edge);
  c = Constraint();
  c.edge = -1;
  released_constraints_.push_back(index);
}

int SubmapGraph::IntraSubmapConstraint(const NodeId& node, const SubmapId& submap) const {
  for (size_t k = 0; k < constraints_.size(); ++k) {
    const Constraint& c = constraints_[k];
    if (c.edge >= 0 && c.kind == EdgeKind::kSequential && c.to_submap < 0 && c.submap == submap && c.node == node) {
      return static_cast<int>(k);
    }
  }
  return -1;
}

bool SubmapGraph::IntraSubmapPose(const NodeId& node, const SubmapId& submap, Pose2* submap_T_node) const {
  const int k = IntraSubmapConstraint(node, submap);
  if (k < 0) return false;
  *submap_T_node = constraints_[k].submap_T_node;
  return true;
}

bool SubmapGraph::ReviseFirstNodeInFirstSubmap(int robot_id, const Pose2& submap_T_node) {
  const auto robot_it = robots_.find(robot_id);
  if (robot_it == robots_.end()) return false;
  Robot& robot = robot_it->second;
  if (robot.nodes.empty() || robot.submaps.empty() || robot.anchor >= 0 || robot.nodes.front().host >= 0) return false;
  const int k = IntraSubmapConstraint({robot_id, 0}, {robot_id, robot.submaps.begin()->first});
  if (k < 0) return false;
  Constraint& c = constraints_[k];
  const int node_pose = robot.nodes.front().pose;
  const int submap_pose = robot.submaps.begin()->second.pose;
  // The first submap where the revised constraint puts it with the first node where it is;
  // the rest of the robot follows the submap.
  const Pose2 moved = problem_.pose(node_pose) * submap_T_node.inverse() * problem_.pose(submap_pose).inverse();
  for (const auto& [index, submap] : robot.submaps) problem_.set_pose(submap.pose, moved * problem_.pose(submap.pose));
  for (size_t n = 1; n < robot.nodes.size(); ++n) {
    const Node& node = robot.nodes[n];
    if (node.host < 0) problem_.set_pose(node.pose, moved * problem_.pose(node.pose));
  }
  robot.robot_T_local = moved * robot.robot_T_local;
  const Eigen::Matrix3d sqrt_information = problem_.edge_sqrt_information(c.edge);
  problem_.ReleaseEdge(c.edge);
  c.submap_T_node = submap_T_node;
  c.edge = problem_.AddEdge(EdgeKind::kSequential, submap_pose, node_pose, submap_T_node, sqrt_information);
  return true;
}

bool SubmapGraph::RemoveInterRobotConstraint(const SubmapId& submap, const NodeId& node) {
  for (Constraint& c : constraints_) {
    if (c.edge < 0 || c.kind != EdgeKind::kInterRobot || !(c.submap == submap) || c.node != node ||
        problem_.edge_removed(c.edge)) {
      continue;
    }
    problem_.RemoveEdge(c.edge);
    ++stats_.inter_robot_constraints_withdrawn;
    return true;
  }
  return false;
}

Status SubmapGraph::Solve(int max_iterations) {
  if (robots_.empty()) return Status::Ok();
  PoseGraphSolveOptions solve_options;
  solve_options.max_num_iterations = max_iterations;
  Status status;
  for (int round = 0; round < 2; ++round) {
    PoseGraphSolveSummary summary;
    status = problem_.Solve(solve_options, &summary);
    ++stats_.solves;
    stats_.solver_iterations += summary.num_iterations;
    stats_.solve_seconds += summary.solve_time_seconds;
    if (!status.ok()) {
      ++stats_.failed_solves;
      break;
    }
    // Consistency check: remove closures the optimised graph disagrees with, then solve once more.
    int removed = 0;
    for (Constraint& c : constraints_) {
      if (c.edge < 0 || c.to_submap >= 0 || c.kind == EdgeKind::kSequential || problem_.edge_removed(c.edge) ||
          c.exempt_from_next_check) {
        continue;
      }
      const LoopClosureReport report{c.submap, c.node, c.kind, c.score, c.submap_T_node,
                                     problem_.EdgeEstimate(c.edge), false, c.weak_direction,
                                     c.weak_information_fraction};
      if (!ClosureAgrees(report, options_.loop_consistency_translation_meters,
                         options_.loop_consistency_rotation_radians)) {
        problem_.RemoveEdge(c.edge);
        ++removed;
        ++stats_.loop_closures_rejected_after_solve;
      }
    }
    if (removed == 0) break;
  }
  for (Constraint& c : constraints_) c.exempt_from_next_check = false;
  for (auto& [id, robot] : robots_) {
    if (robot.nodes.empty()) continue;
    const Node& last = robot.nodes.back();
    robot.robot_T_local = NodePoseOf(robot, last) * last.local_pose.inverse();
  }
  return status;
}

int SubmapGraph::num_nodes(int robot) const {
  const auto it = robots_.find(robot);
  return it == robots_.end() ? 0 : static_cast<int>(it->second.nodes.size());
}

int SubmapGraph::num_submaps(int robot) const {
  const auto it = robots_.find(robot);
  return it == robots_.end() ? 0 : static_cast<int>(it->second.submaps.size());
}

Pose2 SubmapGraph::NodePose(const NodeId& node) const {
  const Robot& robot = robots_.at(node.robot);
  return NodePoseOf(robot, robot.nodes.at(node.index));
}

Pose2 SubmapGraph::SubmapPose(const SubmapId& submap) const {
  return problem_.pose(robots_.at(submap.robot).submaps.at(submap.index).pose);
}

Pose2 SubmapGraph::NodePoseOf(const Robot& robot, const Node& node) const {
  if (node.host < 0) return problem_.pose(node.pose);
  return problem_.pose(robot.submaps.at(node.host).pose) * node.host_T_node;
}

bool SubmapGraph::NodeAttached(const NodeId& id) const {
  const auto robot = robots_.find(id.robot);
  if (robot == robots_.end() || id.index < 0 || id.index >= static_cast<int>(robot->second.nodes.size())) return false;
  return robot->second.nodes[id.index].host >= 0;
}

int SubmapGraph::AttachRevisits(int robot_id) {
  const auto robot_it = robots_.find(robot_id);
  if (robot_it == robots_.end()) return 0;
  Robot& robot = robot_it->second;
  // The nodes that may qualify: those of retired submaps not decided yet.
  int lo = std::numeric_limits<int>::max(), hi = -1;
  for (const auto& [index, submap] : robot.submaps) {
    if (!submap.retired || submap.revisit_done) continue;
    lo = std::min(lo, submap.first_node);
    hi = std::max(hi, submap.last_node);
  }
  if (hi < 0) return 0;
  struct Candidate {
    bool all_retired = true;  // every submap it entered was retired
    bool blocked = false;     // an inter-robot constraint holds it: it stays as it is
    int owner = std::numeric_limits<int>::max();  // the oldest submap it entered
    const Constraint* in_owner = nullptr;         // its intra-submap constraints
    const Constraint* in_next = nullptr;          // (to the owner, to the submap after it)
    std::vector<int> constraints;
  };
  std::map<int, Candidate> candidates;
  for (int k = 0; k < static_cast<int>(constraints_.size()); ++k) {
    const Constraint& c = constraints_[k];
    if (c.edge < 0 || c.node.robot != robot_id || c.node.index < lo || c.node.index > hi) continue;
    const Node& node = robot.nodes[c.node.index];
    if (node.host >= 0 || node.revisit_kept) continue;
    Candidate& candidate = candidates[c.node.index];
    candidate.constraints.push_back(k);
    if (c.kind == EdgeKind::kSequential) {
      candidate.owner = std::min(candidate.owner, c.submap.index);
      if (!robot.submaps.at(c.submap.index).retired) candidate.all_retired = false;
    } else if (c.kind == EdgeKind::kInterRobot) {
      candidate.blocked = true;
    }
  }
  // By owner: a retired submap's nodes (each entered it and the next submap) are decided
  // together, once every one of them qualifies (the next submap was retired too).
  std::map<int, std::vector<int>> groups;
  std::set<int> incomplete;
  for (auto& [index, candidate] : candidates) {
    if (candidate.owner == std::numeric_limits<int>::max()) continue;
    if (!candidate.all_retired) {
      incomplete.insert(candidate.owner);
      continue;
    }
    for (const int k : candidate.constraints) {
      const Constraint& c = constraints_[k];
      if (c.kind != EdgeKind::kSequential) continue;
      (c.submap.index == candidate.owner ? candidate.in_owner : candidate.in_next) = &c;
    }
    if (!candidate.blocked) groups[candidate.owner].push_back(index);
  }
  const double st = options_.intra_translation_sigma_meters, sr = options_.intra_rotation_sigma_radians;
  const Eigen::Matrix3d intra_covariance = Eigen::Vector3d(st * st, st * st, sr * sr).asDiagonal();
  // A constraint from submap `from` to submap `to` in place of released ones.
  auto add_between = [&](int from, int to, EdgeKind kind, const Pose2& from_T_to, const Eigen::Matrix3d& information,
                         double loss_scale) {
    Constraint c;
    c.submap = {robot_id, from};
    c.node = {robot_id, -1};
    c.to_submap = to;
    c.submap_T_node = from_T_to;
    c.kind = kind;
    c.edge = problem_.AddEdge(kind, robot.submaps.at(from).pose, robot.submaps.at(to).pose, from_T_to,
                              SqrtInformationFromInformation(information), loss_scale);
    StoreConstraint(c);
    ++stats_.revisit_summaries;
  };
  int attached = 0;
  for (const auto& [owner, members] : groups) {
    if (incomplete.count(owner) > 0) continue;
    Submap& submap = robot.submaps.at(owner);
    // The closures to each submap the group closed with become one constraint from that submap
    // to this one: a closure, carried through its node's measured pose in this submap, measures
    // their relative pose with the two constraints' covariances in series (the node's lever arm
    // included); the summary is the information-weighted mean (each closure weighted as Huber
    // weighted it in the last solve) with the summed information, and a Huber loss at sqrt(n)
    // times the closures' scale (n closures' residuals in one).
    std::map<int, std::vector<const Constraint*>> closures;  // by target submap
    for (const int index : members) {
      for (const int k : candidates.at(index).constraints) {
        const Constraint& c = constraints_[k];
        if (c.kind == EdgeKind::kLoopClosure && !problem_.edge_removed(c.edge)) closures[c.submap.index].push_back(&c);
      }
    }
    int summaries = 0;
    for (const auto& [target, group_closures] : closures) {
      Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
      Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
      double reference_yaw = 0.0;
      int summarised = 0;
      for (const Constraint* c : group_closures) {
        const Constraint* intra = candidates.at(c->node.index).in_owner;
        if (intra == nullptr) continue;
        const Pose2 target_T_owner = c->submap_T_node * intra->submap_T_node.inverse();
        const Eigen::Matrix3d loop_sqrt =
            LoopSqrtInformation(options_, c->submap_T_node, c->weak_direction, c->weak_information_fraction);
        // The closure's and the node's covariances are in the node's frame (their residuals');
        // ChainCovariance takes them in the submaps' and gives target_T_owner's in the target's,
        // the frame the mean below is taken in. A degenerate closure's weak direction would
        // otherwise turn by the node's heading: on wheeled_corridor closures 0.5 m off along the
        // corridor, their nodes driving 49° to it, stretched the corridor by 0.2 m (ATE 0.077 m;
        // 0.018 m without attaching revisits).
        Eigen::Matrix3d closure_information =
            ChainCovariance(c->submap_T_node,
                            InParentFrame(c->submap_T_node, (loop_sqrt.transpose() * loop_sqrt).inverse()),
                            intra->submap_T_node, InParentFrame(intra->submap_T_node, intra_covariance))
                .inverse();
        // Whitened as its residual is: the error in the measured node's frame.
        const Pose2 error_pose = Between(c->submap_T_node, problem_.EdgeEstimate(c->edge));
        const Eigen::Vector3d error(error_pose.x(), error_pose.y(), WrapAngle(error_pose.theta()));
        const double whitened = (loop_sqrt * error).norm();
        if (whitened > options_.loop_loss_scale) closure_information *= options_.loop_loss_scale / whitened;
        if (summarised == 0) reference_yaw = target_T_owner.theta();
        const Eigen::Vector3d z(target_T_owner.x(), target_T_owner.y(),
                                reference_yaw + WrapAngle(target_T_owner.theta() - reference_yaw));
        information += closure_information;
        weighted += closure_information * z;
        ++summarised;
      }
      if (summarised == 0) continue;
      const Eigen::Vector3d mean = information.ldlt().solve(weighted);
      const Pose2 target_T_owner(mean.x(), mean.y(), mean.z());
      // The summary's residual is in this submap's frame (factors/relative_pose_cost.h).
      add_between(target, owner, EdgeKind::kLoopClosure, target_T_owner,
                  InParentFrame(target_T_owner.inverse(), information),
                  options_.loop_loss_scale * std::sqrt(static_cast<double>(summarised)));
      ++summaries;
    }
    // The chain its nodes formed to the next submap (each entered both, at measured poses that
    // give the two submaps one relative pose, the front end's): one constraint with their
    // summed information (each node's two constraints in series, its lever arm included).
    int next = -1, chained = 0;
    Pose2 submap_T_next;
    Eigen::Matrix3d chain_information = Eigen::Matrix3d::Zero();
    for (const int index : members) {
      const Candidate& candidate = candidates.at(index);
      if (candidate.in_owner == nullptr || candidate.in_next == nullptr) continue;
      if (next < 0) {
        next = candidate.in_next->submap.index;
        submap_T_next = candidate.in_owner->submap_T_node * candidate.in_next->submap_T_node.inverse();
      }
      if (candidate.in_next->submap.index != next) continue;
      // In the next submap's frame, the constraint's residual's (see the closures' above).
      chain_information += InParentFrame(submap_T_next.inverse(),
                                         ChainCovariance(candidate.in_owner->submap_T_node, intra_covariance,
                                                         candidate.in_next->submap_T_node, intra_covariance))
                               .inverse();
      ++chained;
    }
    if (chained > 0) add_between(owner, next, EdgeKind::kSequential, submap_T_next, chain_information, 0.0);
    // Nothing else would tie the submap to the graph: one node stays as it is.
    const int kept = summaries == 0 && chained == 0 ? members[members.size() / 2] : -1;
    const Pose2 submap_pose = problem_.pose(submap.pose);
    // The last node of this group that kept its points (see revisit_points_min_travel_meters).
    std::optional<Pose2> last_with_points;
    const bool thin = options_.revisit_points_min_travel_meters > 0 || options_.revisit_points_min_turn_radians > 0;
    for (const int index : members) {
      Node& node = robot.nodes[index];
      if (index == kept) {
        node.revisit_kept = true;
        continue;
      }
      for (const int k : candidates.at(index).constraints) {
        const Constraint& c = constraints_[k];
        if (c.kind == EdgeKind::kLoopClosure && !problem_.edge_removed(c.edge)) ++stats_.closures_released;
        ReleaseConstraint(k);
      }
      node.host = owner;
      node.host_T_node = submap_pose.inverse() * problem_.pose(node.pose);
      problem_.RemovePose(node.pose);
      // Its matching points served loop searches (done); what it saw stays for the rendered
      // maps (a revisit's scans clear the noise the first pass left in free space).
      std::vector<uint64_t>().swap(node.scan.matching_mask);
      if (node.scan.rare) {
        std::vector<Eigen::Vector2f>().swap(node.scan.rare->matching);
        std::vector<float>().swap(node.scan.rare->matching_weights);
        if (node.scan.rare->empty()) node.scan.rare.reset();
      }
      // What it saw stays for the rendered maps once per so much travel in this submap.
      // (A bound of 0 does not count.)
      const double travel = options_.revisit_points_min_travel_meters, turn = options_.revisit_points_min_turn_radians;
      const bool far = !last_with_points.has_value() ||
                       (travel > 0 && (node.host_T_node.translation() - last_with_points->translation()).norm() >= travel) ||
                       (turn > 0 && std::abs(WrapAngle(node.host_T_node.theta() - last_with_points->theta())) >= turn);
      if (!thin || far) {
        last_with_points = node.host_T_node;
      } else {
        stats_.points_released_bytes += node.scan.ReleasePoints();
        ++stats_.nodes_points_released;
      }
      ++attached;
      ++stats_.nodes_attached;
    }
    submap.revisit_done = true;
  }
  return attached;
}

Pose2 SubmapGraph::LocalToRobot(int robot) const {
  const auto it = robots_.find(robot);
  return it == robots_.end() ? Pose2::Identity() : it->second.robot_T_local;
}

Pose2 SubmapGraph::Anchor(int robot) const {
  const auto it = robots_.find(robot);
  return it == robots_.end() || it->second.anchor < 0 ? Pose2::Identity() : problem_.pose(it->second.anchor);
}

bool SubmapGraph::SetAnchorEstimate(int robot_id, const Pose2& world_T_robot) {
  if (robots_.count(robot_id) == 0 || robot_id == first_robot_) return false;
  problem_.set_pose(EnsureAnchor(robot_id), world_T_robot);
  return true;
}

double SubmapGraph::NodeStamp(const NodeId& node) const { return robots_.at(node.robot).nodes.at(node.index).stamp_seconds; }

SubmapGraph::MatchingPoints SubmapGraph::NodeMatchingPoints(const NodeId& id, bool with_all_points) const {
  const Node& node = robots_.at(id.robot).nodes.at(id.index);
  MatchingPoints matching;
  if (node.host >= 0) return matching;  // released (AttachRevisits)
  const NodeScan& scan = node.scan;
  matching.weights = scan.matching_weights();
  if (scan.matching_mask.empty()) {
    matching.points = scan.matching();
  } else {
    size_t count = 0;
    for (const uint64_t word : scan.matching_mask) count += static_cast<size_t>(__builtin_popcountll(word));
    matching.points.reserve(count);
    std::vector<Eigen::Vector2f> all;
    scan.DecodePoints(&all);
    for (size_t k = 0; k < all.size(); ++k) {
      if ((scan.matching_mask[k / 64] >> (k % 64)) & 1u) matching.points.push_back(all[k]);
    }
    if (with_all_points && matching.weights.empty()) matching.all = std::move(all);
  }
  return matching;
}

const Pose2& SubmapGraph::NodeLocalPose(const NodeId& node) const {
  return robots_.at(node.robot).nodes.at(node.index).local_pose;
}

const LaserMap* SubmapGraph::FinishedSubmapMap(const SubmapId& submap) const {
  return robots_.at(submap.robot).submaps.at(submap.index).map.get();
}

bool SubmapGraph::SubmapFinished(const SubmapId& id) const {
  const auto robot = robots_.find(id.robot);
  if (robot == robots_.end()) return false;
  const auto submap = robot->second.submaps.find(id.index);
  return submap != robot->second.submaps.end() && submap->second.finished;
}

bool SubmapGraph::EvictSubmapMap(const SubmapId& id, EvictionReason reason) {
  const auto robot = robots_.find(id.robot);
  if (robot == robots_.end()) return false;
  const auto submap = robot->second.submaps.find(id.index);
  if (submap == robot->second.submaps.end() || submap->second.map == nullptr) return false;
  const size_t bytes = submap->second.map->MemoryBytes();
  if (reason == EvictionReason::kRevisited) {
    submap->second.retired = true;
    ++stats_.submaps_retired;
    stats_.retired_bytes += bytes;
  } else {
    ++stats_.submaps_evicted;
    stats_.evicted_bytes += bytes;
  }
  submap->second.map.reset();
  return true;
}

double SubmapGraph::CoveredShare(const SubmapId& id, const std::vector<SubmapId>& others, int sample_every) const {
  CHECK_GE(sample_every, 1);
  const LaserMap* map = FinishedSubmapMap(id);
  if (map == nullptr) return -1.0;
  const GridGeometry& g = map->field().geometry();
  const Pose2 robot_T_a = SubmapPose(id);
  // A map's grid as a box in the robot frame: only overlapping boxes can cover.
  auto box_of = [this](const LaserMap& m, const SubmapId& s) {
    const GridGeometry& mg = m.field().geometry();
    const Pose2 robot_T_s = SubmapPose(s);
    const Eigen::Vector2d lo = mg.origin();
    const Eigen::Vector2d size(mg.width() * mg.resolution_meters(), mg.height() * mg.resolution_meters());
    Eigen::AlignedBox2d box;
    for (const Eigen::Vector2d& corner : {lo, Eigen::Vector2d(lo + Eigen::Vector2d(size.x(), 0.0)),
                                          Eigen::Vector2d(lo + Eigen::Vector2d(0.0, size.y())), Eigen::Vector2d(lo + size)}) {
      box.extend(robot_T_s * corner);
    }
    return box;
  };
  const Eigen::AlignedBox2d box = box_of(*map, id);
  // The other maps, with the transform carrying the submap's cells into each.
  std::vector<std::pair<const LikelihoodField*, Pose2::PointTransform>> covering;
  for (const SubmapId& other : others) {
    const LaserMap* other_map = FinishedSubmapMap(other);
    if (other_map == nullptr || other == id || !box_of(*other_map, other).intersects(box)) continue;
    covering.push_back({&other_map->field(), Pose2::PointTransform(SubmapPose(other).inverse() * robot_T_a)});
  }
  constexpr float kCovered = 0.36787944f;  // exp(-1): within one sigma of a hit
  const SparseTiles<uint8_t>& tiles = map->field().frozen_tiles();
  constexpr int kTile = SparseTiles<uint8_t>::kTileSize;
  int occupied = 0, covered = 0, seen = 0;
  // Occupied cells lie in the tiles holding field values (the field is 1 on a hit).
  for (int ty = 0; ty < tiles.tiles_y(); ++ty) {
    for (int tx = 0; tx < tiles.tiles_x(); ++tx) {
      if (!tiles.TileStored(tx, ty)) continue;
      for (int y = ty * kTile; y < std::min(g.height(), (ty + 1) * kTile); ++y) {
        for (int x = tx * kTile; x < std::min(g.width(), (tx + 1) * kTile); ++x) {
          if (map->grid().State(CellIndex{x, y}) != CellState::kOccupied || seen++ % sample_every != 0) continue;
          ++occupied;
          const Eigen::Vector2d centre = g.CellCenter({x, y});
          for (const auto& [other, b_T_a] : covering) {
            if (other->Value(other->geometry().WorldToCell(b_T_a(centre))) >= kCovered) {
              ++covered;
              break;
            }
          }
        }
      }
    }
  }
  return occupied > 0 ? static_cast<double>(covered) / occupied : -1.0;
}

size_t SubmapGraph::FinishedSubmapBytes(int robot) const {
  const auto it = robots_.find(robot);
  if (it == robots_.end()) return 0;
  size_t bytes = 0;
  for (const auto& [index, submap] : it->second.submaps) {
    if (submap.map != nullptr) bytes += submap.map->MemoryBytes();
  }
  return bytes;
}

bool SubmapGraph::SubmapBox(const SubmapId& id, Eigen::Vector2d* min, Eigen::Vector2d* max) const {
  const auto robot = robots_.find(id.robot);
  if (robot == robots_.end()) return false;
  const auto submap = robot->second.submaps.find(id.index);
  if (submap == robot->second.submaps.end()) return false;
  *min = submap->second.min_submap;
  *max = submap->second.max_submap;
  return true;
}

int SubmapGraph::SubmapFirstNode(const SubmapId& submap) const {
  return robots_.at(submap.robot).submaps.at(submap.index).first_node;
}

int SubmapGraph::SubmapLastNode(const SubmapId& submap) const {
  return robots_.at(submap.robot).submaps.at(submap.index).last_node;
}

std::vector<StampedPose2> SubmapGraph::Trajectory(int robot_id) const {
  std::vector<StampedPose2> trajectory;
  const auto it = robots_.find(robot_id);
  if (it == robots_.end()) return trajectory;
  trajectory.reserve(it->second.nodes.size());
  for (const Node& node : it->second.nodes) trajectory.push_back({node.stamp_seconds, NodePoseOf(it->second, node)});
  return trajectory;
}

std::unique_ptr<OccupancyGrid> SubmapGraph::RenderMap(int robot_id, const OccupancyGridOptions& grid_options,
                                                     Layer layer, const std::vector<AnchoredPoints>& extra,
                                                     const Pose2& frame_T_robot) const {
  auto grid = std::make_unique<OccupancyGrid>(grid_options);
  const auto it = robots_.find(robot_id);
  if (it == robots_.end()) return grid;
  std::vector<Eigen::Vector2f> points_robot;  // a node's points, decoded
  if (layer == Layer::kWalls) {
    // The structure with its label layer first; then only the points on its wall cells.
    const std::unique_ptr<OccupancyGrid> all = RenderMap(robot_id, grid_options, Layer::kStructure, {}, frame_T_robot);
    std::vector<Eigen::Vector2d> walls;
    for (const Node& node : it->second.nodes) {
      const NodeScan& scan = node.scan;
      const Pose2 world_T_node = frame_T_robot * NodePoseOf(it->second, node);
      walls.clear();
      scan.DecodePoints(&points_robot);
      const Pose2::PointTransform to_world(world_T_node);
      for (const Eigen::Vector2f& p : points_robot) {
        const Eigen::Vector2d world = to_world(p.cast<double>());
        const int cell = all->geometry().LinearIndex(all->geometry().WorldToCell(world));
        if (all->IsOccupied(cell) && (all->LabelMask(cell) & (1u << OccupancyGrid::kWallLabelBit))) walls.push_back(world);
      }
      if (!walls.empty()) grid->InsertScan(world_T_node * scan.sensor_robot, walls, nullptr);
    }
    grid->DropSmallOccupiedPieces(options_.wall_min_length_meters, kWallPieceLinkCells);
    return grid;
  }
  std::vector<Eigen::Vector2d> points_world;
  std::vector<uint8_t> labels;
  if (layer == Layer::kStructure) {
    // The grid is sized once to the box of every point and sensor: grown scan by scan it would
    // copy itself at every growth (old and new arrays alive together: the process's peak when
    // rendering at the end) and keep the growth slack of the last one.
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d hi = -lo;
    for (const Node& node : it->second.nodes) {
      const NodeScan& scan = node.scan;
      if (scan.num_points() == 0) continue;
      const Pose2 world_T_node = frame_T_robot * NodePoseOf(it->second, node);
      const Eigen::Vector2d sensor = world_T_node * scan.sensor_robot;
      lo = lo.cwiseMin(sensor);
      hi = hi.cwiseMax(sensor);
      scan.DecodePoints(&points_robot);
      const Pose2::PointTransform to_world(world_T_node);
      for (const Eigen::Vector2f& p : points_robot) {
        const Eigen::Vector2d world = to_world(p.cast<double>());
        lo = lo.cwiseMin(world);
        hi = hi.cwiseMax(world);
      }
    }
    // A box the grid cannot hold (a corrupt pose far away) is left to InsertScan, which
    // refuses the offending scans one by one.
    if (lo.x() <= hi.x() && grid->CanContain(lo, hi)) grid->EnsureContains(lo, hi);
    for (const Node& node : it->second.nodes) {
      const NodeScan& scan = node.scan;
      if (scan.num_points() == 0) continue;
      const Pose2 world_T_node = frame_T_robot * NodePoseOf(it->second, node);
      points_world.clear();
      labels.clear();
      scan.DecodePoints(&points_robot);
      const Pose2::PointTransform to_world(world_T_node);
      for (size_t k = 0; k < points_robot.size(); ++k) {
        points_world.push_back(to_world(points_robot[k].cast<double>()));
        labels.push_back(static_cast<uint8_t>(scan.Label(k)));
      }
      grid->InsertScan(world_T_node * scan.sensor_robot, points_world, nullptr, &labels,
                       scan.projected ? &scan.heights_meters() : nullptr);
    }
    grid->DropWeakOccupiedCells(options_.map_min_hit_share);
    return grid;
  }
  // Floor obstacles, over the structure for a planner. A floor-obstacle point within a cell of
  // occupied structure is the bottom of a wall or of furniture seen by a beam tilted down (the
  // map knows better than the one scan): it is left out.
  std::unique_ptr<OccupancyGrid> structure = RenderMap(robot_id, grid_options, Layer::kStructure, {}, frame_T_robot);
  const GridGeometry& g = structure->geometry();
  auto near_structure = [&](const Eigen::Vector2d& world) {
    const CellIndex c = g.WorldToCell(world);
    for (int dy = -kStructureClearanceCells; dy <= kStructureClearanceCells; ++dy) {
      for (int dx = -kStructureClearanceCells; dx <= kStructureClearanceCells; ++dx) {
        const CellIndex n{c.x + dx, c.y + dy};
        if (g.Contains(n) && structure->IsOccupied(g.LinearIndex(n))) return true;
      }
    }
    return false;
  };
  // Hits only, no rays: a beam that ends on a floor obstacle came down from the laser and
  // passed over the cells before it higher than that obstacle's top, so it says nothing of a
  // low obstacle there (paper §III-E: a floor obstacle breaks the 2.5D assumption). Rays cast
  // as for the structure cleared the front face of a box whose top later beams hit
  // (humanoid_explore), and in the planner layer they wore down the structure they crossed. A
  // cell any scan's floor-obstacle point falls in is occupied, in the planner layer too (the
  // structure saw it free: its beams passed above).
  std::vector<Eigen::Vector2d> obstacles;
  auto add = [&](const Pose2& world_T_scan, const std::vector<Eigen::Vector2f>& points) {
    const Pose2::PointTransform to_world(world_T_scan);
    for (const Eigen::Vector2f& p : points) {
      const Eigen::Vector2d world = to_world(p.cast<double>());
      if (world.allFinite() && !near_structure(world)) obstacles.push_back(world);
    }
  };
  for (const Node& node : it->second.nodes) add(frame_T_robot * NodePoseOf(it->second, node), node.scan.floor_obstacles());
  for (const AnchoredPoints& points : extra) {
    if (points.node.robot != robot_id || points.node.index >= static_cast<int>(it->second.nodes.size())) continue;
    add(frame_T_robot * NodePose(points.node) * points.node_T_scan, points.floor_obstacles);
  }
  if (layer == Layer::kPlanner) grid = std::make_unique<OccupancyGrid>(*structure);  // checks stay on the structure
  if (obstacles.empty()) return grid;
  Eigen::Vector2d lo = obstacles.front(), hi = obstacles.front();
  for (const Eigen::Vector2d& p : obstacles) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // Grown once; a point the grid cannot hold (a corrupt pose far away) is left out.
  if (grid->CanContain(lo, hi)) grid->EnsureContains(lo, hi);
  const float occupied = static_cast<float>(grid_options.max_log_odds - grid_options.min_log_odds);
  for (const Eigen::Vector2d& p : obstacles) {
    if (grid->CanContain(p, p)) grid->AddCellObservation(p, occupied);
  }
  return grid;
}

PoseGraph2d SubmapGraph::ExportGraph(int robot_id) const {
  PoseGraph2d graph;
  const auto it = robots_.find(robot_id);
  if (it == robots_.end()) return graph;
  const Robot& robot = it->second;
  std::map<int, int> submap_vertex;
  for (const auto& [index, submap] : robot.submaps) {
    submap_vertex[index] = static_cast<int>(graph.vertices.size());
    graph.vertices.push_back({submap_vertex[index], problem_.pose(submap.pose)});
  }
  const int first_node_vertex = static_cast<int>(graph.vertices.size());
  for (int i = 0; i < static_cast<int>(robot.nodes.size()); ++i) {
    graph.vertices.push_back({first_node_vertex + i, NodePoseOf(robot, robot.nodes[i])});
  }
  for (const Constraint& c : constraints_) {
    if (c.edge < 0 || problem_.edge_removed(c.edge) || c.kind == EdgeKind::kInterRobot || c.node.robot != robot_id) {
      continue;
    }
    PoseGraph2dEdge edge;
    edge.id_from = submap_vertex.at(c.submap.index);
    edge.id_to = c.to_submap >= 0 ? submap_vertex.at(c.to_submap) : first_node_vertex + c.node.index;
    edge.from_T_to_measured = c.submap_T_node;
    edge.kind = c.kind;
    // The information the solve uses (AttachRevisits' summaries carry several constraints' worth).
    const Eigen::Matrix3d sqrt_information = problem_.edge_sqrt_information(c.edge);
    edge.information = sqrt_information.transpose() * sqrt_information;
    graph.edges.push_back(edge);
  }
  if (!robot.submaps.empty()) graph.fixed_vertex_ids.push_back(0);
  return graph;
}

std::vector<LoopClosureReport> SubmapGraph::LoopClosures() const {
  std::vector<LoopClosureReport> reports;
  for (const Constraint& c : constraints_) {
    if (c.edge < 0 || c.to_submap >= 0 || c.kind == EdgeKind::kSequential) continue;
    reports.push_back({c.submap, c.node, c.kind, c.score, c.submap_T_node, problem_.EdgeEstimate(c.edge),
                       problem_.edge_removed(c.edge), c.weak_direction,
                       c.weak_information_fraction});
  }
  return reports;
}

}  // namespace hetslam
