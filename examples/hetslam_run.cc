// hetslam_run: single-robot laser SLAM on a CARMEN log, a hetslam robot log or a ROS 1 bag
// (attitude, 2.5D projection, command prediction); writes the map and trajectory.
//
//   hetslam_run --log=intel.clf --out=out/intel
//   hetslam_run --log=demo.bag --out=out/demo --trajectory_bag=out/demo/trajectory.bag
//   hetslam_run --log=sim/log.clf --truth=sim/truth.txt --out=out/sim
//   hetslam_run --log=team/nao/log.txt --out=out/nao      (scored against the log's TRUTH)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#ifdef __GLIBC__
#include <malloc.h>  // mallopt, malloc_trim
#endif

#include "core/euler.h"
#include "core/file_io.h"
#include "core/g2o_io.h"
#include "core/map_io.h"
#include "core/measurement_log.h"
#include "core/ros_bag.h"
#include "core/trajectory_io.h"
#include "core/trajectory_metrics.h"
#include "examples/flag_help.h"
#include "frontends/constraint_truth.h"
#include "frontends/loop_closer.h"
#include "frontends/online_estimator.h"
#include "merger/map_picture.h"
#include "gflags/gflags.h"
#include "glog/logging.h"

DEFINE_string(log, "", "Log to map: a CARMEN log (.clf: FLASER/ROBOTLASER1/RAWLASER1 scans, ODOM optional), or a "
              "hetslam robot log (a file whose first line is `HSLOG 1`, e.g. a simulated robot's <dir>/<robot>/log.txt: "
              "LASER scans with their MOUNT, ODOM optional, TRUTH used as --truth when that is not given; ATTITUDE/ALTITUDE "
              "for the 2.5D projection, see --use_attitude), or a ROS 1 bag (.bag, plain or bz2/lz4: sensor_msgs/LaserScan, "
              "sensor_msgs/Imu as MARG samples, nav_msgs/Odometry, geometry_msgs/Twist commands; see --scan_topic). "
              "Required.");
DEFINE_string(scan_topic, "", "ROS bags: the sensor_msgs/LaserScan topic to map. Empty = the bag's only LaserScan topic "
              "(among several: /scan).");
DEFINE_string(imu_topic, "", "ROS bags: the sensor_msgs/Imu topic whose rates and accelerations feed the MARG attitude "
              "filter (and whose orientation, when present, is the --attitude_source=logged attitude). Empty = the "
              "bag's only Imu topic (among several: /imu/data, /imu); none = no IMU.");
DEFINE_string(odom_topic, "", "ROS bags: the nav_msgs/Odometry topic (used with --use_odometry). Empty = the bag's only "
              "Odometry topic (among several: /odom); none = no odometry.");
DEFINE_string(cmd_topic, "", "ROS bags: the geometry_msgs/Twist or TwistStamped command topic (see --use_commands). "
              "Empty = the bag's only such topic (among several: /cmd_vel); none = no commands.");
DEFINE_string(image_topic, "", "ROS bags: the sensor_msgs/Image topic, read only with --image_dir. Empty = the bag's only "
              "Image topic.");
DEFINE_string(image_dir, "", "ROS bags: folder that receives the image topic's images as 8-bit grey PGM files (empty = "
              "images are not read; single-robot SLAM does not use them).");
DEFINE_string(base_frame, "base_link", "ROS bags: the body frame; the laser and IMU mounts are looked up from it in "
              "/tf_static (frames not connected to it count as mounted at the body origin, with a warning).");
DEFINE_string(laser_mount, "", "ROS bags: the laser mount in the body frame as x,y,z,roll,pitch,yaw (metres, degrees); "
              "overrides /tf_static. Empty = from /tf_static.");
DEFINE_string(trajectory_bag, "", "Also write the trajectory as a ROS 1 bag at this path: geometry_msgs/PoseStamped on "
              "/hetslam/pose and one nav_msgs/Path on /hetslam/path at the end, frame_id map (plays in RViz).");
DEFINE_string(out, "", "Output folder; created if missing. Receives map.pgm/.yaml (the structure localisation uses), map.png (a readable picture: walls, other structure, floor obstacles, the trajectory, a scale bar and a legend), planner.pgm/.yaml (structure and floor obstacles: what a planner must avoid), floor_obstacles.pgm/.yaml and walls.pgm/.yaml (when any were seen), trajectory.txt, particles.txt (the particle filter's count over time) and, with loop closure, loop_closures.txt (every accepted closure, measured and final) and frontend_trajectory.txt (the uncorrected front-end poses). Required.");
DEFINE_string(truth, "", "Optional ground-truth trajectory (`t x y theta` per line, e.g. a simulator's truth.txt): "
              "prints the absolute trajectory error after SE(2) alignment.");
DEFINE_bool(lenient, false, "Skip malformed log lines with a count instead of stopping at the first one.");
DEFINE_double(max_time_gap, 60.0, "Largest time gap between a log's measurements that is bridged (seconds; 0 = no "
              "bound): a measurement stamped later than that after every earlier one is an error naming file:line "
              "(with --lenient it is dropped and counted). A gap is never integrated by the motion prediction.");
DEFINE_bool(use_odometry, false, "Predict each scan's pose from the log's odometry. Off by default: the pipeline is "
            "odometry-free and uses --prediction instead.");
DEFINE_bool(use_commands, true, "Robot logs with COMMAND lines: the EKF predicts each scan's pose from the "
            "controller's commanded velocities (paper eq. 3); with MARG samples and no commands, from the MARG rates. "
            "--use_odometry takes precedence; CARMEN logs have neither.");
DEFINE_string(prediction, "constant_velocity", "Motion prediction without odometry: constant_velocity (extrapolate "
              "--velocity_fraction of the last translation and --angular_velocity_fraction of the last turn) or stationary.");
DEFINE_double(velocity_fraction, 0.5, "Fraction of the last scan-to-scan translation (robot frame) extrapolated by "
              "constant_velocity, in [0, 1.5].");
DEFINE_double(angular_velocity_fraction, 0.0, "Fraction of the last scan-to-scan heading change extrapolated by "
              "constant_velocity, in [0, 1.5].");
DEFINE_double(resolution, 0.05, "Grid cell size in metres (paper: 5 cm).");
DEFINE_double(sigma, 0.10, "Likelihood field p_hit ~ exp(-d / sigma): sigma in metres.");
DEFINE_string(refine_interpolation, "distances", "What the front end's Ceres refinement of a scan match interpolates "
              "between cell centres: distances (each cell centre's distance to the nearest surface, so the kernel "
              "peaks on the wall itself; see factors/scan_cost.h), the default, or values (the likelihood field's "
              "values; a wall is pulled towards the nearest cell centre, by up to half a cell).");
DEFINE_int32(refine_max_iterations, 20, "Iteration limit of every scan match's Ceres refinement (front end, loop "
             "search, wide loop search), in [0, 1000]. With --refine_function_tolerance, the stopping rule that "
             "tests/bench/run_sensitivity.sh varies to show how far the real logs' figures move.");
DEFINE_double(refine_function_tolerance, 1e-6, "Every scan match's Ceres refinement stops when a step changes its "
              "cost by less than this fraction (Ceres' function_tolerance), in (0, 1).");
DEFINE_double(field_max_distance, 0.3, "Likelihood field window radius in metres (beyond it p_hit = 0).");
DEFINE_double(linear_window, 1.2, "Scan matcher search window, ± metres around the prediction in x and y.");
DEFINE_double(angular_window_deg, 40.0, "Scan matcher search window, ± degrees around the predicted heading.");
DEFINE_double(fallback_angular_window_deg, 92.0, "A match that fails or scores below --fallback_below_score is "
              "searched again over ± this many degrees and ±2 m (sharp turns between sparse scans).");
DEFINE_double(fallback_below_score, 0.35, "Score below which the wider fallback search runs (0 disables it).");
DEFINE_double(min_score, 0.10, "Minimum correlative score (mean p_hit) for a match to count; else the scan is "
              "inserted at the prediction and counted as a failure.");
DEFINE_double(free_space_penalty, 0.5, "Score penalty for each scan point that lands in known free space away from any "
              "hit (disambiguates corridors); 0 disables.");
DEFINE_double(translation_penalty, 0.05, "Weak motion prior: score penalty per square metre of distance from the prediction.");
DEFINE_double(rotation_penalty, 0.0, "Weak motion prior: score penalty per square radian of heading change from the prediction.");
DEFINE_double(matching_voxel, 0.20, "Thin the points used for scan matching to one per voxel of this size in metres, "
              "so near walls do not outvote far structure (0 = use every point). The map gets every point.");
DEFINE_bool(refine_on_voxel_ends, false, "The search places each scan on the first beam of every --matching_voxel voxel; the "
            "refinement of its pose uses each voxel's first and last beam (one where it has one): the first beam "
            "alone is a surface's end on one side of the scan only and turned every simulated front end the same "
            "way, +0.04 to +2.25 deg a run; with both ends the simulated robots' worst heading from their start "
            "is 0.56 deg (1.13 with the first beam alone), for about 3% more time on FR079. Off by default: Intel and ACES each end far "
            "off under one of tests/bench/run_sensitivity.sh's ten stopping rules (README, \"The refinement on "
            "each voxel's first and last beam\"). Only with --norefine_on_all_points (on by default, it takes "
            "precedence over this); takes precedence over "
            "--refine_on_middle_beams.");
DEFINE_bool(refine_on_middle_beams, false, "The search places each scan on the first beam of every --matching_voxel voxel; the "
            "refinement of its pose uses each voxel's middle beam (the first beam is a surface's end on one side "
            "of the scan only, which turned the pose that way scan after scan: the simulated 2.5D robots' worst "
            "heading from their start up to 1.13 deg, up to 0.58 with this but the corridor's 0.99). An even "
            "voxel's middle is the midpoint of its two middle beams. Off by default: the simulated office loop's "
            "corrected trajectory and the corridor's get worse with it (README, Teams). Only with "
            "--norefine_on_all_points (on by default, it takes precedence over this).");
