// hetslam_team: a team of robots mapping together (paper §V-VI). Reads every robot's log of a
// team manifest, feeds all measurements interleaved by stamp to the team estimator
// (merger/team_estimator.h) as they would arrive live, and writes each robot's trajectory and map,
// the merged map and the inter-robot constraints.
//
//   hetslam_team --manifest=/tmp/t2/team.txt --out=/tmp/t2_out
//   hetslam_team --manifest=/tmp/t3/team.txt --out=/tmp/t3_out --wrong_tag_id_rate=0.2
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/file_io.h"
#include "core/map_io.h"
#include "core/measurement_log.h"
#include "core/robot_log.h"
#include "core/team_manifest.h"
#include "core/trajectory_io.h"
#include "core/trajectory_metrics.h"
#include "examples/flag_help.h"
#include "frontends/constraint_truth.h"
#include "frontends/loop_closer.h"
#include "gflags/gflags.h"
#include "glog/logging.h"
#include "merger/team_estimator.h"

DEFINE_string(manifest, "", "Team manifest (`team.txt`, HSTEAM 1): one `robot name kind directory` line per robot, "
              "each directory holding a hetslam robot log `log.txt` and its camera images. The first robot's frame is "
              "the team's common frame. `tag` lines give the tag sizes (their world poses are used only to "
              "evaluate). Required.");
DEFINE_string(out, "", "Output folder (created if missing): <robot>/trajectory.txt (t x y theta, common frame), "
              "<robot>/map.pgm + .yaml, <robot>/walls.pgm + .yaml (when it found walls: cells its laser hit at several heights, "
              "less those a teammate saw through, --wall_seen_through), merged_map.pgm + .yaml + .png, "
              "constraints.txt, frames.txt. Required.");
DEFINE_bool(lenient, false, "Skip malformed log lines with a count instead of stopping at the first one.");
DEFINE_bool(use_images, true, "Detect AprilTags in the camera images; false leaves the robots only their maps to find "
            "each other by (--overlap_search).");
DEFINE_double(wrong_tag_id_rate, 0.0, "Fault injection: relabel this fraction of tag detections with another tag id "
              "of the manifest (seeded by --fault_seed), to test that wrong ids never merge robots. In [0, 1].");
DEFINE_uint64(fault_seed, 1, "Seed of the --wrong_tag_id_rate fault injection.");
DEFINE_double(min_image_interval, 0.5, "While a robot's previous detected image showed no tag, skip its images taken "
              "less than this many seconds after it (0 = detect every image). While a tag is in view every image "
              "is detected. Tag detection, mostly decoding the PNG, is the largest cost of a team run.");
DEFINE_double(skip_static_images_within, 0.02, "While no tag is in view, also skip a robot's image while it has moved "
              "less than this many metres and turned less than --skip_static_images_within_deg since its previous "
              "detected image (a standing robot sees the same picture); 0 = never skip.");
DEFINE_double(skip_static_images_within_deg, 1.0, "See --skip_static_images_within.");
DEFINE_string(attitude_source, "marg", "Each robot's attitude for the 2.5D scan projection: marg (our MARG filter on "
              "the raw samples), logged (the log's ATTITUDE lines) or level.");
DEFINE_double(floor_tilt_gain, hetslam::OnlineEstimatorOptions().floor_tilt_gain,
              "Each robot with an attitude: a scan whose floor hits lie on a line away from the body (a laser tilted "
              "down) corrects the attitude's roll and pitch for the later scans by this fraction of the tilt the line "
              "says the projection got wrong (an accelerometer bias tilts the MARG filter's attitude for good); 0 = off.");
DEFINE_double(command_response, -1.0, "Seconds of each robot's velocity response to a command: the EKF's command model "
              "lets the velocity follow the commanded one with this first-order lag (a multirotor's velocity controller); "
              "0 = the velocity is the command (paper eq. 3). Negative (default): each log's PARAM "
              "command_response_seconds when it has one (the simulator's UAVs: 0.25), else 0.");
DEFINE_bool(use_odometry, false, "Robots whose log has ODOM lines (wheeled) predict each scan's pose from their odometry. "
            "Off by default: the pipeline is odometry-free (the EKF predicts from commands and MARG rates).");
DEFINE_double(link_min_score, 0.55, "A scan match refining a tag link counts when its mean likelihood is at least this.");
DEFINE_int32(link_min_matches, 2, "Agreeing scan matches a tag link needs before two robots are merged.");
DEFINE_bool(more_constraints, true, "After two robots share a frame, search more inter-robot constraints by scan "
            "matching where their trajectories come close (the paper's second constraint, §V-B).");
DEFINE_double(inter_min_score, 0.5, "Minimum mean likelihood of a scan match between robots already in one frame.");
DEFINE_double(min_profile_drop_ratio, 0.1,
              "A scan match between robots whose score drops along its flattest direction by less than this fraction "
              "of its drop along the steepest slides (a door, a corridor): it does not refine a tag link, and as a "
              "further inter-robot constraint it weighs little along that direction. 0 turns the test off.");
DEFINE_double(second_constraint_min_distance, 3.0, "The second constraint of a robot pair lies at least this many "
              "metres from its first link.");
DEFINE_int32(tag_min_votes, 2, "Sightings at one place of a robot's map that must report the same tag id before that "
             "id names the place (merger/tag_places.h: a wrong id is outvoted). At least 1.");
DEFINE_double(tag_min_vote_fraction, 0.6, "Share of a place's sightings that must report its id. In (0.5, 1].");
DEFINE_bool(overlap_search, true, "Also join robots that share no tag by their maps alone: each robot's scans are "
            "searched in the other's submaps (every position, every heading), a relative pose needs "
            "--overlap_min_matches agreeing matches and must fit both whole maps (at most --overlap_max_conflict of "
            "the compared wall cells where the other robot saw free space); two such poses (a symmetric building) "
            "are reported ambiguous and not merged.");
