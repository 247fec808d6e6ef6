// A team of robots mapping together (paper §V-VI, DESIGN.md items 8-11): every robot runs its own
// online estimator (frontends/online_estimator.h), all on ONE shared submap graph
// (frontends/submap_graph.h), each in its own frame, starting with no knowledge of the others.
// The team estimator looks at the robots' camera images for shared landmarks and joins their
// frames through inter-robot constraints in that graph. Fed measurements one at a time, tagged
// with their robot, as they arrive (any interleaving; each robot's own stream in its order).
//
// Per camera image (a CameraImage measurement):
//  1. the AprilTag detector (merger/tag_detector.h, tag36h11, tags of known size only);
//  2. each tag's planar pose in the body's heading frame (merger/landmark_pose.h: camera mount
//     laser_T_camera, laser mount from the robot's latest LaserReading, roll and pitch from its
//     latest ATTITUDE reading), tied to the robot's newest node: node_T_tag = the node's pose to
//     the robot's pose at the image stamp (OnlineEstimator::PoseAt) composed with body_T_tag;
//     so a sighting moves with its node when the graph is re-optimised;
//  3. the robot's sightings grouped by place, each place named by a vote of the ids seen there
//     (merger/tag_places.h): a wrong id is outvoted.
//
// Linking two robots a and b not yet in one frame (the first constraint), when both have a
// confirmed place of the same tag id L:
//  - eq. 4: a_T_b = a_T_L · (b_T_L)^-1 from the two places' means, with its covariance;
//  - every other tag id both robots have a confirmed place for must agree with it within
//    tag_agreement_*, else the link is rejected (a wrong id that won a vote);
//  - refinement (paper: "a local scan-matching step"): nodes of each robot near the tag (its
//    sighting nodes, best seen first, then its other nodes near the tag) are matched against the other robot's finished submaps
//    (ScanMatcher::MatchWithinWindow, Ceres refinement over factors/scan_cost.h) within a window
//    of 3 sigma of the eq. 4 estimate (clamped to link_window_*); a match counts when it scores
//    >= link_min_score; the link needs link_min_matches of them agreeing with each other within
//    link_agreement_*. Without finished submaps there yet the link waits (retried);
//  - accepted: the matches enter the graph as inter-robot constraints (anchored cost, Kim et al.
//    2010, Huber loss), the linked robots' anchors start at the refined estimate
//    (SubmapGraph::SetAnchorEstimate) and the team graph is solved; the graph's consistency check
//    removes any constraint it disagrees with afterwards.
// Every attempt is recorded (constraints()) with its outcome and reason.
//
// More constraints (paper §V-B, the "second constraint"): once robots share a frame, every node
// of one (after inter_search_travel_meters of travel, and, retrospectively, the nodes recorded
// before the link) is matched against the teammates' finished submaps it falls into, within a
// small window around the team's current estimate (inter_window_*, no motion prior); a match
// scoring >= inter_min_score at least inter_min_spacing_meters from the pair's earlier
// inter-robot constraints is added and the graph re-solved. The first such constraint at least
// second_constraint_min_distance_meters from the first link's tag is the pair's second
// constraint; the relative pose before and after its batch solve is recorded (events()).
//
// Linking without a shared tag (map overlap; beyond the paper, which names it the general case):
// groups of robots not in one frame are also joined by their maps alone.
//  - Query nodes: one node of each robot per overlap_node_spacing_meters of travel. Target
//    submaps: a robot's finished submaps whose node-box centres lie at least
//    overlap_submap_spacing_meters from those already chosen (consecutive submaps see the
//    same place).
//  - Every (query node, target submap) pair of two robots in different groups is matched once,
//    over the whole submap (its observed box, at most ±overlap_max_window_meters, ±180°, no
//    motion prior; the wide matcher), at most overlap_max_matches_per_attempt per robot pair
//    and attempt. A match counts when it scores >= overlap_min_score, beats the search's best
//    other mode by overlap_min_mode_margin (not a symmetric room), pins both directions
//    (min_information_ratio) and its points fall on known cells (min_submap_overlap). Kept
//    matches stay for later attempts.
//  - Every overlap_retry_seconds, per pair of groups, every kept match between their members
//    implies a relative pose of the groups' frames; a pose needs overlap_min_matches query
//    nodes whose matches agree (overlap_agreement_*, compared at the nodes). Each such pose is
//    checked against both groups' whole maps (CompareMaps, merger/map_merge.h: at least
//    overlap_min_agreeing_cells occupied cells agree and at most overlap_max_conflict of the
//    compared ones conflict, a wall where the other saw through) and against their tags (one
//    id placed by both groups more than tag_agreement_meters apart, or two ids placed closer
//    than tag_min_separation_meters facing the same way, refutes it: a building of congruent
//    rooms with a tag in each). Exactly one pose must pass; two passing are reported ambiguous
//    and the groups stay apart. Checking groups, not robot pairs, lets a teammate that has seen
//    both of two congruent rooms expose the ambiguity.
//  - Held: the one passing pose is not linked at once (a "held:" record). It is linked when it
//    passes again, still the only passing pose and with the groups unchanged, at an attempt at
//    least overlap_confirm_seconds later, supported then by at least overlap_confirm_new_nodes
//    query nodes that did not support it when held; a held pose that fails (refuted by the maps
//    or by a tag seen meanwhile, or a rival passes) is dropped. At the moment a wrong pose in
//    congruent rooms first passes, nothing in either map can refute it (the rooms are the same);
//    the hold gives the robots time to see what does (a tag, the rest of a room). It costs every
//    map-overlap link one retry period or more. Not held: a pose that puts a tag id both groups
//    have a confirmed place of at one place (within tag_agreement_*): the shared tag tells
//    congruent places apart.
//  - Accepted: the agreeing matches enter the graph as inter-robot constraints, as a tag link's
//    do (record kind map_overlap); the search for more constraints follows.
//  - Withdrawn: every link_retry_seconds each joined group's tag places (two sightings or more)
//    are compared in the group's frame; a contradiction (TagsContradict) between two robots that
//    a map-overlap link put on different sides withdraws the newest such link: its constraints
//    and every inter-robot constraint across it are removed from the graph, the groups split
//    (a kWithdrawn event, a "withdrawn:" record), and the same pose is refused from then on by
//    the tag check above. A tag link is never withdrawn (tags outrank maps).
//
// Frames: the team's common frame is that of the first robot added (the manifest's first). A
// robot not (yet) linked to it keeps its own frame (InCommonFrame false). Transitive chaining
// (a-b and b-c put c in a's frame) comes from the shared graph: anchors of one connected group.
//
// Fault injection (tests of the consistency checks): with wrong_tag_id_rate > 0 each detection
// is relabelled with probability wrong_tag_id_rate to another of the known tag ids (uniformly),
// from a generator seeded with fault_seed.
//
// Errors are returned (bad robot index, unreadable image, data the robot's estimator refuses);
// the estimator stays usable. Deterministic for a given input order and options.
#ifndef HETSLAM_MERGER_TEAM_ESTIMATOR_H_
#define HETSLAM_MERGER_TEAM_ESTIMATOR_H_

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/camera_model.h"
#include "core/measurement.h"
#include "core/occupancy_grid.h"
#include "core/se2.h"
#include "core/status.h"
#include "core/trajectory_io.h"
#include "frontends/online_estimator.h"
#include "frontends/scan_matcher.h"
#include "frontends/submap_graph.h"
#include "merger/landmark_pose.h"
#include "merger/map_merge.h"
#include "merger/tag_detector.h"
#include "merger/tag_places.h"
#include "merger/map_picture.h"