DEFINE_bool(refine_on_all_points, hetslam::LocalSlamOptions().refine_on_all_points,
            "The search places each scan on the first beam of every --matching_voxel voxel; the refinement of its "
            "pose (front end and loop closures) uses every beam. No choice within a voxel: its first beam lies "
            "nearest the side the sweep enters by, which turned the simulated robots' front ends +0.04 to +2.25 deg "
            "a run (-0.57 to +0.51 with this). On by default since session 51 (README, \"Every point refined by "
            "default\"); --norefine_on_all_points refines on the searched beams only: the office loop's seed 1 "
            "0.046 -> 0.030 m, ACES 0.102 -> 0.095 m, Intel 7-9% and FR079 14-22% less wall time, but Intel 0.0192 -> "
            "0.0230 m, MIT CSAIL 0.098 -> 0.157 m and every simulated robot's heading turned one way. Takes "
            "precedence over --refine_on_voxel_ends and --refine_on_middle_beams.");
DEFINE_double(max_range, 30.0, "Ignore beam end points farther than this (metres).");
DEFINE_double(flaser_max_range, 81.0, "FLASER readings at or above this range mean 'no return' (metres).");
DEFINE_bool(no_loop_closure, false, "Run the scan-matching front end alone against one global map (no submaps, no "
            "loop closure, no solves): the walking-skeleton path, kept for comparison.");
DEFINE_int32(scans_per_submap, 40, "Scans per submap of the loop-closing pipeline (a new submap starts every half of it).");
DEFINE_double(loop_min_score, 0.55, "Minimum mean likelihood of a loop-closure match to accept it.");
DEFINE_double(loop_linear_window, 2.0, "Loop-closure search window, ± metres around the graph's estimate (paper: 2 m).");
DEFINE_double(loop_angular_window_deg, 45.0, "Loop-closure search window, ± degrees (paper: 45°).");
DEFINE_int32(solve_every_n_loop_closures, 10, "Re-optimise the pose graph once this many loop closures were accepted "
             "since the last solve and --solve_min_new_nodes scans were added.");
DEFINE_double(max_map_store_mib, 0.0, "Lifelong memory: bound the finished submaps' maps to this many MiB; when a "
              "finished submap takes them over it, the submaps other kept ones cover most are evicted (no longer searched "
              "for loop closures; the trajectory and the rendered maps keep them) and counted in the summary. 0 = no "
              "bound (offline runs keep every map).");
DEFINE_double(retire_revisited_share, 0.9, "Revisits attach to the map they revisit: a submap that finishes with at "
              "least this share of its occupied cells within 0.1 m of earlier submaps' structure (those a loop search of "
              "its scans could find) adds nothing new; its map is freed at once (no longer searched for loop closures; "
              "the trajectory and the rendered maps keep it) and counted in the summary. In [0, 1]; 0 = off (every "
              "submap kept).");
DEFINE_bool(rematch_first_node, true, "The frame is the body at the first scan: when the first submap is finished, "
            "the first scan is refined against it and the map turned around the first pose to the heading the finished "
            "map gives it (the next few scans' matches can turn a young submap's map against the first scan; 0.4-0.6 "
            "deg on a simulated UAV). --norematch_first_node keeps the first scan's heading as inserted.");
DEFINE_bool(attach_revisits, true, "With --retire_revisited_share: after every solve the scans of retired submaps "
            "leave the pose graph and ride on their submap at their solved pose there (in the trajectory as before); "
            "in place of their constraints and loop closures come a few between submaps that sum up what those said. "
            "The rendered maps keep what they saw. Re-driving mapped space then costs a scan's pose and points, not "
            "its constraints.");
DEFINE_int32(solve_min_new_nodes, 20, "Scans added since the last solve before the graph is re-optimised again "
             "(bounds the solves of dense logs, where closures arrive at almost every scan).");
DEFINE_double(solve_min_new_node_share, 0.02, "... and at least this share of the graph's nodes (in [0, 1]): a solve "
              "costs in proportion to the graph, so the spacing grows with it and a long run's solves cost its length, not "
              "its square. 0.02 changes nothing below 1000 nodes; 0 = a fixed spacing.");
DEFINE_int32(loop_min_node_separation, 40, "Do not search for loop closures in submaps whose last scan is fewer than "
             "this many scans old (the front end built them moments ago).");
DEFINE_double(narrow_linear_window, 0.4, "Front end: first search ± this many metres and ± --narrow_angular_window_deg "
              "around the prediction; keep that result when it scores >= --narrow_accept_score away from the "
              "narrow window's border, else search the full windows. 0 = always search the full windows.");
DEFINE_double(narrow_angular_window_deg, 10.0, "Front end narrow first try: ± degrees (see --narrow_linear_window).");
DEFINE_double(narrow_accept_score, 0.4, "Front end narrow first try: minimum score to keep its result (see --narrow_linear_window).");
DEFINE_double(loop_search_min_travel, 0.3, "Search for loop closures again only after the robot moved this many metres "
              "(or turned --loop_search_min_turn_deg) since the last search.");
DEFINE_double(loop_search_min_turn_deg, 20.0, "See --loop_search_min_travel.");
DEFINE_bool(loop_wide_search, true, "Once the drift bound (grown with the travel since the last solve) exceeds "
            "--loop_linear_window and the standard search finds nothing, also search a wide window (up to "
            "--loop_wide_window m), without motion prior; two wide matches of different scans that agree on the "
            "correction enter the graph (long corridors). Each submap is searched within the smaller of that bound "
            "and the one grown with the travel since the submap began, and not at all when that is within "
            "--loop_linear_window.");
DEFINE_int32(loop_max_submaps, 4, "Loop search budget: match each node against at most this many finished submaps, "
             "those its scan overlaps most at its estimate (then the nearest), so a search costs the same however long "
             "the run; submaps that cannot reach --loop_min_score within the drift bound are never searched. 0 = every "
             "submap whose box holds the node.");
DEFINE_double(loop_wide_window, 8.0, "Wide loop search: largest window, ± metres (see --loop_wide_search).");
DEFINE_double(loop_wide_spacing, 1.0, "Wide loop search: search again only after this much travel (metres) since the "
              "last wide search (see --loop_wide_search).");
DEFINE_double(loop_wide_min_score, 0.6, "Wide loop search: minimum mean likelihood of a match (see --loop_wide_search).");
DEFINE_double(loop_agreeing_min_score, hetslam::LoopCloserOptions().agreeing_min_score,
              "Revisits seen the other way round: where the wide loop search would run (no closure, the drift bound "
              "beyond the ±2 m window, once per --loop_wide_spacing), the node is also searched in the standard "
              "window for matches scoring at least this (below --loop_min_score: a scan that overlaps an old submap "
              "only in part); such a match is a closure only once a later node's calls for the same correction of "
              "the estimate (within 5 cm and 0.57 degrees). 0 = off (the default); 0.35 in "
              "examples/flags/unbiased.flags (README, \"Mirrored worlds\").");
DEFINE_double(loop_degenerate_drop_ratio, 0.1, "A loop-closure match whose score drops, shifted 0.1-0.3 m along its "
              "flattest direction, by less than this fraction of its drop along the steepest (a corridor's walls) "
              "places the scan poorly along that direction: the closure's information along it is scaled by (drop "
              "ratio / this), its standard deviation there capped by --loop_weak_sigma, and a wide-search result is "
              "dropped. 0 = off.");
DEFINE_double(intra_sigma, hetslam::SubmapGraphOptions().intra_translation_sigma_meters,
              "Pose graph: standard deviation (metres) of each scan's constraint to the submaps it went into (the "
              "front end's own chain). With --intra_rotation_sigma_deg, how far the graph trusts the front end "
              "against the loop closures (--loop_sigma): smaller, a stiffer chain that the closures pull less. In "
              "(0, 1000].");
DEFINE_double(intra_rotation_sigma_deg, hetslam::SubmapGraphOptions().intra_rotation_sigma_radians * 180.0 / M_PI,
              "Pose graph: standard deviation (degrees) of the heading of each scan's constraint to its submaps (see "
              "--intra_sigma).");
DEFINE_double(loop_sigma, hetslam::SubmapGraphOptions().loop_translation_sigma_meters,
              "Pose graph: standard deviation (metres) of a loop closure (along a degenerate closure's weak "
              "direction up to --loop_weak_sigma), Huber-robust beyond 3 of them. In (0, 1000].");
DEFINE_double(loop_rotation_sigma_deg, hetslam::SubmapGraphOptions().loop_rotation_sigma_radians * 180.0 / M_PI,
              "Pose graph: standard deviation (degrees) of a loop closure's heading (see --loop_sigma).");
DEFINE_double(loop_weak_sigma, 2.0, "Largest standard deviation (metres) of a degenerate loop closure along its weak "
              "direction (see --loop_degenerate_drop_ratio); the consistency check ignores that direction.");
DEFINE_double(loop_weak_direction_snap_deg,
              hetslam::LoopCloserOptions().matcher.weak_direction_snap_radians * 180.0 / M_PI,
              "A degenerate loop closure's weak direction (the score profile's flattest of 16 directions, 11.25 "
              "degrees apart) is replaced by the direction of the scan's surfaces when the two are within this many "
              "degrees: a corridor's closure lies up to metres off along its walls, and a direction a few degrees "
              "off turns part of that into a wrong claim across them. In [0, 90]; 0 = off (README, \"Degenerate "
              "closures along the walls\").");
DEFINE_double(map_min_hit_share, 0.2, "The written maps (map.pgm, walls.pgm, planner.pgm and the structure in map.png) "
              "leave out the noise tail behind walls, which no ray ever clears: an occupied cell hit fewer times than "
              "this share of a neighbour's hits, with never-observed space on its far side from that neighbour, is "
              "unknown. In [0, 1]; 0 keeps every hit cell. Matching, loop closure and the trajectory are unaffected.");
