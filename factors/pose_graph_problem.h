// One builder for every planar pose-graph Ceres problem of hetslam: the submap graph of the
// online estimator (frontends/submap_graph.h), several robots joined through anchors, and
// `OptimizePoseGraph2d` (g2o files, hetslam_posegraph).
//
// Variables: [x, y, yaw] pose blocks with the Se2Manifold, handed out by AddPose in creation
// order at increasing addresses (Ceres orders blocks within an elimination group by address,
// so the elimination order, and the result, is the same on every run). Each pose belongs to an
// elimination group (0 first); with SPARSE_SCHUR the lowest group is eliminated first.
//
// Edges (factors/relative_pose_cost.h), each with a kind carried in the graph data:
//   kSequential   a_T_b between two poses of one frame, no robust loss (the backbone);
//   kLoopClosure  the same cost, a robust loss (Huber, or Cauchy) unless `loss_scale` is 0;
//   kInterRobot   the anchored cost of Kim et al. 2010 between poses of two robots' frames,
//                 each placed in the world by its robot's anchor pose (world_T_robot_origin).
// Gauge: the caller holds poses constant on purpose (SetConstant): the first pose of each
// robot in its own frame, and one anchor of the team.
#ifndef HETSLAM_FACTORS_POSE_GRAPH_PROBLEM_H_
#define HETSLAM_FACTORS_POSE_GRAPH_PROBLEM_H_

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "ceres/types.h"
#include "core/edge_kind.h"  // EdgeKind, EdgeKindName
#include "core/se2.h"
#include "core/status.h"

namespace ceres {
class Problem;
class Manifold;
namespace internal {
class ResidualBlock;  // ceres::ResidualBlockId is a pointer to it (ceres/problem.h)
}  // namespace internal
}  // namespace ceres

namespace hetslam {

struct PoseGraphSolveOptions {
  int max_num_iterations = 50;  // 0: only evaluate the initial cost
  // SPARSE_SCHUR eliminates the lowest elimination group first (bipartite submap graphs);
  // SPARSE_NORMAL_CHOLESKY for general graphs.
  ceres::LinearSolverType linear_solver_type = ceres::SPARSE_SCHUR;
  ceres::SparseLinearAlgebraLibraryType sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  double function_tolerance = 1e-6;  // Ceres' default
  int num_threads = 1;  // 1 keeps runs bit-reproducible
  bool log_progress = false;

  bool IsValid(std::string* error) const;
};

struct PoseGraphSolveSummary {
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int num_iterations = 0;     // iterations after the initial evaluation
  bool converged = false;     // Ceres reported CONVERGENCE, or there were no edges to solve
  double solve_time_seconds = 0.0;
  std::string message;        // Ceres' termination message
  std::string full_report;
};

class PoseGraphProblem {
 public:
  PoseGraphProblem();
  ~PoseGraphProblem();
  PoseGraphProblem(const PoseGraphProblem&) = delete;
  PoseGraphProblem& operator=(const PoseGraphProblem&) = delete;

  // A new pose variable (index = number of poses before it) in `elimination_group` (>= 0).
  int AddPose(const Pose2& initial, int elimination_group = 0);
  void SetConstant(int pose, bool constant);
  bool IsConstant(int pose) const;