namespace hetslam {

struct TeamEstimatorOptions {
  SubmapGraphOptions graph;  // the shared team graph
  // Detector settings for speed on 640 x 480 images: a slightly blurred, 1.5x decimated quad
  // search (5 ms instead of 18 ms, most tags beyond 4 m lost), corners refined on the full image.
  TagDetectorOptions detector = DefaultTeamDetectorOptions();
  TagSightingOptions sighting;
  TagPlaceOptions places;
  // Known tags: id -> edge of the black square (metres). Detections of other ids are ignored.
  std::map<int, double> tag_sizes_meters;
  // Project sightings with the robot's logged ATTITUDE roll/pitch (level without readings).
  bool use_attitude = true;
  double attitude_max_age_seconds = 0.2;
  // Image skipping (tag detection, mostly the PNG decode, is the team estimator's largest cost).
  // While the robot's previous detected image showed no known tag: images less than
  // min_image_interval_seconds after it are skipped, and so are images taken while the robot
  // moved less than skip_image_within_meters and turned less than skip_image_within_radians since
  // it (a standing robot sees the same picture). While a tag is in view every image is detected.
  double min_image_interval_seconds = 0.0;
  double skip_image_within_meters = 0.0;
  double skip_image_within_radians = 0.0;

  // The scan matcher of links and inter-robot searches (no motion prior: the window bounds it).
  ScanMatcherOptions matcher = DefaultTeamMatcherOptions();
  // First constraint (link).
  double link_min_score = 0.55;
  int link_min_matches = 2;
  // Nodes tried per robot and attempt: its sighting nodes (best seen first), then its nodes
  // within link_node_radius_meters of the tag, no two closer than link_node_spacing_meters.
  int link_max_nodes_per_robot = 6;
  double link_node_radius_meters = 4.0;
  double link_node_spacing_meters = 0.3;
  double link_agreement_meters = 0.15;
  double link_agreement_radians = 2.0 * M_PI / 180.0;
  double link_window_min_meters = 0.5, link_window_max_meters = 1.5;
  double link_window_min_radians = 3.0 * M_PI / 180.0, link_window_max_radians = 20.0 * M_PI / 180.0;
  double tag_agreement_meters = 0.5;
  double tag_agreement_radians = 10.0 * M_PI / 180.0;
  // Two tags of different ids facing the same way (within tag_agreement_radians) are never
  // closer than this (about their printed size): a map-overlap hypothesis that puts them
  // closer is refuted. 0 = off; at most tag_agreement_meters.
  double tag_min_separation_meters = 0.15;
  double link_retry_seconds = 2.0;  // a failed or waiting link is tried again after this much time
  // Further constraints.
  bool search_more_constraints = true;
  double inter_search_travel_meters = 0.5;
  double inter_search_turn_radians = 20.0 * M_PI / 180.0;
  double inter_window_meters = 0.3;
  double inter_window_radians = 3.0 * M_PI / 180.0;
  double inter_min_score = 0.5;
  double inter_min_spacing_meters = 1.0;
  double second_constraint_min_distance_meters = 3.0;
  // A node is matched against the finished submaps whose node box, grown by submap_margin_meters,
  // holds it and on whose known cells at least min_submap_overlap of its points fall: the
  // max_submaps_per_match with the largest overlap.
  double submap_margin_meters = 4.0;
  double min_submap_overlap = 0.6;
  int max_submaps_per_match = 3;
  // A match counts only when its translational information (J^T J, yaw marginalised) has a smaller
  // eigenvalue of at least this fraction of the larger (else it slides along a wall or corridor),
  // and a node's matches count only when at least min_agreeing_submaps of those submaps gave
  // one and all of them put the node at the same pose (in the teammate's frame) within
  // submap_agreement_*: a scan that slides lands wherever each submap's partial view pulls it.
  double min_information_ratio = 0.15;
  // A match whose score profile drops along its flattest direction by less than this fraction
  // of the drop along its steepest one slides (MatchSlides; LoopCloserOptions::
  // degenerate_max_drop_ratio's test): in a door or a corridor J^T J holds mostly the walls'
  // noise and can pass min_information_ratio while the match slides (team_three seeds 2 and 5:
  // drone nodes in a door placed 0.07-0.20 m off along it in the nao's submaps, weak drops
  // -0.017 to 0.006 against strong 0.29-0.39). Such a match does not refine a tag link; as a
  // further inter-robot constraint it is kept with little information along the flat
  // direction (ConstraintCandidate::weak_direction, as the loop closer's degenerate closures;
  // dropped instead, team_overlap's final pose got 1 cm worse: those were right across it).
  // 0: off.
  double min_profile_drop_ratio = 0.1;
  // Each inter-robot match refined on every point of the node's scan, not only the searched
  // ones (LocalSlamOptions::refine_on_all_points, on by default; hetslam_team's
  // --refine_on_all_points sets all three).
  bool refine_on_all_points = true;
  int min_agreeing_submaps = 2;
  double submap_agreement_meters = 0.1;
  double submap_agreement_radians = 1.0 * M_PI / 180.0;
  // Linking without a shared tag (see the header).
  bool overlap_search = true;
  ScanMatcherOptions overlap_matcher = DefaultOverlapMatcherOptions();
  double overlap_node_spacing_meters = 1.5;
  double overlap_submap_spacing_meters = 3.0;
  double overlap_max_window_meters = 8.0;
  double overlap_min_score = 0.6;
  // The best match must beat the best other mode of its search (half a metre or 10 degrees
  // away, DefaultOverlapMatcherOptions) by this much correlative score.
  double overlap_min_mode_margin = 0.05;
  int overlap_min_matches = 3;
  double overlap_agreement_meters = 0.2;
  double overlap_agreement_radians = 2.0 * M_PI / 180.0;
  double overlap_retry_seconds = 5.0;
  int overlap_max_matches_per_attempt = 60;  // (node, submap) matches per pair and attempt
  int overlap_min_agreeing_cells = 300;
  // Measured on the team scenarios, seeds 1-5 (session 19): poses near the true one 0-9.1% (one
  // 0.8 deg off: 12.5%; a flying robot sees over furniture a ground robot maps), wrong ones
  // 19.9% and up, or congruent rooms under 5% that only the tags and the hold tell apart. 0.05
  // until session 19 refused true poses at 5.1-9.1% once the UAVs' maps followed their lag.
  double overlap_max_conflict = 0.10;
  // Lasers at different heights (CompareMaps' MapHeights), opt-in: when >= 0, an occupied cell
  // whose highest hit lies more than this below the other group's lowest ray (the lowest of
  // its robots', OnlineEstimatorStats::lowest_ray_height_meters) is not a conflict on its free
  // space; a group with a robot without projected scans has no lowest ray. Negative (default):
  // every such cell conflicts. Off by default: with 0.1 team_overlap links 10 s earlier on two
  // seeds, but most of what it forgives there is the wheeled robot's own map distortion, not
  // what the UAV flew over, its pair error after the second constraint is worse, and a wrong
  // pose was refused at 11.2% instead of 23.9% conflict (README, "Lasers at different heights").
  double overlap_height_margin_meters = -1.0;
  // Re-confirmation: a pose that passes every check is held, not linked, until it passes again
  // as the only passing pose at an attempt at least overlap_confirm_seconds later, supported
  // then by at least overlap_confirm_new_nodes query nodes that did not support it when it was
  // first held, and checked against the maps and tags as they are then. In a building of
  // congruent rooms a wrong pose fits both maps until a robot sees what tells the rooms apart (a
  // tag, the far side of a door). Both 0: linked at the first pass. A pose that puts a tag both
  // groups have a confirmed place of at one place is linked without the hold.
  double overlap_confirm_seconds = 5.0;
  int overlap_confirm_new_nodes = 1;
  int max_iterations_per_solve = 20;
  int max_iterations_final = 50;
  // Walls seen through by a teammate (RenderRobotWallsInCommonFrame, merger/map_merge.h
  // DropWallsSeenThrough): a robot's wall cell is dropped when a teammate of its frame saw free
  // space where the robot's laser met it and met no surface of its own this near (metres; 1.5
  // cells: two maps of one wall, merged, meet within a few cm). Negative: walls as each robot
  // found them alone.
  double wall_seen_through_meters = 0.075;