DEFINE_int32(overlap_min_matches, 3, "Scans of different places (1.5 m apart) whose wide matches must agree on a "
             "map-overlap link. At least 2.");
DEFINE_double(overlap_max_conflict, 0.10, "Largest share of compared occupied cells that may land on the other "
              "robot's free space for a map-overlap link. In [0, 1].");
DEFINE_double(overlap_height_margin_meters, -1.0, "Robots whose lasers sweep different heights, opt-in: when >= 0, an "
              "occupied cell whose highest hit lies more than this below the lowest ray of the other robots' lasers "
              "is no conflict on their free space in the map-overlap check (their lasers may have passed over it: a "
              "low box under a UAV's laser). Negative (default): every such cell conflicts, as does every cell of a "
              "robot without 2.5D projection (no attitude). 0.1 is the measured setting (README).");
DEFINE_double(overlap_confirm_seconds, 5.0, "A map-overlap pose that passes every check is held, not linked, until it "
              "passes again, as the only passing pose, at least this many seconds later (with the tags and maps as "
              "they are then); not held when the pose puts a tag both sides have confirmed at one place. 0 with "
              "--overlap_confirm_new_nodes=0: linked at the first pass.");
DEFINE_int32(overlap_confirm_new_nodes, 1, "Query nodes that did not support a held map-overlap pose when it was "
             "held and must support it when it is re-confirmed (new travel). At least 0.");
DEFINE_string(refine_interpolation, "distances", "What each robot's front end refines its scan matches on between "
              "cell centres: distances (to the nearest surface; the default; see hetslam_run --help and "
              "factors/scan_cost.h) or values (the likelihood field's).");
DEFINE_int32(refine_max_iterations, 20, "Iteration limit of every scan match's Ceres refinement (each robot's front "
             "end and loop search, the team's inter-robot and map-overlap matches), in [0, 1000]; see hetslam_run "
             "--help.");
DEFINE_double(refine_function_tolerance, 1e-6, "Every scan match's Ceres refinement stops when a step changes its "
              "cost by less than this fraction (Ceres' function_tolerance), in (0, 1).");
DEFINE_double(motion_filter_distance, 0.01, "Each robot's motion filter (see hetslam_run --help): a scan that moved "
              "less than this (metres) and turned less than --motion_filter_angle_deg since the robot's last graph "
              "node is matched and mapped but is no node (a standing robot adds nothing); 0 = off.");
DEFINE_double(motion_filter_angle_deg, 0.5, "Each robot's motion filter: heading change (degrees) that makes a scan "
              "new.");
DEFINE_double(tag_min_separation, 0.15, "Two tags of different ids facing the same way are never closer than this "
              "(metres, about their printed size): a map-overlap pose, or a joined group, that puts them closer is "
              "refuted (0 = off; at most 0.5).");
DEFINE_int32(loop_max_submaps, 4, "Each robot's loop search budget (see hetslam_run --help): match each node against "
             "at most this many of its finished submaps, those its scan overlaps most; 0 = every submap whose box holds "
             "the node.");
DEFINE_double(max_map_store_mib, 0.0, "Each robot's map store bound (see hetslam_run --help): the finished submaps' "
              "maps beyond this many MiB are evicted, the most covered first (no longer searched, still rendered); 0 = "
              "no bound.");
DEFINE_double(retire_revisited_share, 0.9, "Each robot's revisits (see hetslam_run --help): a finished submap whose "
              "occupied cells its robot's earlier submaps cover to at least this share is retired (its map freed, no "
              "longer searched by loop closure or the overlap search, still rendered). In [0, 1]; 0 = off.");
DEFINE_double(loop_agreeing_min_score, hetslam::LoopCloserOptions().agreeing_min_score,
              "Each robot's loop closer: revisits seen the other way round, matches scoring at least this (below the "
              "loop closer's minimum) closing the loop once a later node's calls for the same correction (see "
              "hetslam_run --help). 0 = off.");
DEFINE_bool(refine_on_voxel_ends, false, "The search places each scan on the first beam of every 0.2 m matching voxel; the "
            "refinement of its pose uses each voxel's first and last beam (one where it has one): the first beam "
            "alone is a surface's end on one side of the scan only and turned every simulated front end the same "
            "way, +0.04 to +2.25 deg a run; with both ends the simulated robots' worst heading from their start "
            "is 0.56 deg (1.13 with the first beam alone), for about 3% more time on FR079. Off by default: Intel and ACES each end far "
            "off under one of tests/bench/run_sensitivity.sh's ten stopping rules (README, \"The refinement on "
            "each voxel's first and last beam\"). Only with --norefine_on_all_points (on by default, it takes "
            "precedence over this); takes precedence over "
            "--refine_on_middle_beams.");
DEFINE_bool(refine_on_all_points, hetslam::LocalSlamOptions().refine_on_all_points,
            "The search places each scan on the first beam of every 0.2 m matching voxel; the refinement of its "
            "pose (front ends, loop closures and inter-robot matches) uses every beam (a voxel's first beam lies "
            "nearest the side the sweep enters by, which turned each robot's front end +0.04 to +2.25 deg a run). "
            "On by default since session 51: team_three's drone-nao frames 0.233 -> 0.046 m after the second "
            "constraint, team_overlap 0.063 -> 0.036 m (README, \"Every point refined by default\"; "
            "hetslam_run --help). Takes precedence over --refine_on_voxel_ends and --refine_on_middle_beams.");