DEFINE_double(wall_min_length, 0.25, "walls.pgm keeps only pieces of wall at least this long (metres, the diagonal of "
              "a piece's bounding box; hits two cells apart join one piece): a table leg or a post is hit at several "
              "heights like a wall but is no surface. In [0, 100]; 0 keeps every piece.");
DEFINE_double(revisit_points_min_travel, 0.5, "With --attach_revisits: a scan attached to a retired submap keeps its "
              "points for the written maps only when it lies at least this many metres from (or turned "
              "--revisit_points_min_turn_deg against) the last scan of that submap that kept them; the others keep their "
              "pose and floor obstacles. Re-driving mapped space then costs a scan's points per so much travel, not per "
              "scan. 0 with --revisit_points_min_turn_deg=0: every attached scan keeps its points.");
DEFINE_double(revisit_points_min_turn_deg, 15.0, "See --revisit_points_min_travel (degrees).");
DEFINE_string(g2o_out, "", "Write the final pose graph (submaps and scans as VERTEX_SE2, constraints as EDGE_SE2) to this "
              "g2o file.");
DEFINE_double(flaser_fov_deg, 180.0, "Field of view that FLASER beams are spread over, in degrees (FLASER lines do not "
              "record it; PARAM laser_*_fov in the log overrides it).");
DEFINE_bool(use_attitude, true, "Robot logs: project each scan with the body attitude (see --attitude_source) and "
            "ALTITUDE height under the 2.5D assumption and drop floor hits (points lower than --floor_max_height); "
            "false = treat every scan as level (plain 2D). CARMEN logs carry no attitude.");
DEFINE_string(attitude_source, "marg", "Where the attitude for the 2.5D projection comes from: marg (our MARG filter on "
              "the log's raw MARG samples) or logged (the log's ATTITUDE lines, the sensor's own filter).");
DEFINE_double(floor_tilt_gain, hetslam::OnlineEstimatorOptions().floor_tilt_gain,
              "With an attitude: each scan whose floor hits lie on a line away from the body (a laser tilted down) "
              "corrects the attitude's roll and pitch for the later scans by this fraction of the tilt the line says "
              "the projection got wrong (an accelerometer bias tilts the MARG filter's attitude for good); 0 = off.");
DEFINE_double(floor_max_height, 0.08, "With an attitude: end points lower than this above the floor (metres) are floor "
              "hits, neither matched nor mapped.");
DEFINE_double(floor_obstacle_max_height, 0.35, "With an attitude: points at most this high above the floor (metres) and "
              "at least --floor_obstacle_min_drop below the sensor (a beam tilted down) are floor obstacles: never "
              "matched, never in map.pgm, kept in planner.pgm and floor_obstacles.pgm (paper III-E); 0 = off.");
DEFINE_double(floor_obstacle_min_drop, 0.15, "See --floor_obstacle_max_height (metres; exceeds what a degree of attitude "
              "error makes at the laser's range, so a level laser labels none).");
DEFINE_double(suspend_floor_fraction, 0.2, "With an attitude: when more than this fraction of a scan's valid beams hit the "
              "floor, matching and map updates stop for that scan and the EKF carries the pose (paper III-A); 1 = never.");
DEFINE_double(wall_weight, 1.0, "Paper III-E, walls weigh more in scan matching: w in [1, 100]. With w > 1 each submap "
              "also keeps the likelihood field of its wall cells (cells hit at heights spanning --wall_min_height_span: "
              "invariant under the 2.5D assumption), and the front end's matcher scores a point L + (w - 1) L_wall "
              "where the candidate pose puts it in the branch-and-bound search (w on a wall, 1 on other structure; see "
              "--wall_weight_refinement). Logs without attitude have no "
              "walls: no effect there. 1 = off (the loop closer never weighs walls).");
DEFINE_bool(wall_weight_refinement, false, "With --wall_weight > 1: weigh walls in the Ceres refinement too (a second "
            "scan cost over the wall field), not only in the branch-and-bound search. Off: measured, it made "
            "team_overlap's drone worse (README, map semantics).");
DEFINE_double(wall_min_height_span, 0.3, "A cell hit at heights spanning at least this much (metres) is a wall.");
DEFINE_double(degenerate_ratio, 0.3, "When a match is predicted from a source that measures the motion (commands through "
              "the EKF, or odometry) and the smaller eigenvalue of its translational information is below this fraction "
              "of the larger (a corridor, a tilted head seeing side walls only), keep the prediction along the weak "
              "direction; 0 = off. Scans predicted by the front end's own extrapolation always take the whole match.");
DEFINE_double(degenerate_drop_ratio, 0.25, "Like --degenerate_ratio, but from the score: when, shifted 0.1-0.3 m along "
              "its flattest direction, the scan's score drops by less than this fraction of its steepest drop (a "
              "featureless corridor), the prediction is kept along that direction; 0 = off.");
DEFINE_double(command_response, -1.0, "Seconds of the platform's velocity response to a command: the EKF's command model "
              "lets the velocity follow the commanded one with this first-order lag (a multirotor's velocity controller); "
              "0 = the velocity is the command (paper eq. 3). Negative (default): the log's PARAM "
              "command_response_seconds when it has one (the simulator's UAVs: 0.25), else 0.");
DEFINE_double(degenerate_sigma, 0.1, "Standard deviation (metres) of a degenerate match along its weak direction in the "
              "EKF update: there the EKF's prediction (commands, odometry) carries the pose and its covariance grows.");
DEFINE_int32(max_particles, 6, "Rao-Blackwellized particle filter (paper §III-A): particles spawned under ambiguity (the "
             "first match after suspended matching failed, or with --spawn_on_degenerate a degenerate match under an "
             "uncertain prediction: drawn from the prediction's covariance; or two at the modes of an ambiguous match, "
             "see --spawn_on_second_mode), weighted by their scans against the "
             "submaps as they were at the spawn and the earlier map, resampled, collapsed when the ambiguity is gone. "
             "1 = the single-particle pipeline. Counts over time go to particles.txt.");
DEFINE_uint64(particle_seed, 1, "Seed of the particle filter's draws (same log, flags and seed: same output bytes).");
DEFINE_double(spawn_min_sigma, 0.05, "Spawn particles only when the prediction's standard deviation (metres; along the "
              "weak direction of a degenerate match, else its largest) is at least this (see --max_particles).");
DEFINE_bool(spawn_on_degenerate, false, "Also spawn particles along the weak direction of a degenerate match (a "
            "corridor) when the prediction is uncertain there (see --spawn_min_sigma). Off: particles spawn only when "
            "the first match after suspended matching failed or scored below 0.5, or at a second mode (see "
            "--spawn_on_second_mode).");
DEFINE_bool(spawn_on_second_mode, true, "Also spawn particles when a wide search of the front end's matcher (the "
            "prediction was not trusted: a gap between scans, a sharp turn without odometry) finds a second mode, a pose "
            "farther than --second_mode_exclusion (metres in x or y) or --second_mode_exclusion_deg from the best that "
            "scores at least --second_mode_score_ratio of it, and one of the two slides the robot sideways by at least "
            "three --sideslip_sigma: one particle goes on at each mode, weighted by its scans and, without a motion "
            "source, by its sideslip (see --max_particles).");
DEFINE_double(sideslip_sigma, 0.1, "Without a motion source, while several particles live: standard deviation (metres) "
              "of a robot's sideways slide between scans in the particles' weights (a robot drives and turns; it does "
              "not slide sideways). 0 = off (a holonomic robot), which also stops --spawn_on_second_mode.");
DEFINE_double(speed_change_sigma, 0.3, "Without a motion source: standard deviation (m/s) of the change of a robot's "
              "speed from one scan-to-scan motion to the next, in the particles' weights (with --sideslip_sigma) and "
              "where a scan fits two places along the direction of travel that no particle follows: the scan goes on "
              "at the place this motion model and the scan's likelihood favour (a corridor's length: there the wrong "
              "place is where the scan before was taken). 0 = off: the better-scoring place.");
DEFINE_double(mode_map_min_score, 0.5, "Where --speed_change_sigma weighs two places along the direction of travel: "
              "when the robot's finished submaps near either place hold the scan (its mean likelihood there at least "
              "this, in [0, 1], at one of them), the scan's likelihood against them weighs each place too (a robot "
              "re-driving mapped space: the earlier map knows which place is right). 1 = off.");
DEFINE_double(second_mode_exclusion, 0.5, "See --spawn_on_second_mode (metres, > 0).");
DEFINE_double(second_mode_exclusion_deg, 20.0, "See --spawn_on_second_mode (degrees, > 0).");
DEFINE_double(second_mode_score_ratio, 0.9, "See --spawn_on_second_mode, in (0, 1].");
DEFINE_bool(insert_while_ambiguous, false, "While several particles live, insert each particle's scans into its own "
            "copy of the active submaps at once (each extra particle then costs both submaps whole); off: every particle "
            "matches against the submaps as they were at the spawn, and the kept particle's scans go in at the "
            "collapse.");
DEFINE_int32(max_ambiguous_scans, 60, "Collapse to the best particle after this many scans at the latest (see "
             "--max_particles); its deferred scans then enter the graph.");
DEFINE_double(line_max_gap, 0.0, "Map surfaces, not dotted hits: neighbouring beams' end points at most this far apart "
              "(metres) that lie on a line make each hit stand for its piece of that line in the likelihood field (a "
              "wall seen at a grazing angle scores as a wall, not as dots); 0 = hit points only, the default (0.5 "
              "improves Intel but bends MIT CSAIL's map).");
DEFINE_double(frontier_margin, 0.3, "Leave out of a match the points whose surface, within this distance (metres) of "
              "where the prediction puts them, runs into ground the map never observed (the map's frontier, which "
              "pulls matches back along corridors); 0 = off.");