  // Fault injection (see the header).
  double wrong_tag_id_rate = 0.0;
  uint64_t fault_seed = 1;

  static TagDetectorOptions DefaultTeamDetectorOptions();
  static ScanMatcherOptions DefaultTeamMatcherOptions();
  static ScanMatcherOptions DefaultOverlapMatcherOptions();
  bool IsValid(std::string* error) const;
};

struct TeamRobotOptions {
  std::string name;
  OnlineEstimatorOptions estimator;  // estimator.robot is set to the robot's index
  bool has_camera = false;           // else its images are ignored
  CameraIntrinsics intrinsics;
  Eigen::Isometry3d laser_T_camera = Eigen::Isometry3d::Identity();
};

enum class TeamConstraintKind {
  kTagRelativePose,  // eq. 4 from a tag both robots have seen
  kTagScanMatch,     // a scan match that refines a tag link (the first constraint)
  kScanMatch,        // a scan match between robots already in one frame (second and later)
  kMapOverlap,       // a link from map overlap alone: agreeing wide scan matches, whole maps checked
};
// "tag_eq4", "tag_scan_match", "scan_match", "map_overlap"
const char* TeamConstraintKindName(TeamConstraintKind kind);

// Whether a match slides: its score profile drops along its flattest direction by less than
// `min_profile_drop_ratio` of its drop along the steepest (ScanMatchResult::weak_direction_score_drop,
// strong_direction_score_drop), as in a corridor or a door (the weak drop can be negative: the
// refined pose is not the best along that direction); a match without a profile (no refinement)
// never slides, nor any with a ratio of 0. TeamEstimatorOptions::min_profile_drop_ratio.
bool MatchSlides(const ScanMatchResult& match, double min_profile_drop_ratio);

// Whether a match's correction (its pose relative to the prediction the search was centred on)
// is one to keep: within `angular_window`, and translated at most `linear_window` less a margin
// of one cell (at most half the window) along each axis. A peak within a cell of the window's
// border is the search pressing against it, and the true peak may lie outside.
bool InsideSearchWindow(const Pose2& correction, double linear_window, double angular_window, double cell_meters);

// One inter-robot constraint proposed, accepted or rejected.
struct TeamConstraintRecord {
  double stamp_seconds = 0.0;  // when it was proposed (the stamp of the measurement being added)
  int robot_a = 0, robot_b = 0;
  TeamConstraintKind kind = TeamConstraintKind::kTagRelativePose;
  int tag_id = -1;    // tag kinds
  Pose2 a_T_b;        // the relative pose of the robots' frames it measures
  // Scan matches: the node of one robot in the submap of the other, and the match's score.
  SubmapId submap;
  NodeId node;
  Pose2 submap_T_node;
  double score = 0.0;
  bool accepted = false;
  std::string reason;  // why rejected (or how accepted)
};

// The relative pose of two robots' frames, i_T_j.
struct RobotPairPose {
  int robot_i = 0, robot_j = 0;
  Pose2 i_T_j;
};

struct TeamMergeEvent {
  // kWithdrawn: a map-overlap link found wrong later and undone (the groups split again).
  enum class Kind { kFirstLink, kSecondConstraint, kWithdrawn };
  Kind kind = Kind::kFirstLink;
  double stamp_seconds = 0.0;
  int robot_a = 0, robot_b = 0;
  std::string description;
  // Every pair of robots in the joined group, before (second constraint only) and after the solve.
  std::vector<RobotPairPose> before, after;
};

// A robot's tag place, for drawing and reports.
struct TeamTagPlace {
  int robot = 0;
  TagPlace place;  // robot_T_tag in the robot's frame
};

struct TeamEstimatorStats {
  int images = 0;
  int images_detected = 0;   // images the detector ran on
  int detections = 0;        // tags of known size detected
  int detections_relabelled = 0;  // by the fault injection
  int sightings = 0;         // detections turned into sightings
  int sightings_refused = 0; // too far, too oblique, no pose yet
  int link_attempts = 0;
  int links = 0;
  int inter_searches = 0;
  int inter_constraints = 0;
  double detect_seconds = 0.0;
  double link_seconds = 0.0;
  double inter_search_seconds = 0.0;
  int overlap_attempts = 0;   // clusterings of the kept matches
  int overlap_matches = 0;    // (query node, target submap) wide matches run
  int overlap_kept = 0;       // of them, good enough to keep
  int overlap_map_checks = 0; // hypotheses checked against the whole maps
  int overlap_links = 0;
  int overlap_links_withdrawn = 0;  // undone when the joined group's tags contradicted them
  int overlap_held = 0;             // poses held for re-confirmation (each time a new one is held)
  int overlap_held_dropped = 0;     // held poses that failed their re-confirmation
  double overlap_seconds = 0.0;
};

class TeamEstimator {
 public:
  // CHECK-fails on invalid options (validate user input with IsValid first).
  explicit TeamEstimator(const TeamEstimatorOptions& options);
  ~TeamEstimator();
  TeamEstimator(const TeamEstimator&) = delete;
  TeamEstimator& operator=(const TeamEstimator&) = delete;