  // An edge a_T_b; `loss_scale` (in sigmas of the whitened residual) > 0 adds a robust loss of
  // type `loss`, 0 none. Returns the edge index. CHECK-fails on unknown poses, a = b, or a loss
  // on a sequential edge (programmer errors: the backbone never gets one).
  enum class Loss { kHuber, kCauchy };
  int AddEdge(EdgeKind kind, int a, int b, const Pose2& a_T_b, const Eigen::Matrix3d& sqrt_information,
              double loss_scale = 0.0, Loss loss = Loss::kHuber);
  // An anchored edge between pose a (of the robot whose anchor is `anchor_a`) and pose b (anchor
  // `anchor_b`), kInterRobot. The four poses must be distinct.
  int AddAnchoredEdge(int anchor_a, int a, int anchor_b, int b, const Pose2& a_T_b,
                      const Eigen::Matrix3d& sqrt_information, double loss_scale);
  // Takes an edge out of the problem (it stays listed, with removed() true).
  void RemoveEdge(int edge);
  // Takes an edge out of the problem (if it is still in) and forgets it: its index is invalid
  // from now on and a later AddEdge / AddAnchoredEdge may hand it out again (its memory is
  // reused). For edges the caller no longer refers to, e.g. those of a pose it removes.
  void ReleaseEdge(int edge);
  // Takes a pose out of the problem for good (its block keeps its last value). CHECK-fails while
  // an edge that is neither removed nor released still touches it, or for a constant pose.
  void RemovePose(int pose);
  bool pose_removed(int pose) const { return poses_[pose].removed; }
  // Edges in the problem (neither removed nor released) that touch the pose.
  int pose_edges(int pose) const { return poses_[pose].live_edges; }

  int num_poses() const { return static_cast<int>(poses_.size()); }
  int num_edges() const { return static_cast<int>(edges_.size()); }
  Pose2 pose(int index) const;
  void set_pose(int index, const Pose2& pose);
  EdgeKind edge_kind(int edge) const { return edges_[edge].kind; }
  bool edge_removed(int edge) const { return edges_[edge].removed; }
  // The estimate of the edge's relative pose a_T_b (anchors applied for inter-robot edges).
  Pose2 EdgeEstimate(int edge) const;
  // What a live edge (not removed) was added with: read from its cost function, which holds the
  // only copy. CHECK-fails for a removed edge (its cost function is gone).
  Pose2 edge_measurement(int edge) const;
  Eigen::Matrix3d edge_sqrt_information(int edge) const;
  int edge_from(int edge) const { return edges_[edge].a; }
  int edge_to(int edge) const { return edges_[edge].b; }

  // Solves in place. Errors (poses then restored to their values before the call): invalid
  // options, or a solution Ceres reports unusable (IsSolutionUsable false: a NaN cost, a
  // failed linear solve). Hitting the iteration limit is not an error.
  Status Solve(const PoseGraphSolveOptions& options, PoseGraphSolveSummary* summary = nullptr);

 private:
  struct Pose {
    double* block = nullptr;
    int group = 0;
    int live_edges = 0;  // edges in the problem that touch it
    bool in_problem = false;
    bool constant = false;
    bool removed = false;
  };
  struct Edge {
    EdgeKind kind = EdgeKind::kSequential;
    int anchor_a = -1, a = -1, anchor_b = -1, b = -1;
    bool removed = false;
    // The measurement and its square-root information live in the residual's cost function
    // alone (FR079: ~10 000 edges, 96 bytes each repeated here before).
    ceres::internal::ResidualBlock* residual = nullptr;
  };
  void EnsureInProblem(int pose);
  // Both of what a live edge was added with, from its cost function.
  void EdgeMeasurement(int edge, Pose2* measurement, Eigen::Matrix3d* sqrt_information) const;
  // Stores `edge` in a released slot, or at the end; returns its index.
  int StoreEdge(const Edge& edge);
  // Adds `delta` to the live-edge count of every pose `edge` touches.
  void CountLiveEdges(const Edge& edge, int delta);

  std::vector<std::unique_ptr<double[]>> chunks_;
  size_t used_in_chunk_ = 0;
  std::vector<Pose> poses_;
  // A deque: no reallocation (a vector of edges grows by copying itself, the old and new arrays
  // alive together).
  std::deque<Edge> edges_;
  std::vector<int> released_edges_;  // slots ReleaseEdge freed, reused by the next edges
  std::unique_ptr<ceres::Manifold> manifold_;
  std::unique_ptr<ceres::Problem> problem_;
};

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_POSE_GRAPH_PROBLEM_H_
