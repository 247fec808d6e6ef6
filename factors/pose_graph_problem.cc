#include "factors/pose_graph_problem.h"

#include <chrono>
#include <sstream>

#include "ceres/ceres.h"
#include "factors/pose2_math.h"
#include "factors/relative_pose_cost.h"
#include "factors/se2_manifold.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

// Pose blocks live in chunks of this many: one large chunk first (its untouched pages cost no
// memory), so that the blocks of any realistic graph (up to 2^20 poses) have increasing
// addresses in creation order. Beyond it, later chunks may sit anywhere: the solution stays
// correct, only bit-for-bit repeatability across runs is then no longer guaranteed.
constexpr size_t kPosesPerChunk = size_t{1} << 20;

Pose2 ToPose(const double* block) { return Pose2(block[0], block[1], block[2]); }

}  // namespace

bool PoseGraphSolveOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (max_num_iterations < 0) why << "max_num_iterations must be >= 0, got " << max_num_iterations;
  else if (!(function_tolerance >= 0)) why << "function_tolerance must be >= 0, got " << function_tolerance;
  else if (num_threads < 1) why << "num_threads must be >= 1, got " << num_threads;
  if (error != nullptr) *error = why.str();
  return why.str().empty();
}

PoseGraphProblem::PoseGraphProblem() : manifold_(CreateSe2Manifold()) {
  ceres::Problem::Options options;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(options);
}

PoseGraphProblem::~PoseGraphProblem() = default;

int PoseGraphProblem::AddPose(const Pose2& initial, int elimination_group) {
  CHECK_GE(elimination_group, 0) << "elimination groups are >= 0";
  if (chunks_.empty() || used_in_chunk_ == kPosesPerChunk) {
    chunks_.emplace_back(new double[3 * kPosesPerChunk]);
    used_in_chunk_ = 0;
  }
  Pose pose;
  pose.block = chunks_.back().get() + 3 * used_in_chunk_++;
  pose.group = elimination_group;
  poses_.push_back(pose);
  set_pose(num_poses() - 1, initial);
  EnsureInProblem(num_poses() - 1);
  return num_poses() - 1;
}

void PoseGraphProblem::EnsureInProblem(int index) {
  Pose& pose = poses_[index];
  if (pose.in_problem) return;
  problem_->AddParameterBlock(pose.block, 3, manifold_.get());
  pose.in_problem = true;
  if (pose.constant) problem_->SetParameterBlockConstant(pose.block);
}

void PoseGraphProblem::SetConstant(int index, bool constant) {
  CHECK(index >= 0 && index < num_poses()) << "unknown pose " << index;
  poses_[index].constant = constant;
  if (constant) {
    problem_->SetParameterBlockConstant(poses_[index].block);
  } else {
    problem_->SetParameterBlockVariable(poses_[index].block);
  }
}

bool PoseGraphProblem::IsConstant(int index) const { return poses_[index].constant; }

Pose2 PoseGraphProblem::pose(int index) const {
  CHECK(index >= 0 && index < num_poses()) << "unknown pose " << index;
  return ToPose(poses_[index].block);
}

void PoseGraphProblem::set_pose(int index, const Pose2& pose) {
  double* block = poses_[index].block;
  block[0] = pose.x();
  block[1] = pose.y();
  block[2] = pose.theta();
}

int PoseGraphProblem::AddEdge(EdgeKind kind, int a, int b, const Pose2& a_T_b, const Eigen::Matrix3d& sqrt_information,
                              double loss_scale, Loss loss) {
  CHECK(a >= 0 && a < num_poses() && b >= 0 && b < num_poses() && a != b)
      << "edge between poses " << a << " and " << b << " of " << num_poses();
  CHECK_GE(loss_scale, 0.0);
  CHECK(kind != EdgeKind::kSequential || loss_scale == 0.0) << "a sequential edge never gets a robust loss";
  ceres::LossFunction* loss_function = nullptr;
  if (loss_scale > 0) {
    loss_function = loss == Loss::kCauchy ? static_cast<ceres::LossFunction*>(new ceres::CauchyLoss(loss_scale))
                                          : new ceres::HuberLoss(loss_scale);
  }
  Edge edge;
  edge.kind = kind;
  edge.a = a;
  edge.b = b;
  edge.residual = problem_->AddResidualBlock(CreateRelativePose2Cost(a_T_b, sqrt_information),
                                             loss_function, poses_[a].block, poses_[b].block);
  return StoreEdge(edge);
}

int PoseGraphProblem::StoreEdge(const Edge& edge) {
  CountLiveEdges(edge, 1);
  if (released_edges_.empty()) {
    edges_.push_back(edge);
    return num_edges() - 1;
  }
  const int index = released_edges_.back();
  released_edges_.pop_back();
  edges_[index] = edge;
  return index;
}

void PoseGraphProblem::CountLiveEdges(const Edge& edge, int delta) {
  for (const int pose : {edge.anchor_a, edge.a, edge.anchor_b, edge.b}) {
    if (pose >= 0) poses_[pose].live_edges += delta;
  }
}