  // Adds a robot before the first measurement; *index = its id (0, 1, ... in order). Errors:
  // invalid estimator options, a robot added after measurements, a bad camera model.
  Status AddRobot(const TeamRobotOptions& robot, int* index);
  // One measurement of robot `robot`. Errors as above; the measurement is then ignored.
  Status Add(int robot, const Measurement& measurement);
  // Final solves. Idempotent.
  void Finish();

  int num_robots() const { return static_cast<int>(robots_.size()); }
  const std::string& robot_name(int robot) const;
  const OnlineEstimator& estimator(int robot) const;
  const SubmapGraph& graph() const { return *graph_; }

  // Whether `robot` shares the frame of robot 0 (the common frame), and common_T_robot (identity
  // for robot 0 and for robots outside the common frame, which keep their own).
  bool InCommonFrame(int robot) const;
  Pose2 CommonTRobot(int robot) const;
  // i_T_j of two robots in one frame (also outside the common frame); false when not linked.
  bool RelativePose(int robot_i, int robot_j, Pose2* i_T_j) const;
  // The group of robots sharing `robot`'s frame (robot indices, sorted).
  std::vector<int> Group(int robot) const;
  // The robot's trajectory (OnlineEstimator::Trajectory) in the common frame (its own when not
  // in it).
  std::vector<StampedPose2> CommonTrajectory(int robot) const;
  // The robot's map (OnlineEstimator::RenderMap) in the common frame (its own when not in it):
  // its scans rendered there, on the common frame's cells.
  std::unique_ptr<OccupancyGrid> RenderRobotMapInCommonFrame(int robot) const;
  // The robot's wall layer (SubmapGraph::Layer::kWalls: cells its laser hit at several
  // heights) in the common frame (its own when not in it), without the cells a teammate of its
  // frame saw through at its own height (options().wall_seen_through_meters; a shelf's
  // lower face that a humanoid's low laser took for a wall, and a UAV flew over), and without the
  // pieces that leaves shorter than the graph's wall_min_length_meters. `seen_through` (may be
  // null): how many cells the teammates dropped, before the short pieces.
  std::unique_ptr<OccupancyGrid> RenderRobotWallsInCommonFrame(int robot, int* seen_through) const;
  // Robot 0's map with every other robot of the common frame merged in as one observation
  // (merger/map_merge.h), in the common frame (each rendered there, merged cell for cell).
  std::unique_ptr<OccupancyGrid> RenderMergedMap(const MapMergeOptions& merge) const;

