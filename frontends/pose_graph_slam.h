// Single-robot SLAM with submaps, loop closure and an incrementally solved Ceres pose graph
// (paper §III-A "loop closure ... by scan-matching" within a bounded window, DESIGN.md item 7).
//
// Front end. Scans are matched (frontends/scan_matcher.h) against the older of the (up to)
// two active submaps, in the front end's own drifting "local" frame, and inserted into both.
// A submap is a LaserMap in its own frame, that of the local pose of its first scan; a new one
// starts every scans_per_submap / 2 scans, and a submap is finished (frozen) after
// scans_per_submap scans.
//
// Graph. Variables: world_T_submap_s for every submap and world_T_node_i for every inserted
// scan (node), [x, y, yaw] blocks with the Se2Manifold. Constraints (factors/relative_pose_cost.h):
//   intra-submap  s_T_i = local_T_s^-1 * local_T_i   for each submap s that node i entered
//                 (no robust loss: the backbone);
//   loop closure  s_T_i measured by matching node i's scan against finished submap s (at least
//                 `loop_min_node_separation` scans old) inside ±loop window around the graph's
//                 current estimate, narrowed to the drift gate; accepted above a score,
//                 added with a Huber loss, and removed again if, after the solve, the graph
//                 disagrees with it by more than the consistency bounds.
// Gauge: the first submap is held constant (the world frame is the start pose).
//
// Solving: once `solve_every_n_loop_closures` closures were accepted and `solve_min_new_nodes`
// scans added since the last solve (and at Finish()), a warm-started Ceres solve with bounded
// iterations, single-threaded, nodes eliminated first (SPARSE_SCHUR over the submaps) in a
// fixed order: the same input gives the same output, also for repeated runs in one process.
// New nodes enter the graph through the latest world_T_local correction.
#ifndef HETSLAM_FRONTENDS_POSE_GRAPH_SLAM_H_
#define HETSLAM_FRONTENDS_POSE_GRAPH_SLAM_H_

#include <array>
#include <cmath>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/g2o_io.h"
#include "core/laser_map.h"
#include "core/laser_scan.h"
#include "core/se2.h"
#include "core/trajectory_io.h"
#include "frontends/scan_matcher.h"
#include "frontends/scan_matching_slam.h"

namespace ceres {
class Problem;
class Manifold;
class ResidualBlock;
}  // namespace ceres

