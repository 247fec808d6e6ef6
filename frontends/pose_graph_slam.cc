#include "frontends/pose_graph_slam.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "ceres/ceres.h"
#include "factors/relative_pose_cost.h"
#include "factors/se2_manifold.h"
#include "factors/sqrt_information.h"
#include "glog/logging.h"

namespace hetslam {

struct PoseGraphSlam::Node {
  double stamp_seconds = 0.0;
  Pose2 local_pose;                  // front end frame
  double* world_pose = nullptr;      // optimised block [x, y, yaw], in block_pool_
  std::vector<Eigen::Vector2f> points;           // robot frame, all valid points (rendering)
  std::vector<Eigen::Vector2f> matching_points;  // robot frame, voxel-thinned (loop closure)
  Eigen::Vector2d sensor_robot = Eigen::Vector2d::Zero();
};

struct PoseGraphSlam::Submap {
  Pose2 local_T_submap;               // front end frame
  double* world_pose = nullptr;       // optimised block world_T_submap, in block_pool_
  std::unique_ptr<LaserMap> map;      // in the submap frame
  int num_scans = 0;
  int last_node = 0;                  // index of the last node inserted
  bool finished = false;
  Eigen::Vector2d min_submap, max_submap;  // box of node positions, submap frame
};

struct PoseGraphSlam::Constraint {
  int submap = 0;
  int node = 0;
  Pose2 submap_T_node;
  bool loop = false;
  double score = 0.0;
  bool removed = false;
  // Confirmed wide closures are exempt from the consistency check of the solve that brings
  // them in: alone against the whole chain they leave a few degrees of residual; the
  // ordinary closures that the corrected estimate then finds decide at the next solve.
  bool exempt_from_next_check = false;
  ceres::ResidualBlockId residual = nullptr;
};

namespace {

Pose2 ToPose(const double* block) { return Pose2(block[0], block[1], block[2]); }

// Pose blocks live in chunks of this many; see AllocatePoseBlock.
constexpr size_t kPoseBlocksPerChunk = size_t{1} << 20;

}  // namespace

ScanMatcherOptions PoseGraphSlamOptions::DefaultLoopMatcherOptions() {
  ScanMatcherOptions options;
  options.linear_search_window_meters = 2.0;              // paper §III-A: 2 m radius
  options.angular_search_window_radians = 45.0 * M_PI / 180.0;  // paper §III-A: ±45°
  options.min_correlative_score = 0.5;
  options.branch_and_bound_depth = 5;
  // The window is the whole loop-closure search: no wider retry.
  options.fallback_linear_search_window_meters = 0.0;
  options.fallback_angular_search_window_radians = 0.0;
  return options;
}

ScanMatcherOptions PoseGraphSlamOptions::DefaultLoopWideMatcherOptions() {
  ScanMatcherOptions options = DefaultLoopMatcherOptions();
  // No motion prior: the point of the wide search is a pose far from the estimate.
  options.translation_penalty_per_square_meter = 0.0;
  options.rotation_penalty_per_square_radian = 0.0;
  options.branch_and_bound_depth = 6;
  return options;
}

bool PoseGraphSlamOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  std::string sub;
  if (!local.IsValid(&sub)) msg << "local: " << sub;
  if (!loop_matcher.IsValid(&sub)) msg << "loop_matcher: " << sub;
  if (!loop_wide_matcher.IsValid(&sub)) msg << "loop_wide_matcher: " << sub;
  if (!(loop_wide_window_meters > 0 && loop_wide_angular_window_radians > 0 && loop_wide_search_spacing_meters >= 0 &&
        loop_wide_agreement_meters > 0 && loop_wide_agreement_radians > 0))
    msg << "wide search windows and agreement bounds must be > 0, its spacing >= 0; ";
  if (!(loop_wide_min_score >= 0 && loop_wide_min_score < 1)) msg << "loop_wide_min_score must be in [0, 1); ";
  if (scans_per_submap < 2) msg << "scans_per_submap must be >= 2 (got " << scans_per_submap << "); ";
  if (!(loop_min_score >= 0 && loop_min_score < 1)) msg << "loop_min_score must be in [0, 1); ";
  if (!(loop_search_min_travel_meters >= 0 && loop_search_min_turn_radians >= 0))
    msg << "loop search travel/turn thresholds must be >= 0; ";
  for (double sigma : {intra_translation_sigma_meters, intra_rotation_sigma_radians, loop_translation_sigma_meters,
                       loop_rotation_sigma_radians, loop_loss_scale}) {
    if (!(sigma > 0)) msg << "constraint sigmas and loop_loss_scale must be > 0; ";
  }
  if (!(loop_gate_base_meters >= 0 && loop_gate_meters_per_meter >= 0 && loop_gate_base_radians >= 0 &&
        loop_gate_radians_per_meter >= 0))
    msg << "loop gate parameters must be >= 0; ";
  if (!(loop_consistency_translation_meters > 0 && loop_consistency_rotation_radians > 0))
    msg << "loop consistency bounds must be > 0; ";
  if (solve_every_n_loop_closures < 1) msg << "solve_every_n_loop_closures must be >= 1; ";
  if (solve_min_new_nodes < 0) msg << "solve_min_new_nodes must be >= 0; ";
  if (max_iterations_per_solve < 1 || max_iterations_final < 1) msg << "solver iteration limits must be >= 1; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

PoseGraphSlam::PoseGraphSlam(const PoseGraphSlamOptions& options)
    : options_(options),
      local_matcher_(options.local.matcher),
      loop_matcher_(options.loop_matcher),
      loop_wide_matcher_(options.loop_wide_matcher),
      manifold_(CreateSe2Manifold()) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid PoseGraphSlamOptions: " << error;
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(problem_options);
}