DEFINE_bool(refine_on_middle_beams, false, "The search places each scan on the first beam of every 0.2 m matching voxel; the "
            "refinement of its pose uses each voxel's middle beam (the first beam is a surface's end on one side "
            "of the scan only, which turned the pose that way scan after scan: the simulated 2.5D robots' worst "
            "heading from their start up to 1.13 deg, up to 0.58 with this but the corridor's 0.99). An even "
            "voxel's middle is the midpoint of its two middle beams. Off by default: the simulated office loop's "
            "corrected trajectory and the corridor's get worse with it (README, Teams). Only with "
            "--norefine_on_all_points (on by default, it takes precedence over this).");
DEFINE_bool(keep_search_tables_over_solves, true,
            "Before each solve (a robot's or the team's), keep the search tables' pages the searches since the "
            "last solve used, unless the process is near its memory peak; off: free them all (hetslam_run --help "
            "explains it). The same results either way.");
DEFINE_bool(rematch_first_node, true, "The frame is the body at the first scan: when the first submap is finished, "
            "the first scan is refined against it and the map turned around the first pose to the heading the finished "
            "map gives it (the next few scans' matches can turn a young submap's map against the first scan; 0.4-0.6 "
            "deg on a simulated UAV). --norematch_first_node keeps the first scan's heading as inserted.");
DEFINE_bool(attach_revisits, true, "Each robot's retired submaps (see hetslam_run --help): after every solve their "
            "scans leave the graph, riding on their submap, with constraints between submaps in place of theirs; "
            "scans with an inter-robot constraint stay.");
DEFINE_double(revisit_points_min_travel, 0.5, "Each robot's attached scans (see hetslam_run --help): a scan attached "
              "to a retired submap keeps its points for the rendered maps only at least this many metres from (or "
              "--revisit_points_min_turn_deg against) the last scan of that submap that kept them. 0 with "
              "--revisit_points_min_turn_deg=0: every attached scan keeps its points.");
DEFINE_double(revisit_points_min_turn_deg, 15.0, "See --revisit_points_min_travel (degrees).");
DEFINE_double(intra_sigma, hetslam::SubmapGraphOptions().intra_translation_sigma_meters,
              "Every robot's pose graph: standard deviation (metres) of each scan's constraint to the submaps it "
              "went into (the front end's own chain). With --intra_rotation_sigma_deg, how far the graph trusts the "
              "front end against the loop closures (--loop_sigma): smaller, a stiffer chain that the closures pull "
              "less. In (0, 1000].");
DEFINE_double(intra_rotation_sigma_deg, hetslam::SubmapGraphOptions().intra_rotation_sigma_radians * 180.0 / M_PI,
              "Every robot's pose graph: standard deviation (degrees) of the heading of each scan's constraint to "
              "its submaps (see --intra_sigma).");
DEFINE_double(loop_sigma, hetslam::SubmapGraphOptions().loop_translation_sigma_meters,
              "Every robot's pose graph: standard deviation (metres) of a loop closure (along a degenerate closure's "
              "weak direction up to --loop_weak_sigma), Huber-robust beyond 3 of them. In (0, 1000].");
DEFINE_double(loop_rotation_sigma_deg, hetslam::SubmapGraphOptions().loop_rotation_sigma_radians * 180.0 / M_PI,
              "Every robot's pose graph: standard deviation (degrees) of a loop closure's heading (see "
              "--loop_sigma).");
DEFINE_double(map_min_hit_share, 0.2, "Every robot's rendered maps (its map.pgm, the merged map, and the maps the "
              "map-overlap checks compare) leave out the noise tail behind walls: an occupied cell hit fewer times than "
              "this share of a neighbour's hits, with never-observed space beyond it (see hetslam_run --help). In "
              "[0, 1]; 0 keeps every hit cell.");
DEFINE_double(wall_seen_through, hetslam::TeamEstimatorOptions().wall_seen_through_meters,
              "Walls stand from floor to ceiling, so a laser at any height sees them: a cell a robot's laser hit at "
              "several heights (its walls.pgm) is left out when a teammate of its frame saw free space where that laser "
              "met it and met no surface of its own within this many metres (a shelf's lower face that a humanoid's low "
              "laser took for a wall, and a UAV flew over to the shelf's upper part behind it). Negative: each robot's "
              "walls as it found them alone.");
DEFINE_int32(progress_every, 0, "Print progress every N seconds of data (0 = never).");

namespace hetslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

bool Fail(const std::string& message) {
  std::cerr << "hetslam_team: " << message << "\n";
  return false;
}

