// The submap pose graph of one robot or a team (paper §III-A loop closure, DESIGN.md
// "submap graph"; Cartographer's PoseGraph2D::AddNode(data, trajectory_id, submaps) shape).
//
// Variables (factors/pose_graph_problem.h): for every robot r, robot_T_submap for each of its
// submaps and robot_T_node for each inserted scan (node), in r's own frame (its first submap's
// frame: the world frame for a lone robot); per robot one anchor world_T_r, created when the
// first inter-robot constraint reaches r.
// Constraints, all submap_T_node, each carrying its kind:
//   intra-submap  (sequential) from the LocalResult: the node's pose in each submap it entered;
//                 no robust loss: the backbone;
//   loop closure  a node matched against a finished submap of its own robot (LoopCloser, a
//                 fiducial): Huber loss unless the candidate says otherwise;
//   inter-robot   a node of one robot against a submap of another: the anchored cost.
// Gauge: each robot's first submap is held constant in its own frame; the first robot's
// anchor is held constant at identity (its frame is the team's world).
//
// Revisits (AttachRevisits): the nodes of retired submaps leave the problem and ride on their
// submap; constraints between submaps (a chain, closure summaries) stand in for theirs.
// Solve(): a warm-started, bounded, single-threaded, deterministic Ceres solve (nodes
// eliminated first, SPARSE_SCHUR over submaps and anchors), then a consistency check that
// removes loop closures the graph disagrees with (and solves once more). New nodes enter
// through their robot's latest local -> robot-frame correction.
#ifndef HETSLAM_FRONTENDS_SUBMAP_GRAPH_H_
#define HETSLAM_FRONTENDS_SUBMAP_GRAPH_H_

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/g2o_io.h"
#include "core/laser_map.h"
#include "core/occupancy_grid.h"
#include "core/se2.h"
#include "core/status.h"
#include "core/trajectory_io.h"
#include "factors/pose_graph_problem.h"
#include "frontends/local_slam.h"

namespace hetslam {

struct NodeId {
  int robot = 0;
  int index = 0;  // in the robot's insertion order
  bool operator==(const NodeId& o) const { return robot == o.robot && index == o.index; }
  bool operator!=(const NodeId& o) const { return !(*this == o); }
};
struct SubmapId {
  int robot = 0;
  int index = 0;  // the robot's submap number (LocalResult)
  bool operator==(const SubmapId& o) const { return robot == o.robot && index == o.index; }
};

struct SubmapGraphOptions {
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
  // The largest standard deviation of a degenerate closure along its weak direction
  // (ConstraintCandidate::weak_direction: a corridor, where the match cannot place the node
  // along the walls); the consistency check looks only across that direction.
  double loop_weak_translation_sigma_meters = 2.0;
  // RenderMap's structure (and so the walls and planner layers drawn from it) drops the noise
  // tail behind surfaces: occupied cells hit fewer times than this share of a neighbour they
  // lie behind (OccupancyGrid::DropWeakOccupiedCells). Only the rendered maps: the submaps
  // that scans and loop closures are matched against keep every cell. 0 keeps every cell.
  // In [0, 1].
  double map_min_hit_share = 0.2;
  // RenderMap's walls layer keeps only pieces of wall at least this long (the diagonal of a
  // piece's bounding box; cells two apart join one piece): a wall is a surface, while a table
  // leg or a post is hit at several heights as well (OccupancyGrid::DropSmallOccupiedPieces).
  // 0 keeps every piece. In [0, 100] metres.
  double wall_min_length_meters = 0.25;
  // What a node attached to a retired submap (AttachRevisits) keeps for the rendered maps: its
  // points (with their labels and heights) only when it lies at least this far from, or turned
  // at least this much against, the last node of the same retired submap that kept them (the
  // group's first keeps them; a bound of 0 does not count); the others keep their pose and
  // floor obstacles. Re-driving mapped space then costs a scan's points per so much travel, not
  // per scan (FR079: 1940 of 4403 scans re-drive, ~800 bytes of points each; 1409 release
  // them). Both 0: every attached node keeps its points. Travel in [0, 1000] m, turn in
  // [0, 2 pi].
  double revisit_points_min_travel_meters = 0.5;
  double revisit_points_min_turn_radians = 0.26179938779914941;  // 15°