  // What a picture of the merged map shows (merger/map_picture.h), in the common frame: the
  // trajectory of every robot in it, the tag places of its robots ("tag <id> (<robot>)") and the
  // inter-robot constraints kept in the graph (a marker at the node, a line to the origin of the
  // teammate's submap it was matched in; "link" for the first link's). Robots outside the common
  // frame are not drawn.
  void PictureContents(std::vector<MapPictureTrajectory>* trajectories, std::vector<MapPictureMarker>* markers) const;

  const std::vector<TeamConstraintRecord>& constraints() const { return records_; }
  const std::vector<TeamMergeEvent>& events() const { return events_; }
  std::vector<TeamTagPlace> TagPlaces() const;
  const TeamEstimatorStats& stats() const { return stats_; }
  const TeamEstimatorOptions& options() const { return options_; }

  // Tag sightings given directly (what the image path computes from a detection): the tag's
  // planar pose in the body's heading frame at `stamp_seconds`. For tests and for embedders with
  // their own landmark detector.
  Status AddTagSighting(int robot, double stamp_seconds, int tag_id, const PlanarTagSighting& sighting);

 private:
  struct Sighting {
    int tag_id = 0;
    double stamp_seconds = 0.0;
    NodeId node;
    Pose2 node_T_tag;
    Eigen::Matrix3d covariance;  // of node_T_tag, node frame
    double range_meters = 0.0;
  };
  struct Robot {
    std::string name;
    std::unique_ptr<OnlineEstimator> estimator;
    bool has_camera = false;
    CameraIntrinsics intrinsics;
    Eigen::Isometry3d laser_T_camera = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d body_T_laser = Eigen::Isometry3d::Identity();
    std::deque<AttitudeReading> attitudes;
    std::optional<double> last_detected_image_stamp;
    std::optional<Pose2> last_detected_image_pose;
    bool tag_in_view = false;  // the last detected image showed a known tag
    std::vector<Sighting> sightings;
    int nodes_seen = 0;          // nodes already considered by the inter-robot search
    std::optional<Pose2> last_search_pose;  // robot frame
    // Map-overlap search: query nodes, target submaps, submaps already considered as targets.
    std::vector<int> overlap_nodes;
    std::optional<Pose2> last_overlap_pose;
    std::vector<int> overlap_submaps;
    int overlap_submaps_seen = 0;
  };
  struct OverlapState {  // per robot pair (a < b)
    std::set<std::tuple<int, int, int, int>> tried;  // (node robot, node index, submap robot, submap index)
    std::vector<ConstraintCandidate> matches;  // kept: a node of one robot in a submap of the other
  };
  struct LinkState {  // per robot pair and tag id
    double next_attempt_stamp = -INFINITY;
    std::string last_outcome;  // an attempt is recorded only when its outcome differs
  };
  struct InterConstraint {
    int robot_a = 0, robot_b = 0;  // a: the submap's robot, b: the node's robot
    SubmapId submap;
    NodeId node;
    bool first_link = false;
  };