bool OptionsFromFlags(TeamEstimatorOptions* team, OnlineEstimatorOptions* robot, std::string* error) {
  if (FLAGS_manifest.empty()) return (*error = "--manifest is required (a team.txt)"), false;
  if (FLAGS_out.empty()) return (*error = "--out is required (an output folder)"), false;
  if (!(FLAGS_command_response <= 60)) return (*error = "--command_response must be at most 60 seconds"), false;
  if (!ParseAttitudeSource(FLAGS_attitude_source, &robot->attitude_source)) {
    return (*error = "--attitude_source must be marg, logged or level (got '" + FLAGS_attitude_source + "')"), false;
  }
  robot->floor_tilt_gain = FLAGS_floor_tilt_gain;
  if (!ParseScanCostInterpolation(FLAGS_refine_interpolation, &robot->local.matcher.refine_interpolation)) {
    return (*error = "--refine_interpolation must be values or distances (got '" + FLAGS_refine_interpolation + "')"),
           false;
  }
  for (ScanMatcherOptions* matcher : {&robot->local.matcher, &robot->loop.matcher, &robot->loop.wide_matcher,
                                      &team->matcher, &team->overlap_matcher}) {
    matcher->max_ceres_iterations = FLAGS_refine_max_iterations;
    matcher->refine_function_tolerance = FLAGS_refine_function_tolerance;
  }
  team->wall_seen_through_meters = FLAGS_wall_seen_through;
  team->wrong_tag_id_rate = FLAGS_wrong_tag_id_rate;
  team->fault_seed = FLAGS_fault_seed;
  team->min_image_interval_seconds = FLAGS_min_image_interval;
  team->skip_image_within_meters = FLAGS_skip_static_images_within;
  team->skip_image_within_radians = FLAGS_skip_static_images_within_deg * kDeg;
  team->link_min_score = FLAGS_link_min_score;
  team->link_min_matches = FLAGS_link_min_matches;
  team->search_more_constraints = FLAGS_more_constraints;
  team->places.min_votes = FLAGS_tag_min_votes;
  team->places.min_vote_fraction = FLAGS_tag_min_vote_fraction;
  team->overlap_search = FLAGS_overlap_search;
  team->overlap_min_matches = FLAGS_overlap_min_matches;
  team->overlap_max_conflict = FLAGS_overlap_max_conflict;
  team->overlap_height_margin_meters = FLAGS_overlap_height_margin_meters;
  team->overlap_confirm_seconds = FLAGS_overlap_confirm_seconds;
  team->overlap_confirm_new_nodes = FLAGS_overlap_confirm_new_nodes;
  team->inter_min_score = FLAGS_inter_min_score;
  team->min_profile_drop_ratio = FLAGS_min_profile_drop_ratio;
  team->second_constraint_min_distance_meters = FLAGS_second_constraint_min_distance;
  team->tag_min_separation_meters = FLAGS_tag_min_separation;
  team->graph.intra_translation_sigma_meters = FLAGS_intra_sigma;
  team->graph.intra_rotation_sigma_radians = FLAGS_intra_rotation_sigma_deg * kDeg;
  team->graph.loop_translation_sigma_meters = FLAGS_loop_sigma;
  team->graph.loop_rotation_sigma_radians = FLAGS_loop_rotation_sigma_deg * kDeg;
  team->graph.map_min_hit_share = FLAGS_map_min_hit_share;
  team->graph.revisit_points_min_travel_meters = FLAGS_revisit_points_min_travel;
  team->graph.revisit_points_min_turn_radians = FLAGS_revisit_points_min_turn_deg * kDeg;
  robot->local.motion_filter_distance_meters = FLAGS_motion_filter_distance;
  robot->local.motion_filter_angle_radians = FLAGS_motion_filter_angle_deg * kDeg;
  robot->loop.max_submaps_per_search = FLAGS_loop_max_submaps;
  if (!(FLAGS_max_map_store_mib >= 0 && FLAGS_max_map_store_mib <= 1048576)) {
    return (*error = "--max_map_store_mib must be in [0, 1048576] (got " + std::to_string(FLAGS_max_map_store_mib) + ")"),
           false;
  }
  robot->max_map_store_bytes = static_cast<size_t>(FLAGS_max_map_store_mib * 1048576.0);
  robot->retire_revisited_share = FLAGS_retire_revisited_share;
  robot->attach_revisits = FLAGS_attach_revisits;
  robot->rematch_first_node = FLAGS_rematch_first_node;
  robot->keep_search_tables_over_solves = FLAGS_keep_search_tables_over_solves;
  robot->local.refine_on_middle_beams = FLAGS_refine_on_middle_beams;
  robot->local.refine_on_voxel_ends = FLAGS_refine_on_voxel_ends;
  robot->local.refine_on_all_points = FLAGS_refine_on_all_points;
  robot->loop.refine_on_all_points = FLAGS_refine_on_all_points;
  robot->loop.agreeing_min_score = FLAGS_loop_agreeing_min_score;
  team->refine_on_all_points = FLAGS_refine_on_all_points;
  if (FLAGS_progress_every < 0) return (*error = "--progress_every must be >= 0"), false;
  std::string invalid;
  if (!team->IsValid(&invalid)) return (*error = "bad flag value: " + invalid), false;
  if (!robot->IsValid(&invalid)) return (*error = "bad flag value: " + invalid), false;
  return true;
}

struct RobotData {
  std::string name;
  MeasurementLog log;
  bool has_camera = false;
  CameraIntrinsics intrinsics;
  Eigen::Isometry3d laser_T_camera = Eigen::Isometry3d::Identity();
};

// i_T_j error against the truth: translation (m) and rotation (deg).
const char* EventName(TeamMergeEvent::Kind kind) {
  switch (kind) {
    case TeamMergeEvent::Kind::kFirstLink:
      return "merged";
    case TeamMergeEvent::Kind::kSecondConstraint:
      return "second constraint";
    case TeamMergeEvent::Kind::kWithdrawn:
      return "split again";
  }
  return "?";
}

// The event in the "truth:" lines (a withdrawal has no poses after it to score).
const char* EventTruthName(TeamMergeEvent::Kind kind) {
  return kind == TeamMergeEvent::Kind::kFirstLink ? "first link" : "second constraint";
}

std::string PairError(const Pose2& estimate, const Pose2& truth) {
  const Pose2 error = Between(truth, estimate);
  char text[128];
  std::snprintf(text, sizeof(text), "error %.3f m / %.3f deg", error.translation().norm(), std::abs(error.theta()) / kDeg);
  return text;
}

std::string PoseText(const Pose2& p) {
  char text[128];
  std::snprintf(text, sizeof(text), "(%.3f, %.3f, %.2f deg)", p.x(), p.y(), p.theta() / kDeg);
  return text;
}