namespace hetslam {

struct PoseGraphSlamOptions {
  // Front end (matching against the active submap): grid, field, matcher, prediction, points.
  ScanMatchingSlamOptions local;
  int scans_per_submap = 40;
  // Loop closure search: window around the graph's estimate of the node in the submap.
  ScanMatcherOptions loop_matcher = DefaultLoopMatcherOptions();
  double loop_min_score = 0.55;             // mean likelihood at the refined pose
  double loop_search_min_travel_meters = 0.3;  // search again only after moving this far
  double loop_search_min_turn_radians = 0.35;  // ... or turning this much
  // Submaps whose last scan is fewer than this many nodes old are not searched.
  int loop_min_node_separation = 40;
  // Constraint uncertainties (1 sigma) and the loop closure loss scale (in sigmas).
  double intra_translation_sigma_meters = 0.02;
  double intra_rotation_sigma_radians = 0.005;
  double loop_translation_sigma_meters = 0.05;
  double loop_rotation_sigma_radians = 0.01;
  // Huber: quadratic within this many sigmas, linear beyond, so a closure far from the current
  // estimate still pulls (drift correction) but with bounded force.
  double loop_loss_scale = 3.0;
  // After a solve, a loop closure the graph disagrees with by more than this is removed.
  double loop_consistency_translation_meters = 0.3;
  double loop_consistency_rotation_radians = 0.06;
  // Gate against aliasing (corridors, repeated rooms): a closure is accepted only if it
  // moves the node by at most base + rate * (distance travelled since the graph was last
  // optimised) from the graph's estimate: drift grows with travel, aliases need not.
  double loop_gate_base_meters = 0.3;
  double loop_gate_meters_per_meter = 0.1;
  double loop_gate_base_radians = 0.1;
  double loop_gate_radians_per_meter = 0.02;
  // Wide search (issue: "a wider branch-and-bound search when the pose uncertainty grows past
  // that window", long corridors). The drift bound above grows with the travel since the last
  // solve; once it exceeds the loop window and the standard search found nothing, the node is
  // also searched over ±min(drift bound, loop_wide_window_meters) and ±min(angular bound,
  // loop_wide_angular_window_radians), without motion prior, at most once per
  // loop_wide_search_spacing_meters of travel. A wide result (score >= loop_wide_min_score,
  // within the drift bound) is only a candidate until a wide result of a later node confirms
  // it: their corrections of the graph's estimate (world frame) agree within
  // loop_wide_agreement_*; then both enter the graph as loop closures (no robust loss), else
  // the later result becomes the candidate. An accepted ordinary closure drops the candidate.
  bool loop_wide_search = true;
  ScanMatcherOptions loop_wide_matcher = DefaultLoopWideMatcherOptions();
  double loop_wide_window_meters = 8.0;
  double loop_wide_angular_window_radians = M_PI;
  double loop_wide_min_score = 0.6;
  double loop_wide_search_spacing_meters = 1.0;
  double loop_wide_agreement_meters = 0.3;
  double loop_wide_agreement_radians = 0.05;
  int solve_every_n_loop_closures = 10;
  // ... but not before this many nodes were added since the last solve (bounds the solves of
  // dense logs, where closures arrive at almost every scan).
  int solve_min_new_nodes = 20;
  int max_iterations_per_solve = 10;
  int max_iterations_final = 50;
  bool loop_closure = true;

  static ScanMatcherOptions DefaultLoopMatcherOptions();
  static ScanMatcherOptions DefaultLoopWideMatcherOptions();
  bool IsValid(std::string* error) const;
};

struct PoseGraphSlamStats {
  int scans = 0;
  int nodes = 0;
  int submaps = 0;
  int skipped_too_few_points = 0;
  int match_failures = 0;
  int timestamps_backwards = 0;
  long long floor_points = 0;     // end points removed as floor hits (scans with an attitude)
  int degenerate_matches = 0;     // front-end matches whose weak direction kept the prediction
  int loop_searches = 0;          // (node, submap) matches attempted
  int loop_closures_accepted = 0;
  int loop_closures_rejected_after_solve = 0;
  int loop_closures_rejected_by_gate = 0;
  int loop_wide_searches = 0;              // (node, submap) matches over the wide window
  int loop_wide_candidates = 0;            // wide results above the score, within the bound
  int loop_closures_accepted_wide = 0;     // confirmed wide candidates (counted in accepted too)
  int solves = 0;
  int solver_iterations = 0;      // summed over all solves
  double solve_seconds = 0.0;
  double loop_search_seconds = 0.0;
};

// One accepted loop closure, for precision reports: the measured submap_T_node and what the
// final graph says.
struct LoopClosureReport {
  int submap = 0;
  int node = 0;
  double score = 0.0;
  Pose2 measured_submap_T_node;
  Pose2 final_submap_T_node;
  bool removed = false;
};

class PoseGraphSlam {
 public:
  explicit PoseGraphSlam(const PoseGraphSlamOptions& options);
  ~PoseGraphSlam();
  PoseGraphSlam(const PoseGraphSlam&) = delete;
  PoseGraphSlam& operator=(const PoseGraphSlam&) = delete;

  // Processes one scan; `odometry_pose` and `attitude` as in ScanMatchingSlam::AddScan.
  void AddScan(const LaserScan& scan, const std::optional<Pose2>& odometry_pose = std::nullopt,
               const std::optional<BodyAttitude>& attitude = std::nullopt);