DEFINE_double(covariance_sigmas, 3.0, "With the EKF's prediction: search windows of the narrow windows plus this many "
              "standard deviations of its covariance (at most the full windows), no wider fallback.");
DEFINE_double(outlier_max_score, 0.5, "With a prediction's covariance (the EKF, odometry): a match scoring below this "
              "(mean likelihood) whose correction lies beyond --covariance_sigmas of the prediction is a failed match, "
              "and the scan goes in at the prediction; 0 = off.");
DEFINE_double(odometry_noise_fraction, 0.1, "With --use_odometry: the prediction's standard deviations are this fraction of "
              "the odometry increment, and the search windows follow them (no wide fallback); 0 = narrow, full and "
              "fallback windows as without odometry.");
DEFINE_double(motion_filter_distance, 0.01, "Motion filter: a scan that moved less than this (metres) from the last "
              "inserted scan, turned less than --motion_filter_angle_deg, tilted less than "
              "--motion_filter_attitude_deg and (with --motion_filter_time > 0) came within that many seconds of it is "
              "matched and goes into the active submaps (at most --scans_per_submap such scans each) but is no graph "
              "node and no step towards a new submap, so a robot standing still adds nothing (the default 1 cm with "
              "0.5° lets in every scan of a moving robot); 0 = off (every scan is a node).");
DEFINE_double(motion_filter_angle_deg, 0.5, "Motion filter: heading change (degrees) that makes a scan new.");
DEFINE_double(motion_filter_attitude_deg, 1.0, "Motion filter: roll or pitch change (degrees) that makes a scan new (a "
              "tilting head sees new heights).");
DEFINE_double(motion_filter_time, 0.0, "Motion filter: seconds after the last inserted scan that make a scan new (0 = "
              "time never does).");
DEFINE_double(densify_max_gap, 0.0, "Join the end points of neighbouring beams closer than this (metres) by points at "
              "the grid resolution before matching and mapping (0 = off).");
DEFINE_int32(max_scans, 0, "Process at most this many scans (0 = all).");
DEFINE_int32(progress_every, 100, "Print progress every N scans (0 = never).");
DEFINE_bool(keep_search_tables_over_solves, true,
            "Before each pose-graph solve, keep resident the pages of the scan matcher's search tables that the "
            "searches since the last solve used (the rest are given back), unless the process is within their size "
            "of its memory peak; --nokeep_search_tables_over_solves frees them all before every solve, and the next "
            "searches fault them in again (Intel: 28.8 instead of 20.2 thousand page faults). The same results "
            "either way (README, Performance: \"Search tables kept over solves\").");
DEFINE_int32(malloc_mmap_threshold_kib, 1024,
             "glibc: allocations of at least this many KiB get their own pages, returned when freed "
             "(0 = glibc's own threshold, which grows after a large block is freed). Every page given "
             "back is faulted in again when used again (~11 us a page on the VM of the README's figures): "
             "with 256 (and 256 for --malloc_trim_threshold_kib) the four shared logs took 34-106% more "
             "page faults and 6-26% more wall time; glibc's own (both flags 0) 42-66% fewer faults and "
             "another 3-15% less time, but FR079's peak memory up to 29.3 MiB instead of 28.4-28.7 "
             "(README, Performance: \"Page faults, again\").");
DEFINE_int32(malloc_trim_threshold_kib, 512,
             "glibc: free memory above this many KiB at the top of the heap is returned to the system "
             "(0 = glibc's own: 128 KiB once the mmap threshold is fixed, which returns and faults in "
             "again the pages of every finished submap's freed tiles). See --malloc_mmap_threshold_kib.");

