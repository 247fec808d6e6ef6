// The kinds of edge of a planar pose graph, shared by the plain graph data of core/
// (core/g2o_io.h labels the edges it reads) and the solver of factors/ (factors/
// pose_graph_problem.h picks each edge's cost and robust loss by its kind):
//   kSequential   between consecutive poses of one robot (odometry, scan matching, a node in
//                 the submap it was inserted into): the backbone of the graph; never a robust
//                 loss (factors/relative_pose_cost.h says why).
//   kLoopClosure  a revisit inside one robot's graph: may be wrong, so it gets a robust loss.
//   kInterRobot   between poses of two robots: a robust loss, as loop closures.
#ifndef HETSLAM_CORE_EDGE_KIND_H_
#define HETSLAM_CORE_EDGE_KIND_H_

namespace hetslam {

enum class EdgeKind { kSequential = 0, kLoopClosure = 1, kInterRobot = 2 };
const char* EdgeKindName(EdgeKind kind);  // "sequential", "loop closure", "inter-robot"

}  // namespace hetslam

#endif  // HETSLAM_CORE_EDGE_KIND_H_
