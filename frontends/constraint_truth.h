// Loop closures and inter-robot constraints scored against a simulator's truth, one by one.
//
// A robot pair's error against the truth (hetslam_team's "truth:" lines) mixes three things:
// each robot's drift from its start frame, the inner distortion of the submaps the robots were
// matched in, and the matches themselves. This takes the trajectories out: a constraint says
// where node n sits in submap S (submap_T_node, measured by a scan match); the truth says where
// n's body was, and S's frame is placed in the world by S's own nodes, their poses in S as the
// front end inserted them (the frame S's map was built in) aligned to their truth. What is left
// is the match's own error plus what S's map got wrong inside itself.
//
//   world_T_S        = the rigid motion of {S_T_k inserted} onto {world_T_k truth}, k in S:
//                      rotation the circular mean of the heading differences (a submap spans
//                      metres at most, a standing humanoid's centimetres: positions would fix
//                      its rotation poorly), translation bringing the positions' centroids together
//   true S_T_n       = world_T_S^-1 * world_T_n (truth at n's stamp)
//   error            = true S_T_n ^-1 * measured S_T_n   (in n's true frame)
//
// A match that turns every scan the same way (a bias) shows as a mean rotation error away from
// zero; an unbiased matcher on warped maps shows a spread around zero and a worse fit of S.
#ifndef HETSLAM_FRONTENDS_CONSTRAINT_TRUTH_H_
#define HETSLAM_FRONTENDS_CONSTRAINT_TRUTH_H_

#include <map>
#include <string>
#include <vector>

#include "core/edge_kind.h"
#include "core/se2.h"
#include "core/status.h"
#include "core/trajectory_io.h"
#include "frontends/submap_graph.h"

namespace hetslam {

struct ConstraintTruthError {
  SubmapId submap;
  NodeId node;
  EdgeKind kind = EdgeKind::kLoopClosure;
  double score = 0.0;
  bool removed = false;          // withdrawn or rejected after a solve (LoopClosureReport)
  double stamp_seconds = 0.0;    // the node's
  Pose2 error;                   // true S_T_n ^-1 * measured S_T_n: metres, radians, n's frame
  // A degenerate constraint (a corridor: LoopClosureReport::weak_direction, unit, submap frame)
  // measured little along its weak direction; the graph weighs it little there (SubmapGraph).
  // Its translation error across that direction, the submap frame's (all of it when the
  // constraint has none), is what the constraint claims; `error` also holds the part along it.
  Eigen::Vector2d weak_direction = Eigen::Vector2d::Zero();
  double claimed_translation_meters = 0.0;
  int submap_nodes_aligned = 0;  // S's nodes with a truth pose, used to place S
  double submap_fit_rmse_meters = 0.0;  // of S's inserted node positions placed against their truth
};

// Every constraint LoopClosures() reports (loop closures and inter-robot constraints, removed
// ones flagged) whose node and at least two of whose submap's nodes have a truth pose within
// `match_tolerance_seconds` of their stamps; `truth_by_robot` maps a robot id to its
// world_T_body truth in stamp order (one world for all robots). Order: LoopClosures()'.
std::vector<ConstraintTruthError> ConstraintTruthErrors(
    const SubmapGraph& graph, const std::map<int, std::vector<StampedPose2>>& truth_by_robot,
    double match_tolerance_seconds = 1e-3);

// Summary of some of them: count, median and largest translation (claimed_translation_meters)
// and rotation error, and the mean signed rotation error (a matching bias; 0 for none).
struct ConstraintTruthSummary {
  int count = 0;
  double median_translation_meters = 0.0;
  double max_translation_meters = 0.0;
  double median_rotation_degrees = 0.0;  // of |rotation|
  double max_rotation_degrees = 0.0;
  double mean_signed_rotation_degrees = 0.0;
};
ConstraintTruthSummary SummarizeConstraintTruth(const std::vector<ConstraintTruthError>& errors);

// One line a constraint (header comment first): robots by `robot_names` (index = robot id; the
// id itself when it has no name), kind, submap, node, stamp, score, error x y (m, n's frame)
// theta (rad), the submap's aligned nodes and fit rmse, removed. Written through a temporary
// file (no truncated output); an error names the path.
Status WriteConstraintTruthErrors(const std::string& path, const std::vector<ConstraintTruthError>& errors,
                                  const std::vector<std::string>& robot_names);

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_CONSTRAINT_TRUTH_H_
