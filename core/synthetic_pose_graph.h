// Seeded synthetic 2D pose graphs with a known ground truth, in the style of Olson's
// "Manhattan world" benchmark graph: a robot walks a street grid one step per pose, turning only
// at intersections, and every revisit of a lattice cell may add a loop closure to an earlier pose
// in that cell. Used by the pose-graph tests, the benchmark and `hetslam_posegraph
// --generate_manhattan`.
//
// Known optimum: with add_measurement_noise = false every edge equals the true relative pose, so
// the ground truth (with the first vertex fixed at its true pose) has zero cost and is the
// global optimum; the initial estimate is still dead reckoning through noisy odometry. With
// noise, the edges are truth perturbed by the stated standard deviations (in the frame of the
// edge's first vertex), and the information of every edge is the matching inverse covariance.
#ifndef HETSLAM_CORE_SYNTHETIC_POSE_GRAPH_H_
#define HETSLAM_CORE_SYNTHETIC_POSE_GRAPH_H_

#include <cstdint>
#include <string>
#include <vector>

#include "core/g2o_io.h"
#include "core/se2.h"

namespace hetslam {

struct ManhattanGraphOptions {
  static constexpr int kMaxPoses = 100000;  // IsValid's upper limit of num_poses
  int num_poses = 1000;
  double step_meters = 1.0;                // distance between consecutive poses
  int block_steps = 5;                     // steps between intersections
  int half_extent_blocks = 3;              // the walk stays in [-h, h]^2 blocks around the start
  double turn_probability = 0.5;           // chance to turn at an intersection
  double loop_closure_probability = 0.3;   // chance per eligible earlier pose in the same cell
  int max_loop_closures_per_pose = 2;
  int min_loop_separation_poses = 10;      // no closures to the last few poses
  double translation_stddev_meters = 0.05;  // edge noise model, per axis
  double rotation_stddev_radians = 0.01;    // edge noise model
  // false: edges are exact (known optimum = truth); the initial estimate still drifts.
  bool add_measurement_noise = true;

  bool IsValid(std::string* error) const;
};

struct SyntheticPoseGraph2d {
  PoseGraph2d graph;                         // vertices hold the dead-reckoned initial estimate
  std::vector<Pose2> world_T_vertex_true;    // index = vertex id = index in graph.vertices
};

// Vertex ids are 0..num_poses-1; edges (k, k+1) are odometry (kind kSequential), the others
// loop closures (kLoopClosure), as the g2o reader would label them.
// Deterministic for a given (options, seed). CHECK-fails on invalid options.
SyntheticPoseGraph2d GenerateManhattanPoseGraph2d(const ManhattanGraphOptions& options,
                                                  uint32_t seed);

}  // namespace hetslam

#endif  // HETSLAM_CORE_SYNTHETIC_POSE_GRAPH_H_