int PoseGraphProblem::AddAnchoredEdge(int anchor_a, int a, int anchor_b, int b, const Pose2& a_T_b,
                                      const Eigen::Matrix3d& sqrt_information, double loss_scale) {
  for (int p : {anchor_a, a, anchor_b, b}) CHECK(p >= 0 && p < num_poses()) << "unknown pose " << p;
  CHECK(anchor_a != a && anchor_a != anchor_b && anchor_a != b && a != anchor_b && a != b && anchor_b != b)
      << "an anchored edge needs four distinct poses";
  CHECK_GE(loss_scale, 0.0);
  Edge edge;
  edge.kind = EdgeKind::kInterRobot;
  edge.anchor_a = anchor_a;
  edge.a = a;
  edge.anchor_b = anchor_b;
  edge.b = b;
  edge.residual = problem_->AddResidualBlock(CreateAnchoredRelativePose2Cost(a_T_b, sqrt_information),
                                             loss_scale > 0 ? new ceres::HuberLoss(loss_scale) : nullptr,
                                             poses_[anchor_a].block, poses_[a].block, poses_[anchor_b].block,
                                             poses_[b].block);
  return StoreEdge(edge);
}

void PoseGraphProblem::RemoveEdge(int index) {
  Edge& edge = edges_[index];
  if (edge.removed) return;
  problem_->RemoveResidualBlock(edge.residual);
  CountLiveEdges(edge, -1);
  edge.residual = nullptr;
  edge.removed = true;
}

void PoseGraphProblem::ReleaseEdge(int index) {
  CHECK(index >= 0 && index < num_edges()) << "unknown edge " << index;
  RemoveEdge(index);
  edges_[index] = Edge();
  edges_[index].removed = true;
  released_edges_.push_back(index);
}

void PoseGraphProblem::RemovePose(int index) {
  CHECK(index >= 0 && index < num_poses()) << "unknown pose " << index;
  Pose& pose = poses_[index];
  if (pose.removed) return;
  CHECK_EQ(pose.live_edges, 0) << "pose " << index << " still has edges";
  CHECK(!pose.constant) << "pose " << index << " is held constant";
  // No residual touches it any more: Ceres only scans its residual blocks to confirm.
  if (pose.in_problem) problem_->RemoveParameterBlock(pose.block);
  pose.in_problem = false;
  pose.removed = true;
}

void PoseGraphProblem::EdgeMeasurement(int index, Pose2* measurement, Eigen::Matrix3d* sqrt_information) const {
  const Edge& edge = edges_[index];
  CHECK(!edge.removed) << "edge " << index << " is removed: its measurement is gone";
  CHECK(RelativePose2CostMeasurement(*problem_->GetCostFunctionForResidualBlock(edge.residual), measurement,
                                     sqrt_information));
}

Pose2 PoseGraphProblem::edge_measurement(int index) const {
  Pose2 measurement;
  Eigen::Matrix3d sqrt_information;
  EdgeMeasurement(index, &measurement, &sqrt_information);
  return measurement;
}

Eigen::Matrix3d PoseGraphProblem::edge_sqrt_information(int index) const {
  Pose2 measurement;
  Eigen::Matrix3d sqrt_information;
  EdgeMeasurement(index, &measurement, &sqrt_information);
  return sqrt_information;
}

Pose2 PoseGraphProblem::EdgeEstimate(int index) const {
  const Edge& edge = edges_[index];
  if (edge.kind == EdgeKind::kInterRobot && edge.anchor_a >= 0) {
    return Between(pose(edge.anchor_a) * pose(edge.a), pose(edge.anchor_b) * pose(edge.b));
  }
  return Between(pose(edge.a), pose(edge.b));
}

Status PoseGraphProblem::Solve(const PoseGraphSolveOptions& options, PoseGraphSolveSummary* summary) {
  std::string invalid;
  if (!options.IsValid(&invalid)) return Status::Error("invalid PoseGraphSolveOptions: " + invalid);
  if (summary != nullptr) *summary = PoseGraphSolveSummary();
  if (problem_->NumResidualBlocks() == 0) {
    // Nothing to solve: the poses are already optimal (Ceres reports CONVERGENCE here too).
    if (summary != nullptr) {
      summary->converged = true;
      summary->message = "no edges: nothing to solve";
    }
    return Status::Ok();
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = options.linear_solver_type;
  if (options.linear_solver_type == ceres::SPARSE_SCHUR) {
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (const Pose& pose : poses_) {
      if (pose.in_problem) ordering->AddElementToGroup(pose.block, pose.group);
    }
    solver_options.linear_solver_ordering = ordering;
  }
  solver_options.sparse_linear_algebra_library_type = options.sparse_linear_algebra_library_type;
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads = options.num_threads;
  solver_options.logging_type = options.log_progress ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = options.log_progress;

  std::vector<double> before(3 * poses_.size());
  for (size_t i = 0; i < poses_.size(); ++i) std::copy(poses_[i].block, poses_[i].block + 3, &before[3 * i]);
  ceres::Solver::Summary ceres_summary;
  const auto start = std::chrono::steady_clock::now();
  ceres::Solve(solver_options, problem_.get(), &ceres_summary);
  if (summary != nullptr) {
    summary->initial_cost = ceres_summary.initial_cost;
    summary->final_cost = ceres_summary.final_cost;
    summary->num_iterations = std::max(0, static_cast<int>(ceres_summary.iterations.size()) - 1);
    summary->converged = ceres_summary.termination_type == ceres::CONVERGENCE;
    summary->solve_time_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    summary->message = ceres_summary.message;
    summary->full_report = ceres_summary.FullReport();
  }
  if (!ceres_summary.IsSolutionUsable()) {
    for (size_t i = 0; i < poses_.size(); ++i) std::copy(&before[3 * i], &before[3 * i] + 3, poses_[i].block);
    return Status::Error("pose graph solve unusable: " + ceres_summary.message);
  }
  return Status::Ok();
}

}  // namespace hetslam