namespace hetslam {
namespace {

bool Fail(const std::string& message) {
  std::cerr << "hetslam_run: " << message << "\n";
  return false;
}

// "x,y,z,roll,pitch,yaw" (metres, degrees) as robot_T_sensor.
bool ParseMount(const std::string& text, Eigen::Isometry3d* robot_T_sensor) {
  std::istringstream in(text);
  double v[6];
  char comma;
  for (int i = 0; i < 6; ++i) {
    if (!(in >> v[i]) || !std::isfinite(v[i])) return false;
    if (i < 5 && !(in >> comma && comma == ',')) return false;
  }
  if (in >> comma) return false;  // trailing text
  *robot_T_sensor = Eigen::Isometry3d::Identity();
  robot_T_sensor->translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  robot_T_sensor->linear() = RotationFromRollPitchYaw(v[3] * M_PI / 180.0, v[4] * M_PI / 180.0, v[5] * M_PI / 180.0);
  return true;
}

// The flags behind the option fields an IsValid message names, so that the user sees which
// flag to change (" (check --resolution)").
std::string FlagsNamedIn(const std::string& message) {
  static const std::pair<const char*, const char*> kFlagOf[] = {
      {"resolution_meters", "--resolution"},
      {"max_distance_meters", "--field_max_distance"},
      {"sigma_meters", "--sigma"},
      {"local: matcher: linear search windows", "--linear_window, --narrow_linear_window"},
      {"loop: matcher: linear search windows", "--loop_linear_window"},
      {"max_point_range_meters", "--max_range"},
      {"densify_max_gap_meters", "--densify_max_gap"},
      {"matching_voxel_meters", "--matching_voxel"},
      {"angular_search_window_radians", "--angular_window_deg"},
      {"wide_window_meters", "--loop_wide_window"},
      {"max_time_gap_seconds", "--max_time_gap"},
      {"flaser_fov_radians", "--flaser_fov_deg"},
      {"flaser_max_range_meters", "--flaser_max_range"},
      {"scans_per_submap", "--scans_per_submap"},
      {"degenerate_sigma_meters", "--degenerate_sigma"},
      {"degenerate_max_drop_ratio", "--degenerate_drop_ratio"},
      {"loop: degenerate_max_drop_ratio", "--loop_degenerate_drop_ratio"},
      {"loop_weak_translation_sigma_meters", "--loop_weak_sigma"},
      {"weak_direction_snap_radians", "--loop_weak_direction_snap_deg"},
      {"map_min_hit_share", "--map_min_hit_share"},
      {"wall_min_length_meters", "--wall_min_length"},
      {"revisit_points_min_travel_meters", "--revisit_points_min_travel, --revisit_points_min_turn_deg"},
      {"degenerate_eigenvalue_ratio", "--degenerate_ratio"},
      {"frontier_margin_meters", "--frontier_margin"},
      {"covariance_sigmas", "--covariance_sigmas"},
      {"outlier_max_score", "--outlier_max_score"},
      {"odometry_noise_fraction", "--odometry_noise_fraction"},
      {"lines: max_gap_meters", "--line_max_gap"},
      {"max_particles", "--max_particles"},
      {"spawn_min_sigma_meters", "--spawn_min_sigma"},
      {"max_ambiguous_scans", "--max_ambiguous_scans"},
      {"second_mode_exclusion_meters", "--second_mode_exclusion"},
      {"second_mode_score_ratio", "--second_mode_score_ratio"},
      {"sideslip_sigma_meters", "--sideslip_sigma"},
      {"speed_change_sigma_mps", "--speed_change_sigma"},
      {"mode_map_min_score", "--mode_map_min_score"},
      {"max_ceres_iterations", "--refine_max_iterations"},
      {"refine_function_tolerance", "--refine_function_tolerance"},
      {"max_submaps_per_search", "--loop_max_submaps"},
      {"motion_filter_distance_meters", "--motion_filter_distance"},
      {"motion_filter_angle_radians", "--motion_filter_angle_deg"},
      {"motion_filter_attitude_radians", "--motion_filter_attitude_deg"},
      {"motion_filter_time_seconds", "--motion_filter_time"},
      {"wall_weight", "--wall_weight"},
      {"retire_revisited_share", "--retire_revisited_share"},
      {"solve_min_new_node_share", "--solve_min_new_node_share"},
      {"constraint sigmas", "--intra_sigma, --intra_rotation_sigma_deg, --loop_sigma, --loop_rotation_sigma_deg"},
  };
  std::string flags;
  for (const auto& [field, flag] : kFlagOf) {
    if (message.find(field) != std::string::npos) flags += std::string(flags.empty() ? "" : ", ") + flag;
  }
  return flags.empty() ? "" : " (check " + flags + ")";
}

bool OptionsFromFlags(OnlineEstimatorOptions* estimator, MeasurementLogOptions* read, std::string* error) {
  LocalSlamOptions* options = &estimator->local;
  if (FLAGS_log.empty()) return (*error = "--log is required (a CARMEN .clf file, a hetslam robot log or a ROS bag)"), false;
  if (FLAGS_out.empty()) return (*error = "--out is required (an output folder)"), false;
  read->lenient = FLAGS_lenient;
  RosBagReadOptions* bag = &read->ros_bag;
  bag->scan_topic = FLAGS_scan_topic;
  bag->imu_topic = FLAGS_imu_topic;
  bag->odom_topic = FLAGS_odom_topic;
  bag->cmd_topic = FLAGS_cmd_topic;
  bag->image_topic = FLAGS_image_topic;
  bag->image_directory = FLAGS_image_dir;
  bag->base_frame = FLAGS_base_frame;
  if (!FLAGS_laser_mount.empty()) {
    Eigen::Isometry3d robot_T_laser;
    if (!ParseMount(FLAGS_laser_mount, &robot_T_laser)) {
      return (*error = "--laser_mount must be x,y,z,roll,pitch,yaw (metres, degrees), got '" + FLAGS_laser_mount + "'"),
             false;
    }
    bag->robot_T_laser = robot_T_laser;
  }
  read->flaser_max_range_meters = FLAGS_flaser_max_range;
  read->flaser_fov_radians = FLAGS_flaser_fov_deg * M_PI / 180.0;
  read->max_time_gap_seconds = FLAGS_max_time_gap;
  options->grid.resolution_meters = FLAGS_resolution;
  options->field.sigma_meters = FLAGS_sigma;
  options->field.max_distance_meters = FLAGS_field_max_distance;
  options->matcher.linear_search_window_meters = FLAGS_linear_window;
  options->matcher.angular_search_window_radians = FLAGS_angular_window_deg * M_PI / 180.0;
  options->matcher.min_correlative_score = FLAGS_min_score;
  options->matcher.fallback_angular_search_window_radians = FLAGS_fallback_angular_window_deg * M_PI / 180.0;
  options->matcher.fallback_below_score = FLAGS_fallback_below_score;
  options->matcher.free_space_penalty = FLAGS_free_space_penalty;
  options->matcher.translation_penalty_per_square_meter = FLAGS_translation_penalty;
  options->matcher.narrow_linear_search_window_meters = FLAGS_narrow_linear_window;
  options->matcher.narrow_angular_search_window_radians = FLAGS_narrow_angular_window_deg * M_PI / 180.0;
  options->matcher.narrow_accept_score = FLAGS_narrow_accept_score;
  options->matcher.rotation_penalty_per_square_radian = FLAGS_rotation_penalty;
  if (!ParseScanCostInterpolation(FLAGS_refine_interpolation, &options->matcher.refine_interpolation)) {
    return (*error = "--refine_interpolation must be values or distances, got '" + FLAGS_refine_interpolation + "'"),
           false;
  }
  options->max_point_range_meters = FLAGS_max_range;
  options->floor_max_height_meters = FLAGS_floor_max_height;
  options->floor_obstacle_max_height_meters = FLAGS_floor_obstacle_max_height;
  options->floor_obstacle_min_drop_meters = FLAGS_floor_obstacle_min_drop;
  options->suspend_floor_fraction = FLAGS_suspend_floor_fraction;
  options->matcher.wall_weight = FLAGS_wall_weight;
  options->matcher.wall_weight_in_refinement = FLAGS_wall_weight_refinement;
  options->grid.wall_min_height_span_meters = FLAGS_wall_min_height_span;
  options->densify_max_gap_meters = FLAGS_densify_max_gap;
  options->degenerate_eigenvalue_ratio = FLAGS_degenerate_ratio;
  options->degenerate_max_drop_ratio = FLAGS_degenerate_drop_ratio;
  options->field.lines.max_gap_meters = FLAGS_line_max_gap;
  options->frontier_margin_meters = FLAGS_frontier_margin;
  options->covariance_sigmas = FLAGS_covariance_sigmas;
  options->outlier_max_score = FLAGS_outlier_max_score;
  options->odometry_noise_fraction = FLAGS_odometry_noise_fraction;
  options->motion_filter_distance_meters = FLAGS_motion_filter_distance;
  options->motion_filter_angle_radians = FLAGS_motion_filter_angle_deg * M_PI / 180.0;
  options->motion_filter_attitude_radians = FLAGS_motion_filter_attitude_deg * M_PI / 180.0;
  options->motion_filter_time_seconds = FLAGS_motion_filter_time;
  options->matching_voxel_meters = FLAGS_matching_voxel;
  options->refine_on_middle_beams = FLAGS_refine_on_middle_beams;
  options->refine_on_voxel_ends = FLAGS_refine_on_voxel_ends;
  options->refine_on_all_points = FLAGS_refine_on_all_points;
  options->velocity_fraction = FLAGS_velocity_fraction;
  options->angular_velocity_fraction = FLAGS_angular_velocity_fraction;
  options->scans_per_submap = FLAGS_no_loop_closure ? 0 : FLAGS_scans_per_submap;
  if (FLAGS_use_odometry) {
    options->prediction = MotionPrediction::kOdometry;
  } else if (!ParseMotionPrediction(FLAGS_prediction, &options->prediction) ||
             options->prediction == MotionPrediction::kOdometry) {
    *error = "--prediction must be constant_velocity or stationary (got '" + FLAGS_prediction +
             "'); use --use_odometry for odometry";
    return false;
  }
  estimator->degenerate_sigma_meters = FLAGS_degenerate_sigma;
  estimator->particles.max_particles = FLAGS_max_particles;
  estimator->particles.seed = FLAGS_particle_seed;
  estimator->particles.spawn_min_sigma_meters = FLAGS_spawn_min_sigma;
  estimator->particles.max_ambiguous_scans = FLAGS_max_ambiguous_scans;
  estimator->particles.spawn_on_degenerate = FLAGS_spawn_on_degenerate;
  estimator->particles.insert_while_ambiguous = FLAGS_insert_while_ambiguous;
  estimator->particles.spawn_on_second_mode = FLAGS_spawn_on_second_mode;
  estimator->particles.second_mode_exclusion_meters = FLAGS_second_mode_exclusion;
  estimator->particles.second_mode_exclusion_radians = FLAGS_second_mode_exclusion_deg * M_PI / 180.0;
  estimator->particles.second_mode_score_ratio = FLAGS_second_mode_score_ratio;
  estimator->particles.sideslip_sigma_meters = FLAGS_sideslip_sigma;
  estimator->particles.speed_change_sigma_mps = FLAGS_speed_change_sigma;
  estimator->particles.mode_map_min_score = FLAGS_mode_map_min_score;
  estimator->use_odometry = FLAGS_use_odometry;
  estimator->use_commands = FLAGS_use_commands && !FLAGS_use_odometry;
  if (!ParseAttitudeSource(FLAGS_attitude_source, &estimator->attitude_source) ||
      estimator->attitude_source == AttitudeSource::kLevel) {
    *error = "--attitude_source must be marg or logged (got '" + FLAGS_attitude_source +
             "'); use --nouse_attitude for level scans";
    return false;
  }
  if (!FLAGS_use_attitude) estimator->attitude_source = AttitudeSource::kLevel;
  estimator->floor_tilt_gain = FLAGS_floor_tilt_gain;
  estimator->loop_closure = !FLAGS_no_loop_closure;
  LoopCloserOptions* loop = &estimator->loop;
  loop->min_score = FLAGS_loop_min_score;
  loop->wide_search = FLAGS_loop_wide_search;
  loop->wide_window_meters = FLAGS_loop_wide_window;
  loop->wide_min_score = FLAGS_loop_wide_min_score;
  loop->agreeing_min_score = FLAGS_loop_agreeing_min_score;
  loop->wide_search_spacing_meters = FLAGS_loop_wide_spacing;
  loop->degenerate_max_drop_ratio = FLAGS_loop_degenerate_drop_ratio;
  loop->matcher.weak_direction_snap_radians = FLAGS_loop_weak_direction_snap_deg * M_PI / 180.0;
  loop->max_submaps_per_search = FLAGS_loop_max_submaps;
  loop->refine_on_all_points = FLAGS_refine_on_all_points;
  estimator->graph.intra_translation_sigma_meters = FLAGS_intra_sigma;
  estimator->graph.intra_rotation_sigma_radians = FLAGS_intra_rotation_sigma_deg * M_PI / 180.0;
  estimator->graph.loop_translation_sigma_meters = FLAGS_loop_sigma;
  estimator->graph.loop_rotation_sigma_radians = FLAGS_loop_rotation_sigma_deg * M_PI / 180.0;
  estimator->graph.loop_weak_translation_sigma_meters = FLAGS_loop_weak_sigma;
  estimator->graph.map_min_hit_share = FLAGS_map_min_hit_share;
  estimator->graph.wall_min_length_meters = FLAGS_wall_min_length;
  estimator->graph.revisit_points_min_travel_meters = FLAGS_revisit_points_min_travel;
  estimator->graph.revisit_points_min_turn_radians = FLAGS_revisit_points_min_turn_deg * M_PI / 180.0;
  loop->min_node_separation = FLAGS_loop_min_node_separation;
  loop->search_min_travel_meters = FLAGS_loop_search_min_travel;
  loop->search_min_turn_radians = FLAGS_loop_search_min_turn_deg * M_PI / 180.0;
  loop->matcher.linear_search_window_meters = FLAGS_loop_linear_window;
  loop->matcher.angular_search_window_radians = FLAGS_loop_angular_window_deg * M_PI / 180.0;
  for (ScanMatcherOptions* matcher : {&options->matcher, &loop->matcher, &loop->wide_matcher}) {
    matcher->max_ceres_iterations = FLAGS_refine_max_iterations;
    matcher->refine_function_tolerance = FLAGS_refine_function_tolerance;
  }
  estimator->solve_every_n_loop_closures = FLAGS_solve_every_n_loop_closures;
  estimator->solve_min_new_nodes = FLAGS_solve_min_new_nodes;
  estimator->solve_min_new_node_share = FLAGS_solve_min_new_node_share;
  if (!(FLAGS_max_map_store_mib >= 0 && FLAGS_max_map_store_mib <= 1048576)) {
    return (*error = "--max_map_store_mib must be in [0, 1048576] (got " + std::to_string(FLAGS_max_map_store_mib) + ")"),
           false;
  }
  estimator->max_map_store_bytes = static_cast<size_t>(FLAGS_max_map_store_mib * 1048576.0);
  estimator->retire_revisited_share = FLAGS_retire_revisited_share;
  estimator->attach_revisits = FLAGS_attach_revisits;
  estimator->rematch_first_node = FLAGS_rematch_first_node;
  estimator->keep_search_tables_over_solves = FLAGS_keep_search_tables_over_solves;
  if (!(FLAGS_command_response <= 60)) return (*error = "--command_response must be at most 60 seconds"), false;
  if (FLAGS_max_scans < 0) return (*error = "--max_scans must be >= 0"), false;
  if (FLAGS_progress_every < 0) return (*error = "--progress_every must be >= 0"), false;
  std::string invalid;
  if (!read->IsValid(&invalid)) return (*error = "bad flag value: " + invalid + FlagsNamedIn(invalid)), false;
  if (!estimator->IsValid(&invalid)) return (*error = "bad flag value: " + invalid + FlagsNamedIn(invalid)), false;
  return true;
}

// The particle filter's count over time (a line at the first scan and at every change).
Status WriteParticleCounts(const std::string& path, const std::vector<OnlineEstimator::ParticleCount>& counts) {
  std::ostringstream out;
  out << "# timestamp particles\n"
         "# the particle filter's particle count from this scan on (a line at the first scan and at every change)\n";
  out.precision(6);
  out << std::fixed;
  for (const OnlineEstimator::ParticleCount& c : counts) out << c.stamp_seconds << ' ' << c.particles << '\n';
  const std::string text = out.str();
  return WriteFileBytes(path, text.data(), text.size());
}

// The estimator's wall time by stage (seconds; they add up to `estimator_seconds`, the Add()
// loop and Finish()).
std::vector<std::pair<std::string, double>> StageTimes(const OnlineEstimator& estimator, double estimator_seconds) {
  const OnlineEstimatorStats& s = estimator.stats();
  const ParticleFilterStats& p = estimator.particle_filter().stats();
  const double loop = estimator.loop_closer().stats().search_seconds;
  const double solve = estimator.graph().stats().solve_seconds;
  const double known = s.prepare_seconds + p.match_seconds + p.insert_seconds + p.weight_seconds + s.add_node_seconds +
                       loop + solve;
  return {{"scan preparation", s.prepare_seconds},
          {"matching", p.match_seconds},
          {"map insertion", p.insert_seconds},
          {"particle weighting", p.weight_seconds},
          {"graph nodes", s.add_node_seconds},
          {"loop search", loop},
          {"solves", solve},
          {"other estimator work (EKF, MARG, bookkeeping)", std::max(0.0, estimator_seconds - known)}};
}

// Every accepted loop closure as measured and as in the final graph.
Status WriteLoopClosures(const std::string& path, const std::vector<LoopClosureReport>& closures) {
  std::ostringstream out;  // written through a temporary file: no truncated output
  out << "# submap node score measured_x measured_y measured_theta final_x final_y final_theta removed weak_x weak_y\n"
         "# submap_T_node as matched and as in the final graph (metres, radians); removed = 1 when the\n"
         "# consistency check took the closure out; weak = the direction (submap frame) along which a\n"
         "# degenerate closure (a corridor) measured little, 0 0 when it measured both\n";
  out.precision(9);
  for (const LoopClosureReport& loop : closures) {
    const Pose2& m = loop.measured_submap_T_node;
    const Pose2& f = loop.estimated_submap_T_node;
    out << loop.submap.index << ' ' << loop.node.index << ' ' << loop.score << ' ' << m.x() << ' ' << m.y() << ' '
        << m.theta() << ' ' << f.x() << ' ' << f.y() << ' ' << f.theta() << ' ' << (loop.removed ? 1 : 0) << ' ' << loop.weak_direction.x() << ' '
        << loop.weak_direction.y() << '\n';
  }
  const std::string text = out.str();
  return WriteFileBytes(path, text.data(), text.size());
}

std::string Summary(const OnlineEstimator& estimator) {
  const OnlineEstimatorStats& s = estimator.stats();
  const SubmapGraphStats& g = estimator.graph().stats();
  const LoopCloserStats& l = estimator.loop_closer().stats();
  char line[1024];
  std::snprintf(line, sizeof(line),
                "scans: %d processed, %d skipped (too few points), %d refused (too late or too far), %d timestamps "
                "backwards, %d match failures, %d matched but not inserted (nothing new: motion filter), %lld floor "
                "points dropped, %d degenerate matches (prediction kept along a flat direction), %d with %lld frontier "
                "points left out of the match, %d predicted by the EKF, %d without attitude\n",
                s.scans, s.skipped_too_few_points, s.scans_refused, s.scans_stamped_backwards, s.match_failures,
                s.filtered_scans,
                s.floor_points, s.degenerate_matches, s.frontier_scans, s.frontier_points, s.ekf_predicted_scans,
                s.scans_without_attitude);
  std::string out = line;
  const ScanConfidence c = estimator.Confidence();
  std::snprintf(line, sizeof(line),
                "confidence: %s: %d of %d scans (%.0f%%) placed by a match that constrains x, y and yaw (low under "
                "%.0f%%); %d matches flat along one direction (a single wall, a corridor), %d match failures, %d "
                "not matched (first scan, too few points in range, suspended), %d refused\n",
                c.low ? "LOW" : "ok", c.well_constrained, c.scans, 100.0 * c.well_constrained_fraction,
                100.0 * estimator.options().min_well_constrained_fraction, c.flat, c.failed, c.unmatched, c.refused);
  out += line;
  if (s.floor_points > 0 || s.floor_obstacle_points > 0 || s.suspended_scans > 0) {
    std::snprintf(line, sizeof(line),
                  "semantics: %lld floor hits dropped, %lld floor-obstacle points (planner map only, never matched), "
                  "%d scans suspended (laser facing the floor: the EKF carried the pose)\n",
                  s.floor_points, s.floor_obstacle_points, s.suspended_scans);
    out += line;
  }
  if (s.lowest_ray_height_meters.has_value()) {
    std::snprintf(line, sizeof(line),
                  "heights: %d scans projected with an attitude (2.5D); the lowest ray passed %.2f m above the floor "
                  "(what stands lower may lie under every ray: hetslam_team --overlap_height_margin_meters)\n",
                  s.projected_scans, *s.lowest_ray_height_meters);
    out += line;
  }
  if (s.first_node_rematch_radians.has_value()) {
    std::snprintf(line, sizeof(line),
                  "frame: the first scan refined in the finished first submap: heading %+.3f deg there, the map turned "
                  "around the first pose to match (--rematch_first_node)\n",
                  *s.first_node_rematch_radians * 180.0 / M_PI);
    out += line;
  }
  if (s.marg_samples > 0) {
    std::snprintf(line, sizeof(line), "MARG: %d samples (%d refused), EKF: %d updates refused, %lld replayed\n",
                  s.marg_samples, s.marg_errors, s.ekf_errors, static_cast<long long>(estimator.ekf().num_replayed()));
    out += line;
  }
  if (s.floor_tilt_updates > 0) {
    std::snprintf(line, sizeof(line),
                  "floor tilt: %d scans' floor lines corrected the attitude (--floor_tilt_gain); correction at the end "
                  "roll %+.3f deg, pitch %+.3f deg\n",
                  s.floor_tilt_updates, s.floor_tilt_radians.x() * 180.0 / M_PI, s.floor_tilt_radians.y() * 180.0 / M_PI);
    out += line;
  }
  const ParticleFilterStats& p = estimator.particle_filter().stats();
  // Finish() freed the active submaps; their size then.
  const size_t active_bytes = s.active_submap_bytes_at_finish;
  const size_t finished_bytes = estimator.graph().FinishedSubmapBytes(estimator.options().robot);
  std::snprintf(line, sizeof(line),
                "particles: mean %.3f per scan, at most %d; %d spawns (%d at a second mode), %d collapses, %d resamples, %d "
                "scans weighted against the earlier map; one extra particle at most %.2f MiB (the map: %.1f MiB, finished "
                "submaps %.1f MiB and active ones %.1f MiB)\n",
                p.mean_particles(), p.max_particles, p.spawns, p.mode_spawns, p.collapses, p.resamples, p.global_scorings,
                p.max_extra_particle_bytes / 1048576.0, (finished_bytes + active_bytes) / 1048576.0,
                finished_bytes / 1048576.0, active_bytes / 1048576.0);
  out += line;
  if (p.unfollowed_modes > 0) {
    std::snprintf(line, sizeof(line),
                  "particles: %d scans fit two places alike (a second mode of at least --second_mode_score_ratio "
                  "of the best, distinct when matched again) that no particle followed: neither slides the robot "
                  "sideways (two places along a corridor's length, t = %.1f to %.1f s); without a motion source "
                  "each went on at the place the scan, the change of speed (--speed_change_sigma) and, for %d "
                  "of them, the finished submaps near either place favour, %d of them at the second; with one, "
                  "at the better-scoring place\n",
                  p.unfollowed_modes, p.first_unfollowed_mode_stamp, p.last_unfollowed_mode_stamp,
                  p.modes_weighed_by_map, p.modes_chosen_by_motion);
    out += line;
  }
  const SubmapGraphStats& store = estimator.graph().stats();
  std::snprintf(line, sizeof(line), "map store: %d submaps evicted (%.1f MiB) to stay within --max_map_store_mib=%g\n",
                store.submaps_evicted, store.evicted_bytes / 1048576.0, FLAGS_max_map_store_mib);
  if (estimator.options().max_map_store_bytes == 0) line[0] = '\0';
  out += line;
  if (estimator.options().loop_closure && estimator.options().retire_revisited_share > 0) {
    std::snprintf(line, sizeof(line),
                  "revisits: %d finished submaps retired (%.1f MiB freed): earlier submaps covered at least %.0f%% of "
                  "them (--retire_revisited_share)\n",
                  store.submaps_retired, store.retired_bytes / 1048576.0, 100.0 * estimator.options().retire_revisited_share);
    out += line;
    if (estimator.options().attach_revisits) {
      std::snprintf(line, sizeof(line),
                    "revisits: %d scans attached to their retired submaps, %d of their loop closures released, %d "
                    "constraints between submaps in their place (--attach_revisits); %d of them keep no points "
                    "(%.1f MiB freed: one scan per %g m or %g deg of re-driving keeps them, --revisit_points_min_travel)\n",
                    store.nodes_attached, store.closures_released, store.revisit_summaries, store.nodes_points_released,
                    store.points_released_bytes / 1048576.0, FLAGS_revisit_points_min_travel,
                    FLAGS_revisit_points_min_turn_deg);
      out += line;
    }
  }
  if (!estimator.options().loop_closure) return out;
  std::snprintf(line, sizeof(line),
                "graph: %d nodes, %d submaps, %d loop searches (%d submaps over the budget skipped, %d that could not "
                "reach the score), %d loop closures accepted (%d gated out), %d removed as inconsistent, %d solves (%d "
                "iterations, %.2f s, %d failed), loop search %.2f s\n"
                "wide loop search: %d matches, %d candidates, %d closures accepted (%d submaps left out: drift bound from "
                "them within the standard window); %d results flat along a direction (held across it only; wide ones "
                "dropped)\n"
                "agreeing loop search (--loop_agreeing_min_score): %d matches, %d candidates, %d closures accepted\n",
                g.nodes, g.submaps, l.searches, l.submaps_skipped, l.searches_without_overlap, g.loop_closures_accepted,
                l.rejected_by_gate, g.loop_closures_rejected_after_solve, g.solves, g.solver_iterations, g.solve_seconds,
                g.failed_solves, l.search_seconds, l.wide_searches, l.wide_candidates, l.wide_accepted,
                l.wide_within_standard, l.degenerate, l.agreeing_searches, l.agreeing_candidates, l.agreeing_accepted);
  out += line;
  // Loop-closure precision as Cartographer reports it: the share of kept closures that the
  // final graph agrees with to 20 cm and 1° (a degenerate closure: across its weak direction).
  int kept = 0, agree = 0;
  for (const LoopClosureReport& loop : estimator.graph().LoopClosures()) {
    if (loop.removed) continue;
    ++kept;
    agree += ClosureAgrees(loop, 0.2, M_PI / 180.0);
  }
  std::snprintf(line, sizeof(line),
                "loop closure precision: %d of %d kept closures (%.1f%%) agree with the final graph to 20 cm / 1 deg\n",
                agree, kept, kept > 0 ? 100.0 * agree / kept : 0.0);
  return out + line;
}

int Run() {
  OnlineEstimatorOptions options;
  MeasurementLogOptions read_options;
  std::string error;
  if (!OptionsFromFlags(&options, &read_options, &error)) return Fail(error + " (see --help)"), 2;
  if (!FLAGS_g2o_out.empty() && FLAGS_no_loop_closure) {
    return Fail("--g2o_out needs the loop-closing pipeline (drop --no_loop_closure)"), 2;
  }
  if (!FLAGS_trajectory_bag.empty()) {
    // Before the run, not after it: this loads the ROS bag plugin, which may be missing.
    const Status bags = CheckRosBagSupport();
    if (!bags.ok()) return Fail("--trajectory_bag: " + bags.message()), 2;
  }

  // Streamed (a CARMEN log is checked once, then read a measurement at a time; other formats are
  // read whole and handed out one at a time, each freed as it goes).
  std::unique_ptr<MeasurementStream> stream;
  const auto read_start = std::chrono::steady_clock::now();
  const Status read = MeasurementStream::Open(FLAGS_log, read_options, &stream);
  double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
  if (!read.ok()) return Fail(read.message()), 1;
  const MeasurementLog& log = stream->info();
  const Status params = ApplyLogParams(log.params, &options);
  if (!params.ok()) return Fail(FLAGS_log + ": " + params.message()), 1;
  if (FLAGS_command_response >= 0) {
    options.ekf.command_response_seconds = FLAGS_command_response;
    if (!options.IsValid(&error)) return Fail("bad flag value: " + error + " (--command_response; see --help)"), 2;
  }
  for (const std::string& warning : log.warnings) std::cerr << "warning: " << warning << "\n";
  if (log.malformed_lines_skipped > 0)
    std::cerr << "warning: skipped " << log.malformed_lines_skipped << " malformed lines (--lenient)\n";
  if (log.time_gaps_dropped > 0)
    std::cerr << "warning: dropped " << log.time_gaps_dropped << " measurements stamped more than --max_time_gap = "
              << FLAGS_max_time_gap << " s after every earlier one (--lenient)\n";
  if (log.num_scans == 0) return Fail("'" + FLAGS_log + "' holds no laser scans"), 1;
  std::vector<StampedPose2> truth = log.truth;
  std::string truth_name = FLAGS_log + " (TRUTH)";
  if (!FLAGS_truth.empty()) {
    const Status status = ReadTrajectory(FLAGS_truth, &truth);
    if (!status.ok()) return Fail(status.message()), 1;
    truth_name = FLAGS_truth;
  }
  std::error_code ec;
  std::filesystem::create_directories(FLAGS_out, ec);
  if (ec) return Fail("cannot create output folder '" + FLAGS_out + "': " + ec.message()), 1;

  const int num_scans = FLAGS_max_scans > 0 ? std::min(FLAGS_max_scans, log.num_scans) : log.num_scans;
  std::cout << "hetslam_run: " << num_scans << " scans from " << FLAGS_log << " (" << LogFormatName(log.format)
            << ", " << stream->num_measurements() << " measurements; "
            << (FLAGS_use_odometry ? "odometry prediction" : "no odometry") << ")\n";
  if (log.format == LogFormat::kRosBag) {
    const auto param = [&](const char* name) {
      const auto it = log.params.find(name);
      return it == log.params.end() ? std::string() : it->second;
    };
    std::cout << "topics: scans " << param("scan_topic") << ", IMU " << param("imu_topic") << ", odometry "
              << param("odom_topic") << ", commands " << param("cmd_topic") << "; laser frame '"
              << param("laser_frame") << "', mount from " << param("laser_mount") << "\n";
  }
  auto estimator = std::make_unique<OnlineEstimator>(options);
  const auto start = std::chrono::steady_clock::now();
  int scans = 0, errors = 0;
  double first_stamp = 0.0, last_stamp = 0.0;
  double stream_seconds = 0.0;  // reading measurements while mapping
  Measurement measurement;
  while (true) {
    const auto next_start = std::chrono::steady_clock::now();
    bool got = false;
    const Status next = stream->Next(&measurement, &got);
    stream_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - next_start).count();
    if (!next.ok()) return Fail(next.message()), 1;
    if (!got) break;
    const bool scan = std::holds_alternative<LaserReading>(measurement);
    if (scan && scans == num_scans) break;
    const double stamp = StampOf(measurement);
    const Status status = estimator->Add(measurement);
    if (!status.ok() && ++errors <= 5) std::cerr << "warning: " << FLAGS_log << ": " << status.message() << "\n";
    if (!scan) continue;
    if (scans == 0) first_stamp = stamp;
    last_stamp = std::max(last_stamp, stamp);
    ++scans;
    if (FLAGS_progress_every > 0 && scans % FLAGS_progress_every == 0) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::fprintf(stderr, "  %d/%d scans, %.1f s, %.0f scans/s, %d submaps, %d loop closures\n", scans, num_scans,
                   elapsed, scans / elapsed, estimator->graph().stats().submaps,
                   estimator->graph().stats().loop_closures_accepted);
    }
  }
  if (errors > 5) std::cerr << "warning: " << errors << " measurements refused in all (first 5 shown)\n";
  if (estimator->stats().scans_stamped_backwards > 0) {
    std::cerr << "warning: " << estimator->stats().scans_stamped_backwards << " of " << scans
              << " scans are stamped before an earlier scan (processed in file order; time-based figures and the "
                 "truth association are unreliable)\n";
  }
  estimator->Finish();
  const auto finished = std::chrono::steady_clock::now();
  const double estimator_seconds = std::chrono::duration<double>(finished - start).count() - stream_seconds;
  read_seconds += stream_seconds;
  const std::vector<std::pair<std::string, double>> stages = StageTimes(*estimator, estimator_seconds);
  const std::vector<StampedPose2> trajectory = estimator->Trajectory();
  const std::unique_ptr<OccupancyGrid> grid = estimator->RenderMap();
  const double wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string summary = Summary(*estimator);
  if (trajectory.empty()) {
    std::cerr << summary;
    return Fail("no scan of '" + FLAGS_log + "' had enough valid beams to map (at least " +
                std::to_string(options.local.min_points) + " within --max_range); nothing written"), 1;
  }