Status WriteConstraints(const std::string& path, const TeamEstimator& team) {
  std::ostringstream out;  // written through a temporary file: no truncated output
  out << "# stamp robot_a robot_b kind tag a_T_b_x a_T_b_y a_T_b_theta submap_robot submap node_robot node score "
         "status reason\n"
         "# a_T_b: the relative pose of the robots' frames the constraint measures (metres, radians); scan matches\n"
         "# also name the node matched and the submap it was matched in (-1 for eq. 4 estimates)\n";
  out.precision(9);
  for (const TeamConstraintRecord& r : team.constraints()) {
    const bool match = r.kind != TeamConstraintKind::kTagRelativePose;
    out << r.stamp_seconds << ' ' << team.robot_name(r.robot_a) << ' ' << team.robot_name(r.robot_b) << ' '
        << TeamConstraintKindName(r.kind) << ' ' << r.tag_id << ' ' << r.a_T_b.x() << ' ' << r.a_T_b.y() << ' '
        << r.a_T_b.theta() << ' ' << (match ? team.robot_name(r.submap.robot) : "-") << ' '
        << (match ? r.submap.index : -1) << ' ' << (match ? team.robot_name(r.node.robot) : "-") << ' '
        << (match ? r.node.index : -1) << ' ' << r.score << ' ' << (r.accepted ? "accepted" : "rejected") << ' '
        << r.reason << '\n';
  }
  const std::string text = out.str();
  return WriteFileBytes(path, text.data(), text.size());
}

Status WriteFrames(const std::string& path, const TeamEstimator& team) {
  std::ostringstream out;  // written through a temporary file: no truncated output
  out << "# robot in_common_frame common_T_robot_x common_T_robot_y common_T_robot_theta\n"
         "# in_common_frame 0: the robot never merged with " << team.robot_name(0)
      << "; its trajectory and map stay in its own frame\n";
  out.precision(9);
  for (int r = 0; r < team.num_robots(); ++r) {
    const Pose2 p = team.CommonTRobot(r);
    out << team.robot_name(r) << ' ' << (team.InCommonFrame(r) ? 1 : 0) << ' ' << p.x() << ' ' << p.y() << ' '
        << p.theta() << '\n';
  }
  const std::string text = out.str();
  return WriteFileBytes(path, text.data(), text.size());
}