  Status AddImage(int robot, const CameraImage& image);
  void AfterScan(int robot, double stamp_seconds);
  std::vector<TagPlace> Places(int robot) const;
  void TryLinks(double stamp_seconds);
  // One attempt to link robots a and b through tag `tag_id`; true when linked.
  bool TryLink(double stamp_seconds, int a, int b, int tag_id, const TagPlace& place_a, const TagPlace& place_b);
  // Matches node `node` against finished submaps of `submap_robot`, predicted at
  // submap_robot_T_node (the submap robot's frame), within the windows; the best match scoring
  // >= min_score, if any. `*covered` (optional) is set when some finished submap was near enough
  // to try.
  std::optional<ConstraintCandidate> MatchNodeAgainstRobot(const NodeId& node, int submap_robot,
                                                           const Pose2& submap_robot_T_node, double linear_window,
                                                           double angular_window, double min_score, bool* covered);
  void SearchInterRobot(double stamp_seconds, const NodeId& node);
  // Joins the groups of robots a and b at a_T_b (the group without the world anchor moves) with
  // `matches` as inter-robot constraints (*added: which ones the graph took), solves; true when
  // the solve kept them joined.
  bool JoinGroups(int a, int b, const Pose2& a_T_b, const std::vector<ConstraintCandidate>& matches,
                  std::vector<bool>* added);
  // After a first link: every node of a's group against its teammates (paper §V-B).
  void SearchRetrospectively(double stamp_seconds, int a);
  // Map-overlap search (see the header).
  void UpdateOverlapTargets(int robot);
  void TryOverlapLinks(double stamp_seconds);
  // New wide matches between robots a and b.
  void MatchOverlaps(int a, int b);
  // A link between the groups of roots a and b from their members' kept matches.
  void TryOverlapLink(double stamp_seconds, int a, int b);
  // A map-overlap link: the groups it joined (their members then).
  struct OverlapLink {
    double stamp_seconds = 0.0;
    int a = 0, b = 0;  // the groups' roots
    std::vector<int> side_a, side_b;
    bool withdrawn = false;
  };
  // A joined group whose members' tag places (of two sightings or more) contradict each other
  // (TagsContradict) was joined wrongly: the newest map-overlap link between the two robots'
  // sides is withdrawn.
  void CheckGroupTags(double stamp_seconds);
  // Why two tag places (ids and poses in one frame) cannot both be right: one id more than
  // tag_agreement_meters apart, or two ids closer than tag_min_separation_meters facing the
  // same way (within tag_agreement_radians). Empty when they can.
  std::string TagsContradict(int id_x, const Pose2& frame_T_x, int id_y, const Pose2& frame_T_y) const;
  void WithdrawOverlapLink(double stamp_seconds, OverlapLink* link, const std::string& reason);
  // root_a_T_root_b implied by an overlap match between members of the two groups.
  Pose2 OverlapRelativePose(int root_a, int root_b, const ConstraintCandidate& match) const;
  // The maps of a group's robots merged in its root's frame.
  std::unique_ptr<OccupancyGrid> RenderGroupMap(int root) const;
  int Root(int robot) const;
  void Solve(int max_iterations);
  // Whether each of inter_constraints_ is still in the graph (not removed by its consistency check).
  std::vector<bool> InterConstraintsKept() const;
  std::vector<RobotPairPose> GroupPairPoses(int robot) const;
  // Robot b's frame in robot a's, from the graph's anchors.
  Pose2 AnchorRelative(int a, int b) const;
  Pose2 NodeInRobotFrame(const NodeId& node, int frame_robot) const;
  void Record(TeamConstraintRecord record);

