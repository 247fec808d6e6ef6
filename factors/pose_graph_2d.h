// Optimise a planar pose graph (core/g2o_io.h data) with Ceres and hetslam's factors.
//
// The problem is built and solved by PoseGraphProblem (factors/pose_graph_problem.h): one
// [x, y, yaw] pose per vertex (Se2Manifold), one RelativePose2 cost per edge with S = upper
// Cholesky factor of the edge information (factors/sqrt_information.h):
//   minimise 1/2 sum_edges || S_ij [E_x, E_y, wrap(E_yaw)] ||^2,
//   E = i_T_j_measured^-1 * (world_T_i^-1 world_T_j)          (g2o's EDGE_SE2 error).
// Gauge: a pose graph constrains only relative poses, so the whole solution may be moved by any
// rigid transform at equal cost. We remove that freedom by holding the vertices of FIX lines
// constant, or, when there are none, the first vertex in file order (usually the start pose),
// which keeps the solution in the frame of the initial estimate.
//
// Robust losses follow factors/relative_pose_cost.h and each edge's `kind` (core/edge_kind.h;
// the g2o reader labels edges between consecutive ids kSequential, the others kLoopClosure):
// kSequential edges never get a loss; kLoopClosure and kInterRobot edges get `loop_closure_loss`
// (none by default). An inter-robot edge here joins two vertices of the one world frame (a
// PoseGraph2d has no anchors).
#ifndef HETSLAM_FACTORS_POSE_GRAPH_2D_H_
#define HETSLAM_FACTORS_POSE_GRAPH_2D_H_

#include <string>

#include "ceres/types.h"
#include "core/g2o_io.h"
#include "core/status.h"

namespace hetslam {

enum class RobustLossType { kNone, kHuber, kCauchy };

// "none", "huber", "cauchy" <-> RobustLossType. Parse returns false on an unknown name.
bool ParseRobustLossType(const std::string& name, RobustLossType* type);
std::string RobustLossTypeName(RobustLossType type);

struct PoseGraph2dOptions {
  int max_num_iterations = 100;  // >= 1
  // Sparse Cholesky of the normal equations through SuiteSparse (CHOLMOD): the right choice for
  // pose graphs, whose Jacobian is very sparse. DENSE_QR etc. work for small graphs.
  ceres::LinearSolverType linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  ceres::SparseLinearAlgebraLibraryType sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  // kNone or kHuber: PoseGraphProblem puts a Huber loss on loop closures, so IsValid rejects
  // kCauchy.
  RobustLossType loop_closure_loss = RobustLossType::kNone;
  // Loss scale in standard deviations of the whitened residual (> 0).
  double loop_closure_loss_scale = 1.0;
  // Ceres' relative cost-change tolerance for convergence (> 0).
  double function_tolerance = 1e-8;
  int num_threads = 1;  // Jacobian evaluation threads; 1 keeps runs bit-reproducible.
  bool log_progress = false;  // Ceres' per-iteration table on stdout

  bool IsValid(std::string* error) const;
};

struct PoseGraph2dSummary {
  int num_vertices = 0;
  int num_edges = 0;
  int num_fixed_vertices = 0;
  // Ceres cost = 1/2 sum of squared (robustified) whitened residuals, before and after.
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int num_iterations = 0;        // LM iterations (accepted or not) after the initial evaluation
  double solve_time_seconds = 0.0;  // wall time of the solve
  bool converged = false;        // Ceres reported CONVERGENCE (not just an iteration limit)
  std::string message;           // Ceres' termination message
  std::string full_report;       // ceres::Solver::Summary::FullReport()
};

// Optimises the vertex poses of *graph in place. Returns an error (and leaves *graph unchanged)
// for invalid options, an empty graph, two vertices with one id, an edge or FIX naming a missing
// vertex, an edge information that is not positive definite, or a solve whose result Ceres
// reports unusable; `summary` is filled whenever the solver ran. Hitting max_num_iterations is
// not an error: the result is returned with converged == false.
Status OptimizePoseGraph2d(const PoseGraph2dOptions& options, PoseGraph2d* graph,
                           PoseGraph2dSummary* summary);

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_POSE_GRAPH_2D_H_