  // Adds a loop-closure constraint from outside the loop-closure search (a place recognised
  // by other means, a fiducial): `submap_T_node` is node `node`'s pose in submap `submap`'s
  // frame. It is treated like a found closure: robust loss, consistency check after solves.
  // Returns false (and adds nothing) for an unknown submap or node.
  bool AddLoopClosure(int submap, int node, const Pose2& submap_T_node, double score);
  // Solves now (bounded iterations as for incremental solves).
  void SolveNow() { Solve(options_.max_iterations_per_solve); }
  int num_nodes() const;
  int num_submaps() const;

  // Final solve; then trajectory() holds the optimised poses. Idempotent.
  void Finish();

  // Optimised world poses of all nodes (after Finish(): final; before: current estimate).
  std::vector<StampedPose2> trajectory() const;
  // The front end's (drifting, never corrected) poses.
  std::vector<StampedPose2> local_trajectory() const;
  // An occupancy grid of every scan inserted at its optimised pose (built on demand; grid
  // options and border as the submaps' LaserMaps, without their likelihood field, which
  // rendering does not need and which would cost more than the grid).
  std::unique_ptr<OccupancyGrid> RenderMap() const;
  // The pose graph (submaps then nodes as vertices; intra then loop edges), for g2o export.
  PoseGraph2d ExportGraph() const;
  std::vector<LoopClosureReport> LoopClosures() const;

  const PoseGraphSlamStats& stats() const { return stats_; }
  const PoseGraphSlamOptions& options() const { return options_; }

 private:
  struct Node;
  struct Submap;
  struct Constraint;

  // A new [x, y, yaw] block, at an address above all earlier ones (see the .cc).
  double* AllocatePoseBlock(const Pose2& pose);
  void AddNodeToGraph(Node* node, const std::vector<int>& submap_indices);
  void SearchLoopClosures(int node_index);
  // A wide-search result waiting for confirmation (see loop_wide_search).
  struct WideCandidate {
    int node = -1;
    int submap = -1;
    Pose2 submap_T_node;
    Pose2 world_correction;  // matched world pose relative to the graph's estimate, world frame
    double score = 0.0;
  };
  // Matches node `node_index` against every finished, old-enough submap whose box (grown by
  // `margin_meters`) holds its estimate; adds closures scoring >= min_score within the gate.
  // Returns how many were added. With `wide_best`: uses the wide matcher and only keeps the
  // best result in *wide_best (nothing is added; returns 0).
  int SearchSubmaps(int node_index, double linear_window, double angular_window, double gate_meters,
                    double gate_radians, double min_score, double margin_meters,
                    std::optional<WideCandidate>* wide_best = nullptr);
  // The wide search of one node; confirms the pending candidate or replaces it.
  void WideSearch(int node_index, double gate_meters, double gate_radians);
  void AddLoopConstraint(int submap, int node, const Pose2& submap_T_node, double score, bool robust = true);
  void Solve(int max_iterations);
  void UpdateWorldFromLocal();

  PoseGraphSlamOptions options_;
  ScanMatcher local_matcher_;
  ScanMatcher loop_matcher_;
  ScanMatcher loop_wide_matcher_;
  std::vector<std::unique_ptr<double[]>> pose_block_chunks_;
  size_t pose_blocks_used_in_chunk_ = 0;
  std::deque<Node> nodes_;
  std::deque<Submap> submaps_;
  std::deque<Constraint> constraints_;
  std::vector<int> active_submaps_;   // indices, oldest first
  std::unique_ptr<ceres::Manifold> manifold_;
  std::unique_ptr<ceres::Problem> problem_;
  Pose2 world_T_local_;
  std::vector<StampedPose2> local_trajectory_;
  std::optional<Pose2> last_odometry_;
  std::optional<Pose2> last_search_pose_;
  int loop_closures_since_solve_ = 0;
  int nodes_since_solve_ = 0;
  double travel_since_solve_meters_ = 0.0;
  double travel_since_wide_search_meters_ = 0.0;
  std::optional<WideCandidate> pending_wide_;
  bool finished_ = false;
  PoseGraphSlamStats stats_;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_POSE_GRAPH_SLAM_H_
