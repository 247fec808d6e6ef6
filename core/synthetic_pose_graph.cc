#include "core/synthetic_pose_graph.h"

#include <cmath>
#include <map>
#include <random>
#include <string>
#include <utility>

#include "glog/logging.h"

namespace hetslam {

bool ManhattanGraphOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  // Upper limits keep memory and time bounded (and the lattice in int range): the standard
  // benchmark graphs have 3500 (M3500) to 10000 (City10000) poses.
  if (num_poses < 2 || num_poses > kMaxPoses) {
    return fail("num_poses must be in [2, " + std::to_string(kMaxPoses) + "], got " + std::to_string(num_poses));
  }
  if (!(step_meters > 0.0) || !std::isfinite(step_meters)) return fail("step_meters must be > 0");
  if (block_steps < 1 || block_steps > 1000) return fail("block_steps must be in [1, 1000]");
  if (half_extent_blocks < 1 || half_extent_blocks > 10000) return fail("half_extent_blocks must be in [1, 10000]");
  if (!(step_meters <= 1e3)) return fail("step_meters must be <= 1000");
  if (!(turn_probability >= 0.0 && turn_probability <= 1.0)) {
    return fail("turn_probability must be in [0, 1]");
  }
  if (!(loop_closure_probability >= 0.0 && loop_closure_probability <= 1.0)) {
    return fail("loop_closure_probability must be in [0, 1]");
  }
  if (max_loop_closures_per_pose < 0 || max_loop_closures_per_pose > 100) {
    return fail("max_loop_closures_per_pose must be in [0, 100]");
  }
  if (min_loop_separation_poses < 2) return fail("min_loop_separation_poses must be >= 2");
  if (!(translation_stddev_meters > 0.0) || !std::isfinite(translation_stddev_meters)) {
    return fail("translation_stddev_meters must be > 0");
  }
  if (!(rotation_stddev_radians > 0.0) || !std::isfinite(rotation_stddev_radians)) {
    return fail("rotation_stddev_radians must be > 0");
  }
  return true;
}

SyntheticPoseGraph2d GenerateManhattanPoseGraph2d(const ManhattanGraphOptions& options,
                                                  uint32_t seed) {
  std::string error;
  CHECK(options.IsValid(&error)) << "invalid ManhattanGraphOptions: " << error;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);

  // Ground truth on an integer lattice: cell (ix, iy), heading index 0..3 (0 = +x, CCW).
  const int kDx[4] = {1, 0, -1, 0};
  const int kDy[4] = {0, 1, 0, -1};
  const int limit = options.half_extent_blocks * options.block_steps;
  auto inside = [limit](int x, int y) { return std::abs(x) <= limit && std::abs(y) <= limit; };
  std::vector<std::pair<int, int>> cells;
  std::vector<int> headings;
  int ix = 0, iy = 0, heading = 0;
  cells.emplace_back(ix, iy);
  headings.push_back(heading);
  for (int k = 1; k < options.num_poses; ++k) {
    const bool at_intersection =
        ix % options.block_steps == 0 && iy % options.block_steps == 0;
    if (at_intersection && uniform(rng) < options.turn_probability) {
      heading = (heading + (uniform(rng) < 0.5 ? 1 : 3)) % 4;
    }
    // Turn away from the boundary: left, right, then back (always possible on the lattice).
    if (!inside(ix + kDx[heading], iy + kDy[heading])) {
      const int first = uniform(rng) < 0.5 ? 1 : 3;
      for (const int turn : {first, 4 - first, 2}) {
        const int h = (heading + turn) % 4;
        if (inside(ix + kDx[h], iy + kDy[h])) {
          heading = h;
          break;
        }
      }
    }
    ix += kDx[heading];
    iy += kDy[heading];
    cells.emplace_back(ix, iy);
    headings.push_back(heading);
  }

  SyntheticPoseGraph2d result;
  std::vector<Pose2>& truth = result.world_T_vertex_true;
  for (int k = 0; k < options.num_poses; ++k) {
    truth.emplace_back(cells[k].first * options.step_meters, cells[k].second * options.step_meters,
                       headings[k] * (M_PI / 2.0));
  }

  const double st = options.translation_stddev_meters;
  const double sr = options.rotation_stddev_radians;
  Eigen::Matrix3d information = Eigen::Vector3d(1.0 / (st * st), 1.0 / (st * st), 1.0 / (sr * sr))
                                    .asDiagonal();
  auto noisy = [&](const Pose2& exact) {
    return Pose2(exact.x() + st * normal(rng), exact.y() + st * normal(rng),
                 exact.theta() + sr * normal(rng));
  };
  auto measure = [&](int from, int to, EdgeKind kind) {
    PoseGraph2dEdge edge;
    edge.id_from = from;
    edge.id_to = to;
    edge.kind = kind;
    const Pose2 exact = Between(truth[from], truth[to]);
    edge.from_T_to_measured = options.add_measurement_noise ? noisy(exact) : exact;
    edge.information = information;
    return edge;
  };

  PoseGraph2d& graph = result.graph;
  // Odometry edges and the dead-reckoned initial estimate. With exact edges the estimate still
  // drifts: it composes an independent noisy copy of each odometry step.
  Pose2 estimate = truth[0];
  graph.vertices.push_back({0, estimate});
  std::map<std::pair<int, int>, std::vector<int>> poses_in_cell;
  poses_in_cell[cells[0]].push_back(0);
  for (int k = 1; k < options.num_poses; ++k) {
    const PoseGraph2dEdge odometry = measure(k - 1, k, EdgeKind::kSequential);
    graph.edges.push_back(odometry);
    const Pose2 step = options.add_measurement_noise ? odometry.from_T_to_measured
                                                     : noisy(odometry.from_T_to_measured);
    estimate = estimate * step;
    graph.vertices.push_back({k, estimate});

    // Loop closures to earlier visits of this cell, oldest first.
    int added = 0;
    std::vector<int>& earlier = poses_in_cell[cells[k]];
    for (const int j : earlier) {
      if (added >= options.max_loop_closures_per_pose) break;
      if (k - j < options.min_loop_separation_poses) continue;
      if (uniform(rng) < options.loop_closure_probability) {
        graph.edges.push_back(measure(j, k, EdgeKind::kLoopClosure));
        ++added;
      }
    }
    earlier.push_back(k);
  }
  return result;
}

}  // namespace hetslam