  bool IsValid(std::string* error) const;
};

// A constraint proposed for the graph (a loop closure found by the LoopCloser, a place
// recognised by other means, an inter-robot match).
struct ConstraintCandidate {
  SubmapId submap;
  NodeId node;
  Pose2 submap_T_node;
  double score = 0.0;
  bool robust = true;  // Huber loss (else none: a confirmed correction of metres)
  // Not checked for consistency by the solve that first includes it (see LoopCloser's wide
  // search); checked from the next solve on.
  bool exempt_from_next_check = false;
  // Unit, in the submap's frame, when the match placed the node poorly along it (its score's
  // profile is flat there: ScanMatchResult::weak_direction); zero otherwise. Along it the
  // constraint's information is `weak_information_fraction` of the loop closure's (the ratio
  // of the score's drops along the weak and the strong direction: its curvatures), so its
  // standard deviation is loop_translation_sigma_meters / sqrt(fraction), at most
  // SubmapGraphOptions::loop_weak_translation_sigma_meters.
  Eigen::Vector2d weak_direction = Eigen::Vector2d::Zero();
  double weak_information_fraction = 1.0;
};

// One accepted loop-closure or inter-robot constraint, for precision reports: the measured
// submap_T_node and what the graph says now.
struct LoopClosureReport {
  SubmapId submap;
  NodeId node;
  EdgeKind kind = EdgeKind::kLoopClosure;
  double score = 0.0;
  Pose2 measured_submap_T_node;
  Pose2 estimated_submap_T_node;
  bool removed = false;
  Eigen::Vector2d weak_direction = Eigen::Vector2d::Zero();  // submap frame; see ConstraintCandidate
  double weak_information_fraction = 1.0;
};

// Whether the graph agrees with a closure to `meters` and `radians` (Cartographer's loop
// closure precision uses 0.2 m and 1°): the measured and estimated submap_T_node, compared
// only across the weak direction of a degenerate closure.
bool ClosureAgrees(const LoopClosureReport& loop, double meters, double radians);

struct SubmapGraphStats {
  int nodes = 0;
  int submaps = 0;
  int loop_closures_accepted = 0;
  int loop_closures_rejected_after_solve = 0;
  int inter_robot_constraints = 0;
  int inter_robot_constraints_withdrawn = 0;  // by RemoveInterRobotConstraint
  int submaps_evicted = 0;                    // by EvictSubmapMap for the map store's bound
  size_t evicted_bytes = 0;                   // their maps' MemoryBytes
  int submaps_retired = 0;                    // by EvictSubmapMap: revisits of mapped space
  size_t retired_bytes = 0;                   // their maps' MemoryBytes
  // By AttachRevisits: nodes taken out of the problem (attached to their submap), the loop
  // closures released with them, and the constraints between submaps added in their place.
  int nodes_attached = 0;
  int nodes_points_released = 0;  // of those, the nodes whose points were freed (see
                                  // SubmapGraphOptions::revisit_points_min_travel_meters)
  size_t points_released_bytes = 0;
  int closures_released = 0;
  int revisit_summaries = 0;
  int solves = 0;            // Ceres solves (a Solve() call may run two)
  int solver_iterations = 0;
  int failed_solves = 0;     // solutions Ceres reported unusable (poses kept)
  double solve_seconds = 0.0;
};

class SubmapGraph {
 public:
  // CHECK-fails on invalid options (validate user input with IsValid first).
  explicit SubmapGraph(const SubmapGraphOptions& options);

  // Adds the node of an inserted scan (result.inserted must be true) with its intra-submap
  // constraints, the submaps the scan started, and the map of a submap it finished.
  NodeId AddNode(int robot, LocalResult result);
  // Adds a loop closure (same robot) or an inter-robot constraint (different robots). Returns
  // false and adds nothing for an unknown submap or node.
  bool AddConstraint(const ConstraintCandidate& candidate);
  // The node's intra-submap constraint into `submap` (its pose there as the front end inserted
  // it): false when the node did not enter that submap.
  bool IntraSubmapPose(const NodeId& node, const SubmapId& submap, Pose2* submap_T_node) const;
  // The robot's frame is its first node's (its body at its first scan). Replaces the first
  // node's constraint into the robot's first submap by `submap_T_node` (e.g. its scan matched
  // against the finished submap) and moves everything else of the robot rigidly (submaps,
  // nodes, the local -> robot correction) so that the first node keeps its pose: the map turns
  // around the first scan instead of the first scan within the map. Only before the robot's
  // first inter-robot constraint (its anchor would have to move too); false, changing nothing,
  // then, or when the robot has no such node or constraint.
  bool ReviseFirstNodeInFirstSubmap(int robot, const Pose2& submap_T_node);
  // Removes the inter-robot constraint between `submap` and `node` (a link found wrong later,
  // e.g. by a teammate's contradicting landmark); it is then reported removed by LoopClosures().
  // False when the graph holds no such constraint (or it was removed already).
  bool RemoveInterRobotConstraint(const SubmapId& submap, const NodeId& node);
  // Solves; an error when Ceres reports the solution unusable (the poses keep their values).
  Status Solve(int max_iterations);