PoseGraphSlam::~PoseGraphSlam() = default;

void PoseGraphSlam::AddScan(const LaserScan& scan, const std::optional<Pose2>& odometry_pose,
                            const std::optional<BodyAttitude>& attitude) {
  CHECK(!finished_) << "AddScan after Finish";
  ++stats_.scans;
  if (!local_trajectory_.empty() && scan.stamp_seconds < local_trajectory_.back().stamp_seconds) {
    ++stats_.timestamps_backwards;
  }
  const ScanPoints points = PrepareScanPoints(options_.local, scan, attitude);
  stats_.floor_points += points.floor_points;
  if (static_cast<int>(points.all.size()) < options_.local.min_points) {
    ++stats_.skipped_too_few_points;
    return;
  }
  // Front end: match against the oldest active submap, in its frame.
  Pose2 local_pose = PredictNextPose(options_.local, local_trajectory_, last_odometry_, odometry_pose);
  if (!active_submaps_.empty() && submaps_[active_submaps_.front()].num_scans > 0) {
    const Submap& target = submaps_[active_submaps_.front()];
    const Pose2 predicted_submap = target.local_T_submap.inverse() * local_pose;
    const ScanMatchResult match = local_matcher_.Match(*target.map, predicted_submap, points.matching, {},
                                                       NarrowSearchTrusted(options_.local, local_trajectory_));
    if (match.converged) {
      bool degenerate = false;
      local_pose = target.local_T_submap * DegeneracyAwarePose(options_.local, predicted_submap, match, &degenerate);
      stats_.degenerate_matches += degenerate;
    } else {
      ++stats_.match_failures;
    }
  }
  if (odometry_pose.has_value()) last_odometry_ = odometry_pose;
  if (!local_trajectory_.empty()) {
    const double step = (local_pose.translation() - local_trajectory_.back().pose.translation()).norm();
    travel_since_solve_meters_ += step;
    travel_since_wide_search_meters_ += step;
  }
  local_trajectory_.push_back({scan.stamp_seconds, local_pose});

  // Submap bookkeeping: start a new submap every scans_per_submap / 2 scans.
  const int half = std::max(1, options_.scans_per_submap / 2);
  if (active_submaps_.empty() || submaps_[active_submaps_.back()].num_scans >= half) {
    Submap submap;
    submap.local_T_submap = local_pose;
    submap.world_pose = AllocatePoseBlock(world_T_local_ * local_pose);
    submap.map = std::make_unique<LaserMap>(options_.local.grid, options_.local.field);
    submap.min_submap = submap.max_submap = Eigen::Vector2d::Zero();
    submaps_.push_back(std::move(submap));
    const int index = static_cast<int>(submaps_.size()) - 1;
    problem_->AddParameterBlock(submaps_.back().world_pose, 3, manifold_.get());
    if (index == 0) {
      // Gauge: the first submap fixes the world frame (the robot's start pose).
      problem_->SetParameterBlockConstant(submaps_.back().world_pose);
    }
    active_submaps_.push_back(index);
    ++stats_.submaps;
  }

  Node node;
  node.stamp_seconds = scan.stamp_seconds;
  node.local_pose = local_pose;
  node.world_pose = AllocatePoseBlock(world_T_local_ * local_pose);
  node.points = points.all;
  node.matching_points = points.matching;
  node.sensor_robot = points.sensor_robot;
  nodes_.push_back(std::move(node));
  ++stats_.nodes;
  const int node_index = static_cast<int>(nodes_.size()) - 1;

  for (int s : active_submaps_) {
    Submap& submap = submaps_[s];
    const Pose2 submap_T_node = submap.local_T_submap.inverse() * local_pose;
    submap.map->InsertScan(submap_T_node, points.sensor_robot, points.all);
    ++submap.num_scans;
    submap.last_node = node_index;
    submap.min_submap = submap.min_submap.cwiseMin(submap_T_node.translation());
    submap.max_submap = submap.max_submap.cwiseMax(submap_T_node.translation());
  }
  AddNodeToGraph(&nodes_.back(), active_submaps_);
  if (submaps_[active_submaps_.front()].num_scans >= options_.scans_per_submap) {
    submaps_[active_submaps_.front()].finished = true;
    submaps_[active_submaps_.front()].map->Freeze();  // matched against only from now on
    active_submaps_.erase(active_submaps_.begin());
  }

  if (options_.loop_closure) SearchLoopClosures(node_index);
  ++nodes_since_solve_;
  if (loop_closures_since_solve_ >= options_.solve_every_n_loop_closures &&
      nodes_since_solve_ >= options_.solve_min_new_nodes) {
    Solve(options_.max_iterations_per_solve);
  }
}

