#include "factors/pose_graph_2d.h"

#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

#include "Eigen/Cholesky"
#include "ceres/solver.h"
#include "factors/pose_graph_problem.h"
#include "factors/sqrt_information.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

PoseGraphSolveOptions SolveOptions(const PoseGraph2dOptions& options) {
  PoseGraphSolveOptions solve;
  solve.max_num_iterations = options.max_num_iterations;
  solve.linear_solver_type = options.linear_solver_type;
  solve.sparse_linear_algebra_library_type = options.sparse_linear_algebra_library_type;
  solve.function_tolerance = options.function_tolerance;
  solve.num_threads = options.num_threads;
  solve.log_progress = options.log_progress;
  return solve;
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
  if (!(loop_closure_loss_scale > 0.0) || !std::isfinite(loop_closure_loss_scale)) {
    return fail("loop_closure_loss_scale must be finite and > 0");
  }
  std::string why;
  if (!SolveOptions(*this).IsValid(&why)) return fail(why);
  // Ceres knows which solver / library combinations this build supports.
  ceres::Solver::Options solver;
  solver.linear_solver_type = linear_solver_type;
  solver.sparse_linear_algebra_library_type = sparse_linear_algebra_library_type;
  if (!solver.IsValid(&why)) return fail(why);
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

  // Pose k of the problem is graph->vertices[k].
  PoseGraphProblem problem;
  std::unordered_map<int, int> index_of_id;
  for (const PoseGraph2dVertex& v : graph->vertices) {
    if (!index_of_id.emplace(v.id, problem.num_poses()).second) {
      return Status::Error("pose graph has two vertices with id " + std::to_string(v.id));
    }
    problem.AddPose(v.world_T_vertex);
  }

  const double loss_scale = options.loop_closure_loss == RobustLossType::kNone ? 0.0 : options.loop_closure_loss_scale;
  const PoseGraphProblem::Loss loss = options.loop_closure_loss == RobustLossType::kCauchy
                                          ? PoseGraphProblem::Loss::kCauchy
                                          : PoseGraphProblem::Loss::kHuber;
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
    problem.AddEdge(edge.kind, from->second, to->second, edge.from_T_to_measured,
                    SqrtInformationFromInformation(edge.information),
                    edge.kind == EdgeKind::kSequential ? 0.0 : loss_scale, loss);
  }

  // Gauge freedom (see header): FIX vertices, else the first vertex.
  std::vector<int> fixed = graph->fixed_vertex_ids;
  if (fixed.empty()) fixed.push_back(graph->vertices.front().id);
  for (const int id : fixed) {
    const auto it = index_of_id.find(id);
    if (it == index_of_id.end()) {
      return Status::Error("FIX names vertex " + std::to_string(id) + ", which does not exist");
    }
    if (!problem.IsConstant(it->second)) {
      problem.SetConstant(it->second, true);
      ++summary->num_fixed_vertices;
    }
  }
  summary->num_vertices = static_cast<int>(graph->vertices.size());
  summary->num_edges = static_cast<int>(graph->edges.size());

  PoseGraphSolveSummary solve;
  const Status status = problem.Solve(SolveOptions(options), &solve);
  summary->initial_cost = solve.initial_cost;
  summary->final_cost = solve.final_cost;
  summary->num_iterations = solve.num_iterations;
  summary->solve_time_seconds = solve.solve_time_seconds;
  summary->converged = solve.converged;
  summary->message = solve.message;
  summary->full_report = solve.full_report;
  // An unusable solution (IsSolutionUsable false) is an error; *graph stays as it was.
  if (!status.ok()) return status;
  for (int k = 0; k < problem.num_poses(); ++k) graph->vertices[k].world_T_vertex = problem.pose(k);
  return Status::Ok();
}

}  // namespace hetslam