  // Queries. Poses are in the robot's own frame (RobotPose...) or in the world (anchor applied).
  int num_robots() const { return static_cast<int>(robots_.size()); }
  bool HasRobot(int robot) const { return robots_.count(robot) > 0; }
  int num_nodes(int robot) const;
  int num_submaps(int robot) const;
  Pose2 NodePose(const NodeId& node) const;      // robot frame
  Pose2 SubmapPose(const SubmapId& submap) const;  // robot frame
  Pose2 LocalToRobot(int robot) const;             // latest local -> robot frame correction
  Pose2 Anchor(int robot) const;                   // world_T_robot (identity before any link)
  // Sets `robot`'s anchor world_T_robot (creating it if needed): the starting value of the next
  // solve, e.g. a relative pose from a shared landmark (merger/team_estimator.h) given before
  // the robot's first inter-robot constraint, which would otherwise start it at identity.
  // Returns false, changing nothing, for an unknown robot or the world robot (its anchor is held
  // constant at identity).
  bool SetAnchorEstimate(int robot, const Pose2& world_T_robot);
  // The robot whose anchor is the team's world: the first robot that added a node (-1 before).
  int world_robot() const { return first_robot_; }
  double NodeStamp(const NodeId& node) const;
  // A node's matching points (ScanPoints::matching, robot frame) and their weights (empty:
  // every weight 1), as the LocalResult gave them (a copy: the graph keeps them compactly).
  struct MatchingPoints {
    std::vector<Eigen::Vector2f> points;
    std::vector<float> weights;
    // With `with_all_points`: every point the matching points were thinned from (a refinement's
    // points, LocalSlamOptions::refine_on_all_points); empty when the node has matching weights
    // or matching points that are not a subset of its points.
    std::vector<Eigen::Vector2f> all;
  };
  MatchingPoints NodeMatchingPoints(const NodeId& node, bool with_all_points = false) const;
  const Pose2& NodeLocalPose(const NodeId& node) const;
  // A finished submap's map (null while it is active, and once evicted) and the box of its
  // nodes' positions in its own frame; the index of the last node inserted into it.
  const LaserMap* FinishedSubmapMap(const SubmapId& submap) const;
  // Whether the submap was finished (its map may have been evicted since); false if unknown.
  bool SubmapFinished(const SubmapId& submap) const;
  // Frees a finished submap's map: its pose, nodes and constraints stay in the graph, and the
  // maps rendered from node points are unchanged, but it is no longer searched for loop
  // closures. Counted by `reason` (SubmapGraphStats). False (nothing done) for an unknown,
  // active or already evicted submap.
  enum class EvictionReason {
    kMapStoreBound,  // OnlineEstimatorOptions::max_map_store_bytes
    kRevisited,      // OnlineEstimatorOptions::retire_revisited_share
  };
  bool EvictSubmapMap(const SubmapId& submap, EvictionReason reason = EvictionReason::kMapStoreBound);
  // Revisits attach to the map they revisit (issue #15: no growth without new information).
  // Once both submaps a node of `robot` entered were retired (EvictSubmapMap kRevisited: earlier
  // submaps cover them), the nodes of the older one are decided together and leave the
  // problem: each rides rigidly on that submap at its current pose there (NodePose,
  // Trajectory; RenderMap still draws what it saw), its constraints and matching points
  // released. In their place come constraints between submaps, marginal summaries of what the
  // nodes' constraints said: per submap the nodes closed with, one closure (the closures'
  // information-weighted mean through the nodes' measured poses, their summed information,
  // Huber at sqrt(n) times the loop loss scale; not in LoopClosures(), never checked for
  // consistency), and one chain to the next submap (the front end's relative pose, the nodes'
  // summed information). Nodes with an inter-robot constraint stay as they are; so does one
  // node of a submap nothing else would tie. Call it after a Solve (the nodes' poses are then
  // the graph's best). Returns the number of nodes attached.
  int AttachRevisits(int robot);
  // Whether a node was attached by AttachRevisits (false if unknown).
  bool NodeAttached(const NodeId& node) const;
  // The share of `submap`'s occupied cells (every `sample_every`-th, in row order within its
  // field's tiles) at which one of `others` has structure within the likelihood field's sigma
  // (value >= exp(-1)) at the graph's current poses: how much of what it holds the others hold
  // too. Submaps of `others` without a map, or whose box cannot overlap, count for nothing.
  // -1 when `submap` has no map or no occupied cell.
  double CoveredShare(const SubmapId& submap, const std::vector<SubmapId>& others, int sample_every) const;
  // Heap bytes of `robot`'s finished submaps' maps (LaserMap::MemoryBytes); 0 for an unknown robot.
  size_t FinishedSubmapBytes(int robot) const;
  bool SubmapBox(const SubmapId& submap, Eigen::Vector2d* min, Eigen::Vector2d* max) const;
  // The first and the last node inserted into a known submap.
  int SubmapFirstNode(const SubmapId& submap) const;
  int SubmapLastNode(const SubmapId& submap) const;