  const std::filesystem::path out(FLAGS_out);
  const std::string base = (out / "map").string();
  const std::string trajectory_path = (out / "trajectory.txt").string();
  std::vector<Pose2> path;
  for (const StampedPose2& p : trajectory) path.push_back(p.pose);
  // Level scans (CARMEN logs) have no floor obstacles or walls: the planner map is the map.
  const OnlineEstimatorStats stats = estimator->stats();
  std::unique_ptr<OccupancyGrid> obstacles;
  if (stats.floor_obstacle_points > 0) {
    obstacles = estimator->RenderMap(SubmapGraph::Layer::kFloorObstacles);
    // Every candidate may have lain next to mapped structure (and been left out).
    if (obstacles->observed_max().x < obstacles->observed_min().x) obstacles.reset();
  }
  std::vector<Status> written = {WriteMapPgmYaml(*grid, base), WriteTrajectory(trajectory_path, trajectory)};
  if (obstacles != nullptr) {
    written.push_back(WriteMapPgmYaml(*obstacles, (out / "floor_obstacles").string()));
    written.push_back(
        WriteMapPgmYaml(*estimator->RenderMap(SubmapGraph::Layer::kPlanner), (out / "planner").string()));
  } else {
    written.push_back(WriteMapPgmYaml(*grid, (out / "planner").string()));
  }
  if (stats.projected_scans > 0) {
    const std::unique_ptr<OccupancyGrid> walls = estimator->RenderMap(SubmapGraph::Layer::kWalls);
    if (walls->observed_max().x >= walls->observed_min().x) {
      written.push_back(WriteMapPgmYaml(*walls, (out / "walls").string()));
    }
  }
  if (options.loop_closure) {
    written.push_back(WriteLoopClosures((out / "loop_closures.txt").string(), estimator->graph().LoopClosures()));
    written.push_back(WriteTrajectory((out / "frontend_trajectory.txt").string(), estimator->LocalTrajectory()));
  }
  written.push_back(WriteParticleCounts((out / "particles.txt").string(), estimator->particle_counts()));
  if (!FLAGS_trajectory_bag.empty()) {
    written.push_back(WriteTrajectoryBag(FLAGS_trajectory_bag, trajectory, TrajectoryBagOptions()));
  }
  if (!FLAGS_g2o_out.empty()) {
    written.push_back(WriteG2oPoseGraph2d(FLAGS_g2o_out, estimator->graph().ExportGraph(options.robot)));
  }
  // Each loop closure's match against the truth, the trajectory taken out (its submap placed by
  // its own nodes' truth): what the matches got wrong, apart from the drift.
  std::vector<ConstraintTruthError> closure_errors;
  // The front end alone against the truth: whether the loop closures made the trajectory better.
  AbsoluteTrajectoryError frontend_ate;
  if (!truth.empty() && options.loop_closure) {
    frontend_ate = ComputeAbsoluteTrajectoryError(estimator->LocalTrajectory(), truth);
    closure_errors = ConstraintTruthErrors(estimator->graph(), {{options.robot, truth}});
    written.push_back(WriteConstraintTruthErrors((out / "loop_closures_truth.txt").string(), closure_errors, {}));
  }
  std::vector<double> scores = estimator->match_scores();
  estimator.reset();  // the picture is drawn without the graph in memory
#ifdef __GLIBC__
  // ... and without the pages it left in the heap (small blocks: nodes, points, Ceres): glibc
  // keeps freed memory for reuse, and the picture's bands and OpenCV (loaded to draw) would come
  // on top of it.
  malloc_trim(0);
#endif
  written.push_back(
      WriteMapPicture(base + ".png", *grid, obstacles.get(), {{"estimate", path}}, {}, MapPictureOptions()));
  for (const Status& status : written) {
    if (!status.ok()) return Fail(status.message()), 1;
  }
  const double output_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - finished).count();

  std::printf("%s", summary.c_str());
  if (!scores.empty()) {
    std::sort(scores.begin(), scores.end());
    std::printf("match score (mean likelihood at the matched pose): p10 %.3f, median %.3f, p90 %.3f\n",
                scores[scores.size() / 10], scores[scores.size() / 2], scores[scores.size() * 9 / 10]);
  }
  const double duration = last_stamp - first_stamp;
  // A clock jump (bounded by --max_time_gap unless that is 0) makes the time figures meaningless.
  if (scans > 1 && duration / (scans - 1) > 60.0) {
    std::cerr << "warning: the " << scans << " scans span " << duration
              << " s of data, over a minute per scan: a clock jump? (the real-time factor below is meaningless)\n";
  }
  std::printf("time: %.2f s wall, %.1f scans/s, data duration %.1f s, real-time factor %.1fx\n", wall_seconds,
              scans / wall_seconds, duration, duration / wall_seconds);
  std::vector<std::pair<std::string, double>> all_stages = {{"reading the log", read_seconds}};
  all_stages.insert(all_stages.end(), stages.begin(), stages.end());
  all_stages.push_back({"maps and outputs", output_seconds});
  double process_seconds = 0.0;
  for (const auto& stage : all_stages) process_seconds += stage.second;
  std::printf("time per stage (wall s, share of %.2f s):", process_seconds);
  for (size_t k = 0; k < all_stages.size(); ++k) {
    std::printf("%s %s %.2f (%.0f%%)", k > 0 ? "," : "", all_stages[k].first.c_str(), all_stages[k].second,
                process_seconds > 0 ? 100.0 * all_stages[k].second / process_seconds : 0.0);
  }
  std::printf("\n");
  if (!truth.empty()) {
    const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(trajectory, truth);
    // An SE(2) alignment of one or two poses fits them exactly: an error of 0 would say nothing.
    if (ate.matched < 3) {
      std::printf("trajectory error vs %s: only %d estimated poses have a truth pose at their stamp (3 or more are "
                  "needed for an aligned error): no error computed\n",
                  truth_name.c_str(), ate.matched);
    } else {
      std::printf("trajectory error vs %s: %d poses matched, ATE rmse %.3f m (max %.3f m), "
                  "rotation rmse %.2f deg (max %.2f deg)\n",
                  truth_name.c_str(), ate.matched, ate.translation_rmse_meters, ate.translation_max_meters,
                  ate.rotation_rmse_degrees, ate.rotation_max_degrees);
      if (frontend_ate.matched >= 3) {
        // Compared as printed (to the millimetre).
        const long corrected_mm = std::lround(1e3 * ate.translation_rmse_meters);
        const long frontend_mm = std::lround(1e3 * frontend_ate.translation_rmse_meters);
        const char* verdict = corrected_mm < frontend_mm   ? "improved it"
                              : corrected_mm > frontend_mm ? "made it worse"
                                                           : "did not change it (to the millimetre)";
        std::printf("  the front end alone, before loop closure (frontend_trajectory.txt): rmse %.3f m (max %.3f m), "
                    "rotation rmse %.2f deg; the loop closures %s\n",
                    frontend_ate.translation_rmse_meters, frontend_ate.translation_max_meters,
                    frontend_ate.rotation_rmse_degrees, verdict);
      }
      // What the alignment hides: how far the map's frame turned and moved from the start.
      const StartFrameDrift drift = ComputeStartFrameDrift(trajectory, truth);
      std::printf("drift from the start frame vs %s (no alignment; what a teammate's relative pose inherits): "
                  "at the end %.3f m, %+.2f deg; largest %.3f m (t = %.1f s), %.2f deg (t = %.1f s)\n",
                  truth_name.c_str(), drift.final_translation_meters, drift.final_rotation_degrees,
                  drift.max_translation_meters, drift.max_translation_stamp_seconds, drift.max_rotation_degrees,
                  drift.max_rotation_stamp_seconds);
    }
    std::vector<ConstraintTruthError> kept;
    for (const ConstraintTruthError& e : closure_errors) {
      if (!e.removed) kept.push_back(e);
    }
    if (!kept.empty()) {
      const ConstraintTruthSummary c = SummarizeConstraintTruth(kept);
      std::printf("loop closures vs %s (each submap placed by its own nodes' truth; %s/loop_closures_truth.txt): %d "
                  "kept, median %.3f m / %.2f deg, max %.3f m / %.2f deg, mean signed rotation %+.3f deg\n",
                  truth_name.c_str(), FLAGS_out.c_str(), c.count, c.median_translation_meters,
                  c.median_rotation_degrees, c.max_translation_meters, c.max_rotation_degrees,
                  c.mean_signed_rotation_degrees);
    }
  }
  std::printf("wrote %s.pgm, %s.yaml, %s.png, %s%s%s\n", base.c_str(), base.c_str(), base.c_str(),
              trajectory_path.c_str(), FLAGS_trajectory_bag.empty() ? "" : ", ", FLAGS_trajectory_bag.c_str());
  return 0;
}

}  // namespace
}  // namespace hetslam

