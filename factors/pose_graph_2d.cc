#include "factors/pose_graph_2d.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <unordered_map>
#include <vector>

#include "Eigen/Cholesky"
#include "ceres/loss_function.h"
#include "ceres/problem.h"
#include "ceres/solver.h"
#include "factors/relative_pose_cost.h"
#include "factors/se2_manifold.h"
#include "factors/sqrt_information.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

ceres::Solver::Options SolverOptions(const PoseGraph2dOptions& options) {
  ceres::Solver::Options solver;
  solver.max_num_iterations = options.max_num_iterations;
  solver.linear_solver_type = options.linear_solver_type;
  solver.sparse_linear_algebra_library_type = options.sparse_linear_algebra_library_type;
  solver.function_tolerance = options.function_tolerance;
  solver.num_threads = options.num_threads;
  solver.minimizer_progress_to_stdout = options.log_progress;
  return solver;
}

ceres::LossFunction* MakeLoss(RobustLossType type, double scale) {
  switch (type) {
    case RobustLossType::kNone:
      return nullptr;
    case RobustLossType::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLossType::kCauchy:
      return new ceres::CauchyLoss(scale);
  }
  LOG(FATAL) << "unknown RobustLossType " << static_cast<int>(type);
  return nullptr;
}

}  // namespace

bool ParseRobustLossType(const std::string& name, RobustLossType* type) {
  if (name == "none") {
    *type = RobustLossType::kNone;
  } else if (name == "huber") {
    *type = RobustLossType::kHuber;
  } else if (name == "cauchy") {
    *type = RobustLossType::kCauchy;
  } else {
    return false;
  }
  return true;
}

std::string RobustLossTypeName(RobustLossType type) {
  switch (type) {
    case RobustLossType::kNone:
      return "none";
    case RobustLossType::kHuber:
      return "huber";
    case RobustLossType::kCauchy:
      return "cauchy";
  }
  return "unknown";
}

bool PoseGraph2dOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (max_num_iterations < 0) return fail("max_num_iterations must be >= 0");
  if (!(loop_closure_loss_scale > 0.0) || !std::isfinite(loop_closure_loss_scale)) {
    return fail("loop_closure_loss_scale must be finite and > 0");
  }
  if (!(function_tolerance >= 0.0)) return fail("function_tolerance must be >= 0");
  if (num_threads < 1) return fail("num_threads must be >= 1");
  // Ceres knows which solver / library combinations this build supports.
  std::string ceres_error;
  if (!SolverOptions(*this).IsValid(&ceres_error)) return fail(ceres_error);
  return true;
}

Status OptimizePoseGraph2d(const PoseGraph2dOptions& options, PoseGraph2d* graph,
                           PoseGraph2dSummary* summary) {
  CHECK(graph != nullptr);
  CHECK(summary != nullptr);
  *summary = PoseGraph2dSummary();
  std::string error;
  if (!options.IsValid(&error)) return Status::Error("invalid PoseGraph2dOptions: " + error);
  if (graph->vertices.empty()) return Status::Error("pose graph has no vertices");

  std::unordered_map<int, int> index_of_id;
  std::vector<std::array<double, 3>> blocks(graph->vertices.size());
  for (size_t k = 0; k < graph->vertices.size(); ++k) {
    const PoseGraph2dVertex& v = graph->vertices[k];
    if (!index_of_id.emplace(v.id, static_cast<int>(k)).second) {
      return Status::Error("pose graph has two vertices with id " + std::to_string(v.id));
    }
    blocks[k] = {v.world_T_vertex.x(), v.world_T_vertex.y(), v.world_T_vertex.theta()};
  }

  ceres::Problem::Options problem_options;
  // One manifold object is shared by all blocks; we own it, the problem must not delete it.
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  Se2Manifold manifold;
  for (auto& block : blocks) problem.AddParameterBlock(block.data(), 3, &manifold);

  for (const PoseGraph2dEdge& edge : graph->edges) {
    const auto from = index_of_id.find(edge.id_from);
    const auto to = index_of_id.find(edge.id_to);
    if (from == index_of_id.end() || to == index_of_id.end() || from == to) {
      return Status::Error("edge " + std::to_string(edge.id_from) + " -> " +
                           std::to_string(edge.id_to) + " does not join two distinct vertices");
    }
    const Eigen::LLT<Eigen::Matrix3d> llt(edge.information);
    if (!edge.information.allFinite() || llt.info() != Eigen::Success) {
      return Status::Error("edge " + std::to_string(edge.id_from) + " -> " +
                           std::to_string(edge.id_to) + " has a non positive definite information");
    }
    const bool sequential = std::abs(static_cast<long>(edge.id_to) - edge.id_from) == 1;
    ceres::LossFunction* loss =
        sequential ? nullptr
                   : MakeLoss(options.loop_closure_loss, options.loop_closure_loss_scale);
    problem.AddResidualBlock(
        CreateRelativePose2Cost(edge.from_T_to_measured,
                                SqrtInformationFromInformation(edge.information)),
        loss, blocks[from->second].data(), blocks[to->second].data());
  }

  // Gauge freedom (see header): FIX vertices, else the first vertex.
  std::vector<int> fixed = graph->fixed_vertex_ids;
  if (fixed.empty()) fixed.push_back(graph->vertices.front().id);
  for (const int id : fixed) {
    const auto it = index_of_id.find(id);
    if (it == index_of_id.end()) {
      return Status::Error("FIX names vertex " + std::to_string(id) + ", which does not exist");
    }
    if (!problem.IsParameterBlockConstant(blocks[it->second].data())) {
      problem.SetParameterBlockConstant(blocks[it->second].data());
      ++summary->num_fixed_vertices;
    }
  }
  summary->num_vertices = static_cast<int>(graph->vertices.size());
  summary->num_edges = static_cast<int>(graph->edges.size());

  ceres::Solver::Summary ceres_summary;
  ceres::Solve(SolverOptions(options), &problem, &ceres_summary);
  summary->initial_cost = ceres_summary.initial_cost;
  summary->final_cost = ceres_summary.final_cost;
  // Ceres lists the initial evaluation as iteration 0; count only the LM steps after it.
  summary->num_iterations = std::max(0, static_cast<int>(ceres_summary.iterations.size()) - 1);
  summary->solve_time_seconds = ceres_summary.total_time_in_seconds;
  summary->converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary->message = ceres_summary.message;
  summary->full_report = ceres_summary.FullReport();
  if (!ceres_summary.IsSolutionUsable()) {
    return Status::Error("pose graph solve failed: " + ceres_summary.message);
  }
  for (size_t k = 0; k < blocks.size(); ++k) {
    graph->vertices[k].world_T_vertex = Pose2(blocks[k][0], blocks[k][1], blocks[k][2]);
  }
  return Status::Ok();
}

}  // namespace hetslam