int Run() {
  TeamEstimatorOptions team_options;
  OnlineEstimatorOptions robot_options;
  std::string error;
  if (!OptionsFromFlags(&team_options, &robot_options, &error)) return Fail(error + " (see --help)"), 2;

  TeamManifest manifest;
  Status status = ReadTeamManifest(FLAGS_manifest, &manifest);
  if (!status.ok()) return Fail(status.message()), 1;
  if (manifest.robots.empty()) return Fail("'" + FLAGS_manifest + "' lists no robot"), 1;
  for (const TagTruth& tag : manifest.tags) team_options.tag_sizes_meters[tag.id] = tag.size_meters;
  if (!FLAGS_use_images) team_options.tag_sizes_meters.clear();

  std::vector<RobotData> robots;
  RobotLogReadOptions read_options;
  read_options.lenient = FLAGS_lenient;
  for (const TeamRobot& member : manifest.robots) {
    RobotLog log;
    status = ReadRobotLog(manifest.RobotLogPath(member), read_options, &log);
    if (!status.ok()) return Fail(status.message()), 1;
    for (const std::string& warning : log.warnings) std::cerr << "warning: " << warning << "\n";
    RobotData robot;
    robot.name = member.name;
    robot.has_camera = !log.images.empty() && log.CameraModel(&robot.intrinsics, &robot.laser_T_camera).ok();
    if (!log.images.empty() && !robot.has_camera) {
      std::cerr << "warning: " << member.name << ": images without a usable camera model, ignored: "
                << log.CameraModel(&robot.intrinsics, &robot.laser_T_camera).message() << "\n";
    }
    robot.log = MeasurementLogFromRobotLog(std::move(log));
    robots.push_back(std::move(robot));
  }

  TeamEstimator team(team_options);
  for (const RobotData& robot : robots) {
    TeamRobotOptions options;
    options.name = robot.name;
    options.estimator = robot_options;
    status = ApplyLogParams(robot.log.params, &options.estimator);
    if (!status.ok()) return Fail(robot.name + ": " + status.message()), 1;
    if (FLAGS_command_response >= 0) options.estimator.ekf.command_response_seconds = FLAGS_command_response;
    const bool has_odometry = std::any_of(robot.log.measurements.begin(), robot.log.measurements.end(),
                                          [](const Measurement& m) { return std::holds_alternative<OdometryReading>(m); });
    if (FLAGS_use_odometry && has_odometry) {
      options.estimator.use_odometry = true;
      options.estimator.use_commands = false;
      options.estimator.local.prediction = MotionPrediction::kOdometry;
    }
    options.has_camera = robot.has_camera;
    options.intrinsics = robot.intrinsics;
    options.laser_T_camera = robot.laser_T_camera;
    int index = 0;
    status = team.AddRobot(options, &index);
    if (!status.ok()) return Fail(status.message()), 1;
  }

  // Interleaved by stamp as they would arrive live; at equal stamps in manifest order.
  std::vector<size_t> next(robots.size(), 0);
  double first_stamp = INFINITY, last_stamp = -INFINITY;
  for (const RobotData& robot : robots) {
    for (const Measurement& m : robot.log.measurements) {
      if (!std::holds_alternative<LaserReading>(m)) continue;
      first_stamp = std::min(first_stamp, StampOf(m));
      last_stamp = std::max(last_stamp, StampOf(m));
    }
  }
  std::printf("hetslam_team: %zu robots from %s, images %s\n", robots.size(), FLAGS_manifest.c_str(),
              FLAGS_use_images ? "on" : "off");
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  size_t events_printed = 0;
  int errors = 0;
  double next_progress = first_stamp + FLAGS_progress_every;
  while (true) {
    int pick = -1;
    for (size_t r = 0; r < robots.size(); ++r) {
      if (next[r] >= robots[r].log.measurements.size()) continue;
      if (pick < 0 || StampOf(robots[r].log.measurements[next[r]]) < StampOf(robots[pick].log.measurements[next[pick]])) {
        pick = static_cast<int>(r);
      }
    }
    if (pick < 0) break;
    const Measurement& m = robots[pick].log.measurements[next[pick]++];
    status = team.Add(pick, m);
    if (!status.ok() && ++errors <= 5) std::cerr << "warning: " << robots[pick].name << ": " << status.message() << "\n";
    for (; events_printed < team.events().size(); ++events_printed) {
      const TeamMergeEvent& e = team.events()[events_printed];
      std::printf("t=%.2f s: %s %s-%s: %s\n", e.stamp_seconds,
                  EventName(e.kind),
                  robots[e.robot_a].name.c_str(), robots[e.robot_b].name.c_str(), e.description.c_str());
    }
    if (FLAGS_progress_every > 0 && StampOf(m) >= next_progress) {
      next_progress += FLAGS_progress_every;
      std::fprintf(stderr, "  t=%.0f s, %.1f s wall\n", StampOf(m),
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
  }
  if (errors > 5) std::cerr << "warning: " << errors << " measurements refused in all (first 5 shown)\n";
  team.Finish();
  const double wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;

  // Outputs.
  const std::filesystem::path out(FLAGS_out);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) return Fail("cannot create output folder '" + FLAGS_out + "': " + ec.message()), 1;
  std::vector<Status> written;
  std::vector<int> walls_seen_through(team.num_robots(), 0);
  for (int r = 0; r < team.num_robots(); ++r) {
    const std::filesystem::path dir = out / robots[r].name;
    std::filesystem::create_directories(dir, ec);
    if (ec) return Fail("cannot create '" + dir.string() + "': " + ec.message()), 1;
    written.push_back(WriteTrajectory((dir / "trajectory.txt").string(), team.CommonTrajectory(r)));
    const std::unique_ptr<OccupancyGrid> map = team.RenderRobotMapInCommonFrame(r);
    if (map->observed_max().x >= map->observed_min().x) written.push_back(WriteMapPgmYaml(*map, (dir / "map").string()));
    const std::unique_ptr<OccupancyGrid> walls = team.RenderRobotWallsInCommonFrame(r, &walls_seen_through[r]);
    if (walls->observed_max().x >= walls->observed_min().x) {
      written.push_back(WriteMapPgmYaml(*walls, (dir / "walls").string()));
    }
  }
  const std::unique_ptr<OccupancyGrid> merged = team.RenderMergedMap(MapMergeOptions());
  written.push_back(WriteMapPgmYaml(*merged, (out / "merged_map").string()));
  std::vector<MapPictureTrajectory> trajectories;
  std::vector<MapPictureMarker> markers;
  team.PictureContents(&trajectories, &markers);
  written.push_back(WriteMapPicture((out / "merged_map.png").string(), *merged, nullptr, trajectories, markers,
                                    MapPictureOptions()));
  written.push_back(WriteConstraints((out / "constraints.txt").string(), team));
  written.push_back(WriteFrames((out / "frames.txt").string(), team));
  for (const Status& s : written) {
    if (!s.ok()) return Fail(s.message()), 1;
  }

  // Summary.
  const TeamEstimatorStats& s = team.stats();
  std::printf("tags: %d images, %d detected (%.2f s), %d detections (%d relabelled by fault injection), %d sightings, "
              "%d refused\n",
              s.images, s.images_detected, s.detect_seconds, s.detections, s.detections_relabelled, s.sightings,
              s.sightings_refused);
  int accepted = 0, rejected = 0;
  for (const TeamConstraintRecord& r : team.constraints()) (r.accepted ? accepted : rejected)++;
  std::printf("links: %d attempts, %d links (%.2f s); inter-robot constraints: %d (%d searches, %.2f s); records: %d "
              "accepted, %d rejected\n",
              s.link_attempts, s.links, s.link_seconds, s.inter_constraints, s.inter_searches, s.inter_search_seconds,
              accepted, rejected);
  std::printf("map overlap (no shared tag): %d attempts, %d wide matches (%d kept), %d hypotheses checked against the "
              "whole maps, %d poses held for re-confirmation (%d of them failed it), %d links, %d withdrawn when "
              "the tags contradicted them (%.2f s)\n",
              s.overlap_attempts, s.overlap_matches, s.overlap_kept, s.overlap_map_checks, s.overlap_held,
              s.overlap_held_dropped, s.overlap_links, s.overlap_links_withdrawn, s.overlap_seconds);
  std::printf("revisits: %d finished submaps retired (%.1f MiB freed; --retire_revisited_share=%g)\n",
              team.graph().stats().submaps_retired, team.graph().stats().retired_bytes / 1048576.0,
              FLAGS_retire_revisited_share);
  if (FLAGS_attach_revisits && FLAGS_retire_revisited_share > 0) {
    std::printf("revisits: %d scans attached to their retired submaps, %d of their loop closures released, %d "
                "constraints between submaps in their place (--attach_revisits); %d of them keep no points (%.1f MiB "
                "freed, --revisit_points_min_travel=%g)\n",
                team.graph().stats().nodes_attached, team.graph().stats().closures_released,
                team.graph().stats().revisit_summaries, team.graph().stats().nodes_points_released,
                team.graph().stats().points_released_bytes / 1048576.0, FLAGS_revisit_points_min_travel);
  }
  if (FLAGS_max_map_store_mib > 0) {
    std::printf("map store: %d submaps evicted (%.1f MiB) to stay within --max_map_store_mib=%g per robot\n",
                team.graph().stats().submaps_evicted, team.graph().stats().evicted_bytes / 1048576.0,
                FLAGS_max_map_store_mib);
  }
  for (int r = 0; r < team.num_robots(); ++r) {
    const std::string frame = team.InCommonFrame(r) ? "in the common frame at " + PoseText(team.CommonTRobot(r))
                                                    : "NOT MERGED: own frame (not " + robots[0].name + "'s)";
    const OnlineEstimatorStats& stats = team.estimator(r).stats();
    std::string tilt;
    if (stats.floor_tilt_updates > 0) {
      char text[160];
      std::snprintf(text, sizeof(text), "; the floor corrected its attitude on %d scans (roll %+.3f deg, pitch %+.3f deg)",
                    stats.floor_tilt_updates, stats.floor_tilt_radians.x() / kDeg, stats.floor_tilt_radians.y() / kDeg);
      tilt = text;
    }
    if (stats.first_node_rematch_radians.has_value()) {
      char text[160];
      std::snprintf(text, sizeof(text), "; its first scan's heading in its finished first submap %+.3f deg "
                    "(--rematch_first_node)", *stats.first_node_rematch_radians / kDeg);
      tilt += text;
    }
    if (walls_seen_through[r] > 0) {
      char text[160];
      std::snprintf(text, sizeof(text), "; %d wall cells a teammate saw through left out of its walls.pgm",
                    walls_seen_through[r]);
      tilt += text;
    }
    std::printf("%s: %d nodes, %s%s\n", robots[r].name.c_str(), team.graph().num_nodes(r), frame.c_str(), tilt.c_str());
  }
  for (const TeamTagPlace& tag : team.TagPlaces()) {
    const TagPlace& p = tag.place;
    std::printf("%s: tag place %s: id %d, %d of %zu sightings agree%s\n", robots[tag.robot].name.c_str(),
                PoseText(p.robot_T_tag).c_str(), p.tag_id, p.votes, p.members.size(),
                p.outvoted    ? " (not used: a place next to it has more votes for that id)"
                : !p.confirmed ? " (not confirmed)"
                : p.ambiguous  ? " (ambiguous: id confirmed elsewhere too)"
                               : "");
  }
  const double duration = last_stamp - first_stamp;
  std::printf("time: %.2f s wall (%.2f s CPU, one thread), data duration %.1f s, real-time factor %.1fx (%.1fx on CPU "
              "time)\n",
              wall_seconds, cpu_seconds, duration, duration / wall_seconds, duration / cpu_seconds);

  // Against the simulator's truth: robot frames are the bodies at their first TRUTH.
  bool have_truth = true;
  for (const RobotData& robot : robots) have_truth = have_truth && !robot.log.truth.empty();
  if (have_truth) {
    auto truth_pair = [&](int i, int j) { return Between(robots[i].log.truth.front().pose, robots[j].log.truth.front().pose); };
    for (const TeamMergeEvent& e : team.events()) {
      for (const RobotPairPose& p : e.after) {
        std::string before;
        for (const RobotPairPose& b : e.before) {
          if (b.robot_i == p.robot_i && b.robot_j == p.robot_j) before = "before " + PairError(b.i_T_j, truth_pair(p.robot_i, p.robot_j)) + ", ";
        }
        std::printf("truth: after %s %s-%s at t=%.2f s: %s-%s %s%s\n",
                    EventTruthName(e.kind),
                    robots[e.robot_a].name.c_str(), robots[e.robot_b].name.c_str(), e.stamp_seconds,
                    robots[p.robot_i].name.c_str(), robots[p.robot_j].name.c_str(), before.c_str(),
                    ("after " + PairError(p.i_T_j, truth_pair(p.robot_i, p.robot_j))).c_str());
      }
    }
    // Each robot's own map has drift: the frame it built sits where the SE(2) alignment of its
    // own-frame trajectory onto the truth puts it. Against those frames the error is the
    // merger's alone (how well it joined the maps as they were built).
    std::vector<Pose2> world_T_built(team.num_robots());
    for (int r = 0; r < team.num_robots(); ++r) {
      const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(team.estimator(r).Trajectory(), robots[r].log.truth);
      world_T_built[r] = ate.truth_T_estimate;
      // The start-frame drift is what the robot-pair errors above inherit from this robot.
      const StartFrameDrift drift = ComputeStartFrameDrift(team.estimator(r).Trajectory(), robots[r].log.truth);
      std::printf("truth: %s own map: ATE rmse %.3f m, %.2f deg (after SE(2) alignment); drift from its start frame "
                  "(no alignment) at the end %.3f m, %+.2f deg, largest %.3f m (t = %.1f s), %.2f deg (t = %.1f s)\n",
                  robots[r].name.c_str(), ate.translation_rmse_meters, ate.rotation_rmse_degrees,
                  drift.final_translation_meters, drift.final_rotation_degrees, drift.max_translation_meters,
                  drift.max_translation_stamp_seconds, drift.max_rotation_degrees, drift.max_rotation_stamp_seconds);
    }
    // Each constraint's match against the truth, with the trajectories taken out (the submap placed
    // by its own nodes' truth): what the matches got wrong, apart from the robots' drift.
    std::map<int, std::vector<StampedPose2>> truth_by_robot;
    std::vector<std::string> names;
    for (int r = 0; r < team.num_robots(); ++r) {
      truth_by_robot[r] = robots[r].log.truth;
      names.push_back(robots[r].name);
    }
    const std::vector<ConstraintTruthError> constraint_errors = ConstraintTruthErrors(team.graph(), truth_by_robot);
    for (int a = 0; a < team.num_robots(); ++a) {
      for (int b = 0; b < team.num_robots(); ++b) {
        std::vector<ConstraintTruthError> kept;
        for (const ConstraintTruthError& e : constraint_errors) {
          if (!e.removed && e.submap.robot == a && e.node.robot == b) kept.push_back(e);
        }
        if (kept.empty()) continue;
        const ConstraintTruthSummary c = SummarizeConstraintTruth(kept);
        const std::string what = a == b ? robots[a].name + " loop closures"
                                        : robots[b].name + " nodes in " + robots[a].name + "'s submaps";
        std::printf("truth: %s against the truth (each submap placed by its own nodes' truth): %d, median %.3f m / "
                    "%.2f deg, max %.3f m / %.2f deg, mean signed rotation %+.3f deg\n",
                    what.c_str(), c.count, c.median_translation_meters, c.median_rotation_degrees,
                    c.max_translation_meters, c.max_rotation_degrees, c.mean_signed_rotation_degrees);
      }
    }
    if (const Status status = WriteConstraintTruthErrors((std::filesystem::path(FLAGS_out) / "constraints_truth.txt").string(),
                                                         constraint_errors, names);
        !status.ok()) {
      std::cerr << "hetslam_team: " << status.message() << "\n";
      return 1;
    }
    for (int i = 0; i < team.num_robots(); ++i) {
      for (int j = i + 1; j < team.num_robots(); ++j) {
        Pose2 i_T_j;
        if (!team.RelativePose(i, j, &i_T_j)) {
          std::printf("truth: final %s-%s: not merged\n", robots[i].name.c_str(), robots[j].name.c_str());
          continue;
        }
        std::printf("truth: final %s-%s: %s (estimate %s, truth %s); against the frames as built (alignment): %s\n",
                    robots[i].name.c_str(), robots[j].name.c_str(), PairError(i_T_j, truth_pair(i, j)).c_str(),
                    PoseText(i_T_j).c_str(), PoseText(truth_pair(i, j)).c_str(),
                    PairError(i_T_j, Between(world_T_built[i], world_T_built[j])).c_str());
      }
    }
    // Each robot's trajectory in the common frame against its truth brought into the common frame
    // by robot 0's map alignment: how well its map overlays robot 0's as built.
    for (int r = 0; r < team.num_robots(); ++r) {
      if (!team.InCommonFrame(r)) continue;
      std::vector<StampedPose2> truth = robots[r].log.truth;
      for (StampedPose2& p : truth) p.pose = world_T_built[0].inverse() * p.pose;
      const std::vector<StampedPose2> estimate = team.CommonTrajectory(r);
      double sum = 0.0, max = 0.0;
      int n = 0;
      size_t k = 0;
      for (const StampedPose2& e : estimate) {
        while (k + 1 < truth.size() && truth[k + 1].stamp_seconds <= e.stamp_seconds + 1e-6) ++k;
        if (std::abs(truth[k].stamp_seconds - e.stamp_seconds) > 1e-3) continue;
        const double d = (truth[k].pose.translation() - e.pose.translation()).norm();
        sum += d * d;
        max = std::max(max, d);
        ++n;
      }
      if (n > 0) {
        std::printf("truth: %s in the common frame against %s's map as built (no alignment of its own): %d poses, "
                    "rmse %.3f m, max %.3f m\n",
                    robots[r].name.c_str(), robots[0].name.c_str(), n, std::sqrt(sum / n), max);
      }
    }
  }
  std::printf("wrote %s/{<robot>/trajectory.txt, <robot>/map.pgm, merged_map.pgm, merged_map.png, constraints.txt, "
              "frames.txt%s}\n",
              FLAGS_out.c_str(), have_truth ? ", constraints_truth.txt" : "");
  return 0;
}

}  // namespace
}  // namespace hetslam