int main(int argc, char** argv) {
  gflags::SetUsageMessage(
      "single-robot laser SLAM on a CARMEN log, a hetslam robot log or a ROS 1 bag, without odometry by default.\n"
      "  hetslam_run --log=FILE.clf --out=DIR [--truth=truth.txt]\n"
      "  hetslam_run --log=FILE.bag --out=DIR [--scan_topic=/scan] [--trajectory_bag=DIR/trajectory.bag]\n"
      "Writes DIR/map.pgm + map.yaml (ROS map_server), DIR/map.png (map with trajectory) and\n"
      "DIR/trajectory.txt (`timestamp x y theta`), and prints a summary. With a truth (--truth, or a robot log's\n"
      "TRUTH lines) also DIR/loop_closures_truth.txt: each loop closure's match against the truth, its submap placed\n"
      "by its own nodes' truth (the drift taken out).");
  hetslam::PrintProgramHelpIfAsked(argc, argv, __FILE__);
  gflags::ParseCommandLineFlags(&argc, &argv, true);
  google::InitGoogleLogging(argv[0]);
  FLAGS_logtostderr = true;
#ifdef __GLIBC__
  // glibc raises its mmap threshold (up to 32 MiB) whenever a large mmapped block is freed;
  // from then on the grids' growth copies and the scan matchers' tables come from the brk heap,
  // where the freed ones stay as fragments. A fixed threshold returns them: Intel's peak RSS
  // 165 -> 115 MiB at 256 KiB for ~0.3 s of page faults (128 KiB: the same; 1 MiB: 140 MiB).
  // With the threshold fixed, glibc's trim threshold stays at 128 KiB: the heap's top was given
  // back and faulted in again as submaps' tiles were freed and allocated (Intel: 82 000 -> 60 000
  // page faults at 1 MiB, the peak the same in session 22). Since session 31 256 KiB: at 1 MiB the
  // free top of the heap then held 0.2-0.6 MiB more at FR079's and Intel's peaks (FR079 29.4-29.6
  // against 28.8-29.1 MiB, up to 3.0x LaMa's), for 63 000 -> 77 000 faults on Intel, ~1% of the time.
  if (FLAGS_malloc_mmap_threshold_kib < 0 || FLAGS_malloc_trim_threshold_kib < 0) {
    std::cerr << "hetslam_run: --malloc_mmap_threshold_kib and --malloc_trim_threshold_kib must be >= 0\n";
    return 2;
  }
  if (FLAGS_malloc_mmap_threshold_kib > 0) mallopt(M_MMAP_THRESHOLD, FLAGS_malloc_mmap_threshold_kib * 1024);
  if (FLAGS_malloc_trim_threshold_kib > 0) mallopt(M_TRIM_THRESHOLD, FLAGS_malloc_trim_threshold_kib * 1024);
#endif
  if (argc > 1) {
    std::cerr << "hetslam_run: unexpected argument '" << argv[1] << "' (flags are --name=value; see --help)\n";
    return 2;
  }
  return hetslam::Run();
}