void PoseGraphSlam::AddNodeToGraph(Node* node, const std::vector<int>& submap_indices) {
  const int node_index = static_cast<int>(nodes_.size()) - 1;
  problem_->AddParameterBlock(node->world_pose, 3, manifold_.get());
  const Eigen::Matrix3d sqrt_information = SqrtInformationFromStddev(
      options_.intra_translation_sigma_meters, options_.intra_translation_sigma_meters,
      options_.intra_rotation_sigma_radians);
  for (int s : submap_indices) {
    Constraint c;
    c.submap = s;
    c.node = node_index;
    c.submap_T_node = submaps_[s].local_T_submap.inverse() * node->local_pose;
    c.residual = problem_->AddResidualBlock(CreateRelativePose2Cost(c.submap_T_node, sqrt_information), nullptr,
                                            submaps_[s].world_pose, node->world_pose);
    constraints_.push_back(c);
  }
}

void PoseGraphSlam::SearchLoopClosures(int node_index) {
  const Node& node = nodes_[node_index];
  if (last_search_pose_.has_value()) {
    const Pose2 moved = Between(*last_search_pose_, node.local_pose);
    if (moved.translation().norm() < options_.loop_search_min_travel_meters &&
        std::abs(moved.theta()) < options_.loop_search_min_turn_radians) {
      return;
    }
  }
  last_search_pose_ = node.local_pose;
  const auto start = std::chrono::steady_clock::now();
  // The gate below rejects any closure farther from the estimate than the drift since the
  // last closure allows, so the search window need not reach beyond it (same result, less work).
  const double travel = travel_since_solve_meters_;
  const double linear_window = std::min(options_.loop_matcher.linear_search_window_meters,
                                        options_.loop_gate_base_meters + options_.loop_gate_meters_per_meter * travel);
  const double angular_window = std::min(options_.loop_matcher.angular_search_window_radians,
                                         options_.loop_gate_base_radians + options_.loop_gate_radians_per_meter * travel);
  const double gate_meters = options_.loop_gate_base_meters + options_.loop_gate_meters_per_meter * travel;
  const double gate_radians = options_.loop_gate_base_radians + options_.loop_gate_radians_per_meter * travel;
  const int accepted = SearchSubmaps(node_index, linear_window, angular_window, gate_meters, gate_radians,
                                     options_.loop_min_score, options_.loop_matcher.linear_search_window_meters);
  if (accepted > 0) {
    pending_wide_.reset();
  } else if (options_.loop_wide_search && gate_meters > options_.loop_matcher.linear_search_window_meters &&
             travel_since_wide_search_meters_ >= options_.loop_wide_search_spacing_meters) {
    WideSearch(node_index, gate_meters, gate_radians);
  }
  stats_.loop_search_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void PoseGraphSlam::WideSearch(int node_index, double gate_meters, double gate_radians) {
  travel_since_wide_search_meters_ = 0.0;
  std::optional<WideCandidate> best;
  SearchSubmaps(node_index, std::min(gate_meters, options_.loop_wide_window_meters),
                std::min(gate_radians, options_.loop_wide_angular_window_radians), gate_meters, gate_radians,
                options_.loop_wide_min_score, std::min(gate_meters, options_.loop_wide_window_meters), &best);
  if (!best.has_value()) return;
  ++stats_.loop_wide_candidates;
  // One wide match may be an alias (a corridor, a repeated room); two matches of different
  // nodes that call for the same correction of the drifting estimate are taken as real.
  if (pending_wide_.has_value() && pending_wide_->node != node_index) {
    const Pose2 disagreement = Between(pending_wide_->world_correction, best->world_correction);
    if (disagreement.translation().norm() <= options_.loop_wide_agreement_meters &&
        std::abs(disagreement.theta()) <= options_.loop_wide_agreement_radians) {
      // Confirmed closures enter without robust loss: they are metres from the estimate, where
      // the Huber loss of ordinary closures would leave them almost no pull.
      AddLoopConstraint(pending_wide_->submap, pending_wide_->node, pending_wide_->submap_T_node,
                        pending_wide_->score, /*robust=*/false);
      AddLoopConstraint(best->submap, best->node, best->submap_T_node, best->score, /*robust=*/false);
      constraints_[constraints_.size() - 1].exempt_from_next_check = true;
      constraints_[constraints_.size() - 2].exempt_from_next_check = true;
      stats_.loop_closures_accepted_wide += 2;
      pending_wide_.reset();
      // A correction of metres must reach the estimate of the next nodes before they search.
      Solve(options_.max_iterations_final);
      return;
    }
  }
  pending_wide_ = best;
}

int PoseGraphSlam::SearchSubmaps(int node_index, double linear_window, double angular_window, double gate_meters,
                                 double gate_radians, double min_score, double margin_meters,
                                 std::optional<WideCandidate>* wide_best) {
  const Node& node = nodes_[node_index];
  const Pose2 world_T_node = ToPose(node.world_pose);
  int accepted = 0;
  for (int s = 0; s < static_cast<int>(submaps_.size()); ++s) {
    Submap& submap = submaps_[s];
    if (!submap.finished) continue;
    // The front end built this submap moments ago: the intra-submap chain already ties the
    // node to it, a closure would add little but cost a search.
    if (node_index - submap.last_node < options_.loop_min_node_separation) continue;
    // Only submaps the node could be inside: its estimated position within the box of the
    // submap's own trajectory, grown by the search window.
    const Pose2 predicted = ToPose(submap.world_pose).inverse() * world_T_node;
    const Eigen::Vector2d p = predicted.translation();
    if ((p.array() < submap.min_submap.array() - margin_meters).any() ||
        (p.array() > submap.max_submap.array() + margin_meters).any()) {
      continue;
    }
    const ScanMatcher& matcher = wide_best != nullptr ? loop_wide_matcher_ : loop_matcher_;
    ++(wide_best != nullptr ? stats_.loop_wide_searches : stats_.loop_searches);
    const ScanMatchResult match =
        matcher.MatchWithinWindow(*submap.map, predicted, node.matching_points, linear_window, angular_window);
    if (!match.converged || match.score < min_score) continue;
    const Pose2 correction = Between(predicted, match.pose);
    if (correction.translation().norm() > gate_meters || std::abs(correction.theta()) > gate_radians) {
      ++stats_.loop_closures_rejected_by_gate;
      continue;
    }
    if (wide_best != nullptr) {
      if (!wide_best->has_value() || match.score > (*wide_best)->score) {
        const Pose2 world_matched = ToPose(submap.world_pose) * match.pose;
        *wide_best = WideCandidate{node_index, s, match.pose, world_matched * world_T_node.inverse(), match.score};
      }
      continue;
    }
    AddLoopConstraint(s, node_index, match.pose, match.score);
    ++accepted;
  }
  return accepted;
}

void PoseGraphSlam::AddLoopConstraint(int submap, int node, const Pose2& submap_T_node, double score,
                                      bool robust) {
  const Eigen::Matrix3d sqrt_information = SqrtInformationFromStddev(
      options_.loop_translation_sigma_meters, options_.loop_translation_sigma_meters,
      options_.loop_rotation_sigma_radians);
  Constraint c;
  c.submap = submap;
  c.node = node;
  c.submap_T_node = submap_T_node;
  c.loop = true;
  c.score = score;
  c.residual = problem_->AddResidualBlock(CreateRelativePose2Cost(submap_T_node, sqrt_information),
                                          robust ? new ceres::HuberLoss(options_.loop_loss_scale) : nullptr,
                                          submaps_[submap].world_pose, nodes_[node].world_pose);
  constraints_.push_back(c);
  ++stats_.loop_closures_accepted;
  ++loop_closures_since_solve_;
}

double* PoseGraphSlam::AllocatePoseBlock(const Pose2& pose) {
  // One large chunk first (its untouched pages cost no memory), so that the blocks of any
  // realistic run (up to 2^20 nodes and submaps) have increasing addresses in creation order.
  // Beyond it, later chunks may sit anywhere: the solution stays correct, only the
  // bit-for-bit repeatability across runs is then no longer guaranteed.
  if (pose_blocks_used_in_chunk_ == kPoseBlocksPerChunk || pose_block_chunks_.empty()) {
    pose_block_chunks_.emplace_back(new double[3 * kPoseBlocksPerChunk]);
    pose_blocks_used_in_chunk_ = 0;
  }
  double* block = pose_block_chunks_.back().get() + 3 * pose_blocks_used_in_chunk_++;
  block[0] = pose.x();
  block[1] = pose.y();
  block[2] = pose.theta();
  return block;
}

int PoseGraphSlam::num_nodes() const { return static_cast<int>(nodes_.size()); }
int PoseGraphSlam::num_submaps() const { return static_cast<int>(submaps_.size()); }

bool PoseGraphSlam::AddLoopClosure(int submap, int node, const Pose2& submap_T_node, double score) {
  if (submap < 0 || submap >= num_submaps() || node < 0 || node >= num_nodes()) return false;
  AddLoopConstraint(submap, node, submap_T_node, score);
  return true;
}

void PoseGraphSlam::Solve(int max_iterations) {
  loop_closures_since_solve_ = 0;
  nodes_since_solve_ = 0;
  // The estimate of new nodes is corrected from here on: drift is counted afresh. (Closures
  // accepted but not yet solved do not correct it, so the gate keeps growing until a solve.)
  travel_since_solve_meters_ = 0.0;
  if (nodes_.empty()) return;
  const auto start = std::chrono::steady_clock::now();
  ceres::Solver::Options solver_options;
  // Every constraint joins a submap and a node, so the graph is bipartite like a bundle
  // adjustment: eliminating the (many) nodes leaves a small sparse system over the submaps.
  // Ceres orders the blocks within a group by address; AllocatePoseBlock hands out
  // addresses in creation order, so the elimination order, and the result, is the same on
  // every run.
  solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (const Node& node : nodes_) ordering->AddElementToGroup(node.world_pose, 0);
  for (const Submap& submap : submaps_) ordering->AddElementToGroup(submap.world_pose, 1);
  solver_options.linear_solver_ordering = ordering;
  solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver_options.max_num_iterations = max_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  for (int round = 0; round < 2; ++round) {
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, problem_.get(), &summary);
    ++stats_.solves;
    stats_.solver_iterations += static_cast<int>(summary.iterations.size()) - 1;
    // Consistency check (issue: loop closures verified by consistency with the graph):
    // remove closures the optimised graph disagrees with, then solve once more.
    int removed = 0;
    for (Constraint& c : constraints_) {
      if (!c.loop || c.removed || c.exempt_from_next_check) continue;
      const Pose2 estimate = Between(ToPose(submaps_[c.submap].world_pose), ToPose(nodes_[c.node].world_pose));
      const Pose2 error = Between(c.submap_T_node, estimate);
      if (error.translation().norm() > options_.loop_consistency_translation_meters ||
          std::abs(error.theta()) > options_.loop_consistency_rotation_radians) {
        problem_->RemoveResidualBlock(c.residual);
        c.removed = true;
        c.residual = nullptr;
        ++removed;
        ++stats_.loop_closures_rejected_after_solve;
      }
    }
    if (removed == 0) break;
  }
  for (Constraint& c : constraints_) c.exempt_from_next_check = false;
  UpdateWorldFromLocal();
  stats_.solve_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void PoseGraphSlam::UpdateWorldFromLocal() {
  const Node& last = nodes_.back();
  world_T_local_ = ToPose(last.world_pose) * last.local_pose.inverse();
  // Active submaps still receive scans in their local frames; keep their world estimates
  // consistent with the new correction only through the graph (they are variables).
}

void PoseGraphSlam::Finish() {
  if (finished_) return;
  finished_ = true;
  if (options_.loop_closure && !nodes_.empty()) Solve(options_.max_iterations_final);
}

std::vector<StampedPose2> PoseGraphSlam::trajectory() const {
  std::vector<StampedPose2> trajectory;
  trajectory.reserve(nodes_.size());
  for (const Node& node : nodes_) trajectory.push_back({node.stamp_seconds, ToPose(node.world_pose)});
  return trajectory;
}

std::vector<StampedPose2> PoseGraphSlam::local_trajectory() const { return local_trajectory_; }

std::unique_ptr<OccupancyGrid> PoseGraphSlam::RenderMap() const {
  auto grid = std::make_unique<OccupancyGrid>(WithFieldMargin(options_.local.grid, options_.local.field));
  std::vector<Eigen::Vector2d> points_world;
  for (const Node& node : nodes_) {
    const Pose2 world_T_node = ToPose(node.world_pose);
    points_world.clear();
    for (const Eigen::Vector2f& p : node.points) points_world.push_back(world_T_node * p.cast<double>());
    grid->InsertScan(world_T_node * node.sensor_robot, points_world, nullptr);
  }
  return grid;
}

PoseGraph2d PoseGraphSlam::ExportGraph() const {
  PoseGraph2d graph;
  const int num_submaps = static_cast<int>(submaps_.size());
  for (int s = 0; s < num_submaps; ++s) graph.vertices.push_back({s, ToPose(submaps_[s].world_pose)});
  for (int i = 0; i < static_cast<int>(nodes_.size()); ++i) {
    graph.vertices.push_back({num_submaps + i, ToPose(nodes_[i].world_pose)});
  }
  for (const Constraint& c : constraints_) {
    if (c.removed) continue;
    PoseGraph2dEdge edge;
    edge.id_from = c.submap;
    edge.id_to = num_submaps + c.node;
    edge.from_T_to_measured = c.submap_T_node;
    edge.kind = c.loop ? EdgeKind::kLoopClosure : EdgeKind::kSequential;
    const double st = c.loop ? options_.loop_translation_sigma_meters : options_.intra_translation_sigma_meters;
    const double sr = c.loop ? options_.loop_rotation_sigma_radians : options_.intra_rotation_sigma_radians;
    edge.information = Eigen::Vector3d(1 / (st * st), 1 / (st * st), 1 / (sr * sr)).asDiagonal();
    graph.edges.push_back(edge);
  }
  if (!submaps_.empty()) graph.fixed_vertex_ids.push_back(0);
  return graph;
}

std::vector<LoopClosureReport> PoseGraphSlam::LoopClosures() const {
  std::vector<LoopClosureReport> reports;
  for (const Constraint& c : constraints_) {
    if (!c.loop) continue;
    reports.push_back({c.submap, c.node, c.score, c.submap_T_node,
                       Between(ToPose(submaps_[c.submap].world_pose), ToPose(nodes_[c.node].world_pose)), c.removed});
  }
  return reports;
}

}  // namespace hetslam
