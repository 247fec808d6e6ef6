// Optimise a planar pose graph (core/g2o_io.h data) with Ceres and hetslam's factors.
//
// Problem: one [x, y, yaw] block per vertex with the Se2Manifold, one RelativePose2 cost per
// edge with S = upper Cholesky factor of the edge information (factors/sqrt_information.h):
//   minimise 1/2 sum_edges || S_ij [E_x, E_y, wrap(E_yaw)] ||^2,
//   E = i_T_j_measured^-1 * (world_T_i^-1 world_T_j)          (g2o's EDGE_SE2 error).
// Gauge: a pose graph constrains only relative poses, so the whole solution may be moved by any
// rigid transform at equal cost. We remove that freedom by holding the vertices of FIX lines
// constant, or, when there are none, the first vertex in file order (usually the start pose),
// which keeps the solution in the frame of the initial estimate.
//
// Robust losses follow factors/relative_pose_cost.h: an edge between consecutive ids
// (|id_to - id_from| == 1) counts as sequential odometry and never gets a loss; every other edge
// is a loop closure and gets `loop_closure_loss` (none by default).
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
  int max_num_iterations = 100;
  // Sparse Cholesky of the normal equations through SuiteSparse (CHOLMOD): the right choice for
  // pose graphs, whose Jacobian is very sparse. DENSE_QR etc. work for small graphs.
  ceres::LinearSolverType linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  ceres::SparseLinearAlgebraLibraryType sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  RobustLossType loop_closure_loss = RobustLossType::kNone;
  // Loss scale in standard deviations of the whitened residual (> 0).
  double loop_closure_loss_scale = 1.0;
  // Ceres' relative cost-change tolerance for convergence.
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
  double solve_time_seconds = 0.0;  // wall time of ceres::Solve
  bool converged = false;        // Ceres reported CONVERGENCE (not just an iteration limit)
  std::string message;           // Ceres' termination message
  std::string full_report;       // ceres::Solver::Summary::FullReport()
};

// Optimises the vertex poses of *graph in place. Returns an error (and leaves *graph unchanged)
// for invalid options, an empty graph, an edge or FIX naming a missing vertex, or a solve whose
// result Ceres reports unusable; `summary` is filled whenever the solver ran. Hitting
// max_num_iterations is not an error: the result is returned with converged == false.
Status OptimizePoseGraph2d(const PoseGraph2dOptions& options, PoseGraph2d* graph,
                           PoseGraph2dSummary* summary);

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_POSE_GRAPH_2D_H_