  TeamEstimatorOptions options_;
  std::unique_ptr<SubmapGraph> graph_;
  std::vector<Robot> robots_;
  std::vector<int> parent_;  // union-find over robots: linked groups
  TagDetector detector_;
  ScanMatcher matcher_;
  ScanMatcher overlap_matcher_;
  std::vector<int> known_tag_ids_;
  std::mt19937_64 fault_rng_;
  std::map<std::tuple<int, int, int>, LinkState> link_states_;
  std::vector<InterConstraint> inter_constraints_;
  // Per pair (a < b): where its first link was (the shared tag, robot a's frame), and whether
  // the second constraint was found.
  std::map<std::pair<int, int>, std::vector<Eigen::Vector2d>> first_link_places_;
  std::set<std::pair<int, int>> has_second_constraint_;
  std::map<std::pair<int, int>, OverlapState> overlap_states_;
  std::map<std::pair<int, int>, std::string> overlap_outcomes_;  // per pair of group roots: the last recorded
  double next_overlap_attempt_stamp_ = -INFINITY;
  std::vector<OverlapLink> overlap_links_;
  // A map-overlap pose that passed once and waits for its re-confirmation, per pair of group
  // roots (a < b).
  struct HeldOverlap {
    double stamp_seconds = 0.0;          // when it first passed
    std::vector<int> side_a, side_b;     // the groups then
    Pose2 a_T_b;                         // root a's frame to root b's
    std::set<std::pair<int, int>> nodes; // (robot, node index): the query nodes that supported it
  };
  std::map<std::pair<int, int>, HeldOverlap> overlap_held_;
  double next_tag_check_stamp_ = -INFINITY;
  std::vector<TeamConstraintRecord> records_;
  std::vector<TeamMergeEvent> events_;
  bool started_ = false;
  bool finished_ = false;
  TeamEstimatorStats stats_;
};

}  // namespace hetslam

#endif  // HETSLAM_MERGER_TEAM_ESTIMATOR_H_
