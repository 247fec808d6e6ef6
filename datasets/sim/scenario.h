// The simulator's scenario: a world (datasets/sim/world.h) with AprilTags on its walls and
// either one wheeled robot for the 2D CARMEN path or a team of robots (wheeled, UAV, humanoid:
// datasets/sim/robot_spec.h), read from a small text format.
//
// Frames and units: the world frame is right-handed, x east, y north, z up, the floor is the
// plane z = 0; all lengths in metres. Scenario files write angles in degrees (easier to
// author); every struct here holds radians, with the unit in the field name.
//
// Scenario file format: the full description of every statement is in datasets/README.md
// ("Scenario files"). One statement per line, fields separated by white space, '#' starts a
// comment (to the end of the line), blank lines are ignored. World statements: wall, box,
// wall_height, ceiling, table, shelf, obstacle, random_obstacles, tag. Single-robot (2D path)
// statements: waypoint, start, laser, robot, odometry. duration_limit_s applies to both paths.
// `robot_begin NAME KIND` .. `robot_end` blocks describe the robots of a team scenario (then
// the single-robot statements are not allowed outside the blocks). Any error (unknown keyword,
// wrong field count, a non-numeric or non-finite number, a value out of range, a repeated
// singleton, a statement in the wrong place) is reported as "file:line: message"; a
// scenario-level error (no waypoints, no walls) names the file.
#ifndef HETSLAM_DATASETS_SIM_SCENARIO_H_
#define HETSLAM_DATASETS_SIM_SCENARIO_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/se2.h"
#include "core/status.h"
#include "datasets/sim/robot_spec.h"
#include "datasets/sim/world.h"

namespace hetslam {
namespace sim {

// An AprilTag (tag36h11) on a wall: centre at `center`, its normal (the tag's z axis, out of
// the wall towards the viewer) horizontal at yaw `normal_yaw_radians`; tag x is horizontal
// (right as seen when facing it), tag y is up.
struct TagSpec {
  int id = 0;
  double size_meters = 0.16;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double normal_yaw_radians = 0.0;
  int source_line = 0;
  Eigen::Isometry3d WorldTTag() const;
};

// `count` floor obstacles placed at run time with the run's random generator (see
// PlaceRandomObstacles in team_simulator.h) inside `region`, heights up to max_height_meters.
struct RandomObstacleSpec {
  int count = 0;
  Eigen::AlignedBox2d region;
  double max_height_meters = 0.3;
  int source_line = 0;
};

struct Scenario {
  std::string source_name;  // file the scenario was read from ("" when built in code)
  World world;
  std::vector<Eigen::Vector2d> waypoints;  // world frame, visited in order
  bool has_start_pose = false;
  Pose2 start_pose;  // world_T_robot at t = 0 when has_start_pose
  LaserOptions laser;
  RobotOptions robot;
  OdometryOptions odometry;
  double duration_limit_seconds = 600.0;  // the simulation stops here even if unfinished
  // Team scenarios (robot blocks); empty for the 2D single-robot path.
  std::vector<RobotSpec> robots;
  std::vector<TagSpec> tags;
  std::vector<RandomObstacleSpec> random_obstacles;

  // True when the scenario has robot blocks (a team dataset, not a CARMEN log).
  bool IsTeam() const { return !robots.empty(); }

  // The initial pose: `start_pose` if given, else the first waypoint facing the second
  // (facing +x when there is only one waypoint).
  Pose2 InitialPose() const;
  // Index of the first waypoint still to be reached: 1 when the start is the implied first
  // waypoint, 0 when an explicit start pose is given.
  int FirstWaypointToReach() const;

  // Checks a non-empty world and a positive duration limit; single-robot scenarios: every
  // option struct and at least one waypoint; team scenarios: every robot, unique robot names,
  // unique tag ids in [0, 586].
  bool IsValid(std::string* error) const;
};

// The scenario mirrored about the vertical line x = axis through the middle of its walls'
// bounds (x -> 2 axis - x): walls, prisms (tables, shelves, obstacles), tags (centres moved,
// normals mirrored; a tag's pattern is not, so it stays readable), random-obstacle regions,
// start poses (heading theta -> pi - theta), waypoints, and each robot's body-frame commands
// (sideways speed and yaw rate negated). The robots themselves (laser and camera mounts, head
// profiles, sensors) are not mirrored, and floor obstacles placed at run time land elsewhere
// in their mirrored region (the run's random draws are the same, not their places). What it is
// for: a method whose errors lean one way because of the handedness of its scans (a beam order
// that picks points on one side, say) gets them the other way round in the mirrored world, so
// a claim that holds on both holds whatever way the building is built (hetslam_sim --mirror;
// tests/bench/run_scenarios.sh with HETSLAM_MIRROR=1). `source_name` gets " (mirrored)".
Scenario MirroredScenario(const Scenario& scenario);

// Parses scenario text; `source_name` prefixes every error message ("name:line: ...").
// On error `*scenario` is left in an unspecified state.
Status ParseScenario(const std::string& text, const std::string& source_name,
                     Scenario* scenario);

// Reads and parses a scenario file; errors name the file (and the line).
Status ReadScenarioFile(const std::string& path, Scenario* scenario);

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_SCENARIO_H_