  // Optimised poses of a robot's nodes, robot frame (attached nodes: where their submap puts them).
  std::vector<StampedPose2> Trajectory(int robot) const;
  // Scan points seen at a pose relative to a node (a scan that was not inserted, e.g. while
  // matching was suspended): rendered wherever the node's optimised pose puts them.
  struct AnchoredPoints {
    NodeId node;
    Pose2 node_T_scan;
    std::vector<Eigen::Vector2f> floor_obstacles;  // scan frame (drawn from their hits alone: RenderMap)
  };
  // Wall cells this close (cells, Chebyshev) join one piece of wall: a one-cell gap a sparse
  // scan leaves between hits does not split a wall (SubmapGraphOptions::wall_min_length_meters).
  static constexpr int kWallPieceLinkCells = 2;
  enum class Layer {
    kStructure,       // what localisation uses (map.pgm)
    kFloorObstacles,  // objects on the floor (paper §III-E)
    kPlanner,         // both: everything a planner must avoid
    kWalls,           // the structure points on wall cells (hit at several heights, paper §III-E)
  };
  // An occupancy grid of `robot`'s scans at their optimised poses (robot frame; or another
  // frame, the robot's at frame_T_robot in it: the scans rendered there, on that frame's cells,
  // not a rendered grid resampled): the layer's points of every node, and for floor obstacles
  // also those of `extra`.
  std::unique_ptr<OccupancyGrid> RenderMap(int robot, const OccupancyGridOptions& grid, Layer layer = Layer::kStructure,
                                           const std::vector<AnchoredPoints>& extra = {},
                                           const Pose2& frame_T_robot = Pose2::Identity()) const;
  // The graph of one robot: its submaps then its nodes as vertices, intra then loop edges.
  PoseGraph2d ExportGraph(int robot) const;
  std::vector<LoopClosureReport> LoopClosures() const;

  const SubmapGraphStats& stats() const { return stats_; }
  const SubmapGraphOptions& options() const { return options_; }

