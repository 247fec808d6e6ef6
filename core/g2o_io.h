// Planar pose graphs in the g2o text format (the format of the standard 2D SLAM benchmark
// graphs: Manhattan M3500, Intel, FR079, ...). Plain data here: core/ knows no Ceres; the solver
// that optimises a PoseGraph2d lives in factors/pose_graph_2d.h.
//
// Lines read and written (white-space separated, one record per line):
//   VERTEX_SE2 id x y theta
//       world_T_vertex, metres, metres, radians.
//   EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33
//       from_T_to_measured = i_T_j (pose of vertex j in the frame of vertex i) and the upper
//       triangle of its 3x3 information matrix (inverse covariance; 1/m^2, 1/(m rad), 1/rad^2)
//       for the error E = i_T_j_measured^-1 * i_T_j_estimated, [E_x, E_y, E_theta]; this is
//       g2o's EDGE_SE2 convention and the error of factors/relative_pose_cost.h.
//   FIX id [id ...]
//       vertices held constant during optimisation.
// Edge kinds (core/edge_kind.h): g2o files carry none, so the reader applies the convention of
// the standard benchmark graphs, whose vertex ids number the poses in travel order: an edge
// between consecutive ids (|i - j| == 1) is kSequential, any other edge kLoopClosure. The writer
// stores no kind either: reading a written graph labels its edges by that convention again.
// Blank lines and lines starting with '#' are skipped. Anything else, a wrong field count, a
// non-finite or non-numeric field, a duplicated vertex id, an edge from a vertex to itself or to
// an undefined vertex, an information matrix that is not positive definite (its Cholesky factor
// must be finite with a positive diagonal), positions or edge translations beyond +-1e9 m and
// information entries beyond +-1e18 are errors whose message names the file and the line
// ("graph.g2o:12: ...").
#ifndef HETSLAM_CORE_G2O_IO_H_
#define HETSLAM_CORE_G2O_IO_H_

#include <istream>
#include <ostream>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/edge_kind.h"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

struct PoseGraph2dVertex {
  int id = 0;
  Pose2 world_T_vertex;  // metres, radians
};

struct PoseGraph2dEdge {
  int id_from = 0;
  int id_to = 0;
  Pose2 from_T_to_measured;  // pose of vertex id_to in the frame of vertex id_from
  // Symmetric positive definite information (inverse covariance) of the edge error; rows and
  // columns in (x metres, y metres, theta radians).
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  // Decides the robust loss (factors/pose_graph_2d.h). Whoever builds an edge sets it; the g2o
  // reader applies the id convention above.
  EdgeKind kind = EdgeKind::kSequential;
};

struct PoseGraph2d {
  std::vector<PoseGraph2dVertex> vertices;  // in file order
  std::vector<PoseGraph2dEdge> edges;       // in file order
  std::vector<int> fixed_vertex_ids;        // from FIX lines, in file order
};

// Reads `path` (replaces *graph). Errors name the file and line.
Status ReadG2oPoseGraph2d(const std::string& path, PoseGraph2d* graph);

// Same, from a stream; `source_name` stands for the file name in error messages.
Status ParseG2oPoseGraph2d(std::istream& input, const std::string& source_name,
                           PoseGraph2d* graph);

// Writes vertices, then edges, then one FIX line (if any), at full double precision
// (17 significant digits: values read back equal to rounding; theta is re-wrapped by Pose2).
// An error names the file.
Status WriteG2oPoseGraph2d(const std::string& path, const PoseGraph2d& graph);
void WriteG2oPoseGraph2d(const PoseGraph2d& graph, std::ostream* output);

}  // namespace hetslam

#endif  // HETSLAM_CORE_G2O_IO_H_
