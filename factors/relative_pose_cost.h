// Relative pose ("between") costs for planar pose graphs: the sequential and loop-closure edges
// of one robot's graph, and the anchored inter-robot edges of a team graph.
//
// Parameter blocks are [x, y, yaw] arrays (metres, metres, radians) that should carry the
// Se2Manifold (factors/se2_manifold.h). All costs here are 3 residuals. The anchored cost is
// autodiff; the plain between cost has a hand-written Jacobian (it is most of a pose-graph
// solve's evaluation time: ~12k edges re-evaluated by each of FR079's ~100 incremental
// solves), tested against the autodiff of RelativePose2Residual and ceres::GradientChecker.
//
// Error (shared with every pose factor, see factors/pose2_math.h; it is g2o's EDGE_SE2 error,
// so information matrices from g2o files apply unchanged):
//   E = a_T_b_measured^-1 * a_T_b_estimated,  residual = S [E_x, E_y, wrap(E_yaw)]
// with S the upper-triangular square-root information (factors/sqrt_information.h).
//
// Robust losses (pass to Problem::AddResidualBlock; the residual is already whitened, so a loss
// scale is in standard deviations):
//   * sequential edges (consecutive keyframes, scan-matching odometry): NO loss. They are the
//     backbone that makes the graph connected; a loss would only weaken correct edges, and an
//     outlier there is a front-end failure to fix at the source.
//   * loop closures and inter-robot (anchored) edges: a loss, e.g. new ceres::CauchyLoss(1.0)
//     or ceres::HuberLoss(1.0..3.0): one wrong closure must not bend the whole map.
//   * priors that fix the gauge: NO loss.
//
// Ownership: every Create*Cost returns a new ceres::CostFunction that the caller owns until it
// is handed to ceres::Problem::AddResidualBlock (the problem then deletes it, by default). The
// functors copy their measurement and S: nothing is referenced after construction.
#ifndef HETSLAM_FACTORS_RELATIVE_POSE_COST_H_
#define HETSLAM_FACTORS_RELATIVE_POSE_COST_H_

#include "Eigen/Core"
#include "ceres/cost_function.h"
#include "core/se2.h"
#include "factors/pose2_math.h"

namespace hetslam {

// Between cost of two poses in one frame (world, or a robot's own origin frame):
//   a_T_b_estimated = world_T_a^-1 * world_T_b
//   residual(3)     = S [E_x, E_y, wrap(E_yaw)],  E = a_T_b_measured^-1 * a_T_b_estimated
// Parameter blocks: world_T_a[3], world_T_b[3].
class RelativePose2Residual {
 public:
  RelativePose2Residual(const Pose2& a_T_b_measured, const Eigen::Matrix3d& sqrt_information);
  const Pose2& measurement() const { return a_T_b_measured_; }
  const Eigen::Matrix3d& sqrt_information() const { return sqrt_information_; }

  template <typename T>
  bool operator()(const T* world_T_a, const T* world_T_b, T* residual) const {
    T a_T_b[3];
    BetweenPose2(world_T_a, world_T_b, a_T_b);
    RelativePose2Error(a_T_b, a_T_b_measured_, sqrt_information_, residual);
    return true;
  }

 private:
  const Pose2 a_T_b_measured_;              // pose of b in frame a; metres, radians
  const Eigen::Matrix3d sqrt_information_;  // S, S^T S = Sigma^-1 of E; rows 1/m, 1/m, 1/rad
};

// New cost (3 residuals; blocks world_T_a[3], world_T_b[3]) with the residual of
// RelativePose2Residual and its Jacobian written out by hand (equal to the autodiff one to
// rounding); caller owns it. CHECK-fails on a non-finite measurement or S.
// (ceres::AutoDiffCostFunction<RelativePose2Residual, 3, 3, 3> is the autodiff reference.)
ceres::CostFunction* CreateRelativePose2Cost(const Pose2& a_T_b_measured,
                                             const Eigen::Matrix3d& sqrt_information);

// Anchored relative pose cost (Kim et al. 2010, "Multiple relative pose graphs for robust
// cooperative mapping"). Each robot keeps its poses in its own frame (origin = its anchor);
// the anchor world_T_<robot>_origin places that frame in the shared world. A measurement
// between pose i of robot a and pose j of robot b (e.g. from a shared AprilTag or an inter-map
// scan match) constrains both the poses and the anchors:
//   world_T_ai      = world_T_a_origin * a_origin_T_ai
//   world_T_bj      = world_T_b_origin * b_origin_T_bj
//   ai_T_bj_estimated = world_T_ai^-1 * world_T_bj
//   residual(3)     = S [E_x, E_y, wrap(E_yaw)],  E = ai_T_bj_measured^-1 * ai_T_bj_estimated
// Parameter blocks, in this order: world_T_a_origin[3], a_origin_T_ai[3], world_T_b_origin[3],
// b_origin_T_bj[3]. Gauge: fix one anchor of the team (SetParameterBlockConstant), and the first
// pose of each robot in its own frame; a finished robot's trajectory may be held constant.
// Pitfall: all four blocks must be distinct arrays (Ceres rejects a block passed twice); for a
// constraint inside one robot use RelativePose2Residual instead.
class AnchoredRelativePose2Residual {
 public:
  AnchoredRelativePose2Residual(const Pose2& ai_T_bj_measured,
                                const Eigen::Matrix3d& sqrt_information);
  const Pose2& measurement() const { return ai_T_bj_measured_; }
  const Eigen::Matrix3d& sqrt_information() const { return sqrt_information_; }

  template <typename T>
  bool operator()(const T* world_T_a_origin, const T* a_origin_T_ai, const T* world_T_b_origin,
                  const T* b_origin_T_bj, T* residual) const {
    T world_T_ai[3];
    T world_T_bj[3];
    ComposePose2(world_T_a_origin, a_origin_T_ai, world_T_ai);
    ComposePose2(world_T_b_origin, b_origin_T_bj, world_T_bj);
    T ai_T_bj[3];
    BetweenPose2(world_T_ai, world_T_bj, ai_T_bj);
    RelativePose2Error(ai_T_bj, ai_T_bj_measured_, sqrt_information_, residual);
    return true;
  }

 private:
  const Pose2 ai_T_bj_measured_;            // pose j of robot b in the frame of pose i of robot a
  const Eigen::Matrix3d sqrt_information_;  // S, S^T S = Sigma^-1 of E; rows 1/m, 1/m, 1/rad
};

// New autodiff cost (3 residuals; blocks world_T_a_origin[3], a_origin_T_ai[3],
// world_T_b_origin[3], b_origin_T_bj[3]); caller owns it. Give it a robust loss.
ceres::CostFunction* CreateAnchoredRelativePose2Cost(const Pose2& ai_T_bj_measured,
                                                     const Eigen::Matrix3d& sqrt_information);

// The measurement and S a cost made by CreateRelativePose2Cost or CreateAnchoredRelativePose2Cost
// holds (so that a graph need not keep its own copy of every edge's); false, with the outputs
// untouched, for any other cost function.
bool RelativePose2CostMeasurement(const ceres::CostFunction& cost, Pose2* measurement,
                                  Eigen::Matrix3d* sqrt_information);

}  // namespace hetslam

#endif  // HETSLAM_FACTORS_RELATIVE_POSE_COST_H_