 private:
  // A node's points live as long as it is in the graph (FR079: 4395 nodes, the largest share of its
  // memory after the maps), kept compactly (FR079: ~1.1 KB a node with its 224-byte Node, was
  // ~1.3 KB with a whole ScanPoints, 384 bytes, in each):
  //  - all: each point rounded to the millimetre in 16-bit integers and delta-coded in `packed`
  //    (~2.5 bytes a point instead of 8) when every point is within 32.7 m of the robot (as with
  //    the default 30 m range), else as given; the node's points serve matches and maps on 5 cm
  //    cells. See DecodePoints.
  //  - matching: `matching_mask` when they are points of `all` in its order (the voxel filter
  //    keeps a voxel's first point; FR079: 48 bytes a scan instead of ~1.5 KB as points, ~380 as
  //    16-bit indices), see NodeMatchingPoints;
  //  - labels: none when every point has `uniform_label` (a CARMEN scan's are all structure);
  //  - what a plain 2D scan lacks (labels that differ, heights of a projected scan, floor
  //    obstacles, matching points that are not a subset of `all`, matcher weights) in one
  //    allocation, `rare`, absent when all of them are empty.
  // AttachRevisits releases the matching points (loop searches are done).
  static constexpr float kPointsPerMeter = 1000.f;
  static constexpr uint8_t kPackedEscape = 0x80;  // NodeScan::packed: a point in full follows
  // What a node saw (AttachRevisits releases the matching points; the rest is rendered).
  struct NodeScan {
    struct Rare {
      std::vector<PointLabel> labels;    // one per point of `all` (unless labels_uniform)
      std::vector<float> heights_meters; // one per point of `all` when projected
      std::vector<Eigen::Vector2f> floor_obstacles;
      std::vector<Eigen::Vector2f> matching;  // when matching_mask cannot hold them
      std::vector<float> matching_weights;
      bool empty() const {
        return labels.empty() && heights_meters.empty() && floor_obstacles.empty() && matching.empty() &&
               matching_weights.empty();
      }
    };
    // `all` to the millimetre when packed (num_packed > 0): each point as its difference from
    // the previous one (the first from 0) in 16-bit millimetres, two signed bytes when both
    // parts are within ±127 mm (neighbouring beams on a surface), else the byte 0x80 and the
    // point itself, x and y in 16 bits (5 bytes). FR079: ~2.5 bytes a point instead of 8.
    std::vector<uint8_t> packed;
    std::vector<Eigen::Vector2f> all;  // when not packed
    std::vector<uint64_t> matching_mask;  // bit k % 64 of word k / 64: point k of `all` matches
    std::unique_ptr<Rare> rare;
    Eigen::Vector2d sensor_robot = Eigen::Vector2d::Zero();
    uint32_t num_packed = 0;
    bool projected = false;
    bool labels_uniform = false;
    PointLabel uniform_label = PointLabel::kStructure;
    PointLabel Label(size_t k) const { return labels_uniform ? uniform_label : rare->labels[k]; }
    size_t num_points() const { return num_packed > 0 ? num_packed : all.size(); }
    // Frees the points with their labels, heights and matching points (the floor obstacles
    // stay); returns the bytes their buffers held.
    size_t ReleasePoints();
    // The rare parts (empty when absent).
    const std::vector<float>& heights_meters() const { return rare ? rare->heights_meters : NoFloats(); }
    const std::vector<Eigen::Vector2f>& floor_obstacles() const { return rare ? rare->floor_obstacles : NoPoints(); }
    const std::vector<Eigen::Vector2f>& matching() const { return rare ? rare->matching : NoPoints(); }
    const std::vector<float>& matching_weights() const { return rare ? rare->matching_weights : NoFloats(); }
    // Every point of `all`, in order, into `out` (replaced).
    void DecodePoints(std::vector<Eigen::Vector2f>* out) const;
    static const std::vector<float>& NoFloats();
    static const std::vector<Eigen::Vector2f>& NoPoints();
  };
  struct Node {
    double stamp_seconds = 0.0;
    Pose2 local_pose;
    int pose = -1;  // in problem_ (removed from it once attached)
    // Attached (AttachRevisits): the submap it rides on and its pose there; -1 while in the problem.
    int host = -1;
    Pose2 host_T_node;
    bool revisit_kept = false;        // decided by AttachRevisits: stays in the problem
    NodeScan scan;
  };
  struct Submap {
    int pose = -1;
    std::shared_ptr<const LaserMap> map;  // set when finished, reset when evicted
    bool finished = false;
    bool retired = false;       // evicted as a revisit (EvictionReason::kRevisited)
    bool revisit_done = false;  // its nodes decided by AttachRevisits
    int first_node = -1;
    int last_node = 0;
    Eigen::Vector2d min_submap = Eigen::Vector2d::Zero(), max_submap = Eigen::Vector2d::Zero();
  };
  struct Robot {
    std::deque<Node> nodes;
    std::map<int, Submap> submaps;  // by submap index
    Pose2 robot_T_local;
    int anchor = -1;  // pose index, -1 until linked
  };
  struct Constraint {
    SubmapId submap;
    NodeId node;
    Pose2 submap_T_node;
    EdgeKind kind = EdgeKind::kSequential;
    double score = 0.0;
    bool exempt_from_next_check = false;
    Eigen::Vector2d weak_direction = Eigen::Vector2d::Zero();  // submap frame; zero: none
    double weak_information_fraction = 1.0;
    int edge = -1;
    // Between two submaps (AttachRevisits: a chain, kSequential, or a closure summary,
    // kLoopClosure): `submap` to this one, submap_T_node holds their relative pose; `node` is
    // unused.
    int to_submap = -1;
  };
  int EnsureAnchor(int robot);
  // The index in constraints_ of `node`'s intra-submap constraint into `submap`; -1 when none.
  int IntraSubmapConstraint(const NodeId& node, const SubmapId& submap) const;
  // Stores `c` in a slot ReleaseConstraint freed, or at the end.
  void StoreConstraint(const Constraint& c);
  // Releases constraints_[index] and its edge; the slot is reused.
  void ReleaseConstraint(int index);
  Pose2 NodePoseOf(const Robot& robot, const Node& node) const;

  SubmapGraphOptions options_;
  PoseGraphProblem problem_;
  std::map<int, Robot> robots_;
  int first_robot_ = -1;
  std::deque<Constraint> constraints_;  // released slots have edge -1
  std::vector<int> released_constraints_;
  SubmapGraphStats stats_;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_SUBMAP_GRAPH_H_