int main(int argc, char** argv) {
  gflags::SetUsageMessage(
      "a team of robots mapping together: each robot's laser SLAM in its own frame, joined through shared AprilTags\n"
      "(paper eq. 4, refined by scan matching) in one anchored pose graph; maps merged as one observation.\n"
      "  hetslam_team --manifest=DIR/team.txt --out=OUT [--wrong_tag_id_rate=0.2]\n"
      "Prints when each robot pair merged and with which constraints, and, when the logs have TRUTH, each pair's\n"
      "relative pose error. Writes OUT/<robot>/trajectory.txt (t x y theta, frame of the manifest's first robot;\n"
      "OUT/frames.txt flags a robot that never merged: it keeps its own frame), OUT/<robot>/map.pgm + .yaml,\n"
      "OUT/merged_map.pgm + .yaml + .png and OUT/constraints.txt (every inter-robot constraint, accepted or\n"
      "rejected, and why); with TRUTH also OUT/constraints_truth.txt (each loop closure and inter-robot constraint\n"
      "against the truth, its submap placed by its own nodes' truth: the matches' own error, drift taken out).");
  hetslam::PrintProgramHelpIfAsked(argc, argv, __FILE__);
  gflags::ParseCommandLineFlags(&argc, &argv, true);
  google::InitGoogleLogging(argv[0]);
  FLAGS_logtostderr = true;
  if (argc > 1) {
    std::cerr << "hetslam_team: unexpected argument '" << argv[1] << "' (flags are --name=value; see --help)\n";
    return 2;
  }
  return hetslam::Run();
}
