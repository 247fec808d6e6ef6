// The simulator's world and scenario: a 2.5D building (walls, furniture, floor obstacles, a
// floor and a ceiling, AprilTags on walls) and either one wheeled robot for the 2D CARMEN path
// or a team of robots (wheeled, UAV, humanoid), read from a small text format.
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
//
// Geometry: walls are zero-thickness vertical rectangles (a segment x [0, wall height]);
// furniture and floor obstacles are vertical prisms (a convex footprint x [z_min, z_max]); a
// table is a top slab on four legs, a shelf a deep lower prism under a shallow upper one. The 2D
// queries (CastRay, CastRays, SegmentHitsWall, DistanceToNearestWall) see the walls only, as
// infinitely tall segments: the z-independent special case the 2D CARMEN path has always used.
// CastRay3D / CastRays3D see everything, including the floor and the ceiling.
#ifndef HETSLAM_DATASETS_SIM_WORLD_H_
#define HETSLAM_DATASETS_SIM_WORLD_H_

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {
namespace sim {

// What a 3D ray hit (CastRay3D). kFurniture: tables and shelves (they break the 2.5D
// assumption: different footprints at different heights); kObstacle: low floor obstacles.
enum class Surface { kNone = 0, kFloor, kCeiling, kWall, kFurniture, kObstacle };

// "none", "floor", "ceiling", "wall", "furniture", "obstacle".
const char* SurfaceName(Surface surface);

// A wall: the segment from `a` to `b` in the world frame (metres), zero thickness; in 3D it
// spans z in [0, World::wall_height_meters()]. `source_line` is the scenario line it came from
// (0 when added in code).
struct WallSegment {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  int source_line = 0;
};

// A vertical prism: the convex polygon `footprint` (world frame, counter-clockwise, at least
// three vertices) extruded from z_min_meters to z_max_meters. A table top, a table leg, one
// part of a shelf, a floor obstacle.
struct Prism {
  std::vector<Eigen::Vector2d> footprint;
  double z_min_meters = 0.0;
  double z_max_meters = 0.0;
  Surface surface = Surface::kFurniture;  // kFurniture or kObstacle
  int source_line = 0;
};

// The result of a 3D ray cast: the distance along the (unit) direction to the first surface,
// and which kind of surface it is, with the scenario line that made it (0 for floor/ceiling).
struct RayHit {
  bool hit = false;
  double range_meters = std::numeric_limits<double>::infinity();
  Surface surface = Surface::kNone;
  int source_line = 0;
};

// Table geometry used by World::AddTable (metres).
struct TableShape {
  double top_thickness_meters = 0.04;
  double leg_width_meters = 0.05;  // square legs
  double leg_inset_meters = 0.05;  // from the top's corners to the legs' outer faces
};

// A building: walls, prisms, the floor z = 0 and an optional ceiling, with exact ray casting.
// A World built in code has infinitely tall walls and no ceiling (the 2D special case: a
// level 3D ray at any height sees exactly what the 2D ray sees, plus prisms); the scenario
// parser sets the heights (defaults 2.6 m). Queries are brute force over the structures within
// range of the ray origin: a few hundred walls and a few hundred thousand rays take well under
// a second.
class World {
 public:
  // Adds one wall. CHECK-fails on a non-finite or zero-length segment (the parser reports
  // those as user errors before calling this).
  void AddWall(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int source_line = 0);
  // Adds the four walls of a `size_meters.x() x size_meters.y()` rectangle centred at
  // `center`, rotated by `yaw_radians` about its centre.
  void AddBox(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
              double yaw_radians, int source_line = 0);

  // Adds a prism. The footprint must be convex with at least three vertices, either winding
  // (it is stored counter-clockwise); 0 <= z_min < z_max; surface kFurniture or kObstacle.
  // CHECK-fails otherwise (the parser validates user input first).
  void AddPrism(std::vector<Eigen::Vector2d> footprint, double z_min_meters,
                double z_max_meters, Surface surface, int source_line = 0);
  // A rectangular prism of size_meters (x along the yawed box axis) centred at `center`.
  void AddBoxPrism(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
                   double yaw_radians, double z_min_meters, double z_max_meters,
                   Surface surface, int source_line = 0);
  // A table: a top slab of size_meters at [height - top thickness, height] on four square legs
  // [0, height - top thickness] inset from the corners (all kFurniture). Needs each side larger
  // than 2 * (leg inset + leg width) and height larger than the top thickness.
  void AddTable(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
                double yaw_radians, double height_meters, int source_line = 0,
                const TableShape& shape = TableShape());
  // A shelf standing with its back along the segment back_a -> back_b, on the left of that
  // segment seen from above: a lower part `lower_depth` deep from the floor to lower_height,
  // and an upper part `upper_depth` deep from lower_height to height (both kFurniture).
  void AddShelf(const Eigen::Vector2d& back_a, const Eigen::Vector2d& back_b,
                double lower_depth_meters, double lower_height_meters,
                double upper_depth_meters, double height_meters, int source_line = 0);

  // Vertical extent: walls span [0, wall_height], the ceiling is the plane z = ceiling_height
  // (+infinity: none). Both > 0 (CHECK).
  void SetHeights(double wall_height_meters, double ceiling_height_meters);
  double wall_height_meters() const { return wall_height_meters_; }
  double ceiling_height_meters() const { return ceiling_height_meters_; }

  const std::vector<WallSegment>& walls() const { return walls_; }
  const std::vector<Prism>& prisms() const { return prisms_; }
  bool empty() const { return walls_.empty(); }

  // Casts the ray origin + t * (cos(angle), sin(angle)), t >= 0 (world frame), and returns
  // true with the distance `*range_meters` to the nearest wall hit with t <= max_range_meters.
  // Exact segment intersection; a ray parallel to a wall never hits it (grazing), a ray
  // through a wall end point hits it. Returns false when nothing is hit within range.
  // Walls only (see the file comment).
  bool CastRay(const Eigen::Vector2d& origin, double angle_radians, double max_range_meters,
               double* range_meters) const;

  // Casts one ray per entry of `angles_radians` (world frame) from the same origin, with the
  // same result as CastRay for each: `(*ranges_meters)[i]` is the range of ray i, or +infinity
  // when it hits nothing within max range. Faster than calling CastRay per ray: each wall
  // is tested only against the rays inside the angle it subtends at the origin, so a scan
  // costs O(walls log rays + rays + hits) instead of O(walls * rays). Walls only.
  void CastRays(const Eigen::Vector2d& origin, const std::vector<double>& angles_radians,
                double max_range_meters, std::vector<double>* ranges_meters) const;

  // Casts the 3D ray origin + t * direction (direction normalised here; t >= 0, world frame)
  // against the floor, the ceiling, the walls (z within [0, wall height]) and the prisms
  // (exact slab clipping of the convex prism), and returns the nearest hit with
  // t <= max_range_meters (hit = false otherwise). A ray starting inside a prism hits it at 0.
  // Touching counts as a hit (a ray through a wall's top edge or a prism's corner hits it).
  RayHit CastRay3D(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                   double max_range_meters) const;
  // CastRay3D for many directions from one origin (same results); structures farther than
  // max range from the origin (horizontally) are skipped once for all rays.
  void CastRays3D(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& directions,
                  double max_range_meters, std::vector<RayHit>* hits) const;

  // True when nothing (walls, prisms, floor, ceiling) blocks the open segment from p to q:
  // hits closer than `end_margin_meters` to q are ignored (q may lie on a wall, e.g. a tag).
  bool LineOfSight(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                   double end_margin_meters = 0.02) const;

  // True when the closed segment p..q crosses or touches any wall.
  bool SegmentHitsWall(const Eigen::Vector2d& p, const Eigen::Vector2d& q) const;

  // Euclidean distance from `p` to the nearest wall (infinity for an empty world).
  double DistanceToNearestWall(const Eigen::Vector2d& p) const;
  // Horizontal distance from `p` to the nearest wall or prism footprint (0 inside a
  // footprint; infinity when there is nothing).
  double DistanceToNearestStructure(const Eigen::Vector2d& p) const;

  // Axis-aligned bounds of all wall end points (an empty box for an empty world).
  Eigen::AlignedBox2d Bounds() const;

 private:
  std::vector<WallSegment> walls_;
  std::vector<Prism> prisms_;
  double wall_height_meters_ = std::numeric_limits<double>::infinity();
  double ceiling_height_meters_ = std::numeric_limits<double>::infinity();
};

// A 2D scanning laser on the robot's origin, looking along the robot's x axis.
// Beam i of n is at angle  -fov/2 + i * fov / n       for even n (e.g. 180 or 360 over 180°:
//                                                     -90° .. +89° / +89.5°, the SICK modes)
//                          -fov/2 + i * fov / (n - 1) for odd n (361 over 180°: -90° .. +90°)
// which is how core/carmen_log.h recovers FLASER beam angles by default (180° fans); for
// other fans WriteCarmenLog adds PARAM lines (fov, resolution, max range), so a written log
// reads back with the same angles and the same no-return range. Beams that hit nothing within
// max range, and dropouts, are "no return" readings.
struct LaserOptions {
  double field_of_view_radians = M_PI;
  int num_beams = 361;
  double max_range_meters = 30.0;
  double range_noise_std_meters = 0.01;  // Gaussian, added to every returned range
  double dropout_probability = 0.002;    // per beam, independent
  double rate_hz = 10.0;

  // Checks: 0 < fov <= 2 pi, 2 <= num_beams <= 100000, 0 < max range <= 1000 m,
  // 0 <= noise < max range, 0 <= dropout < 1, 0 < rate <= 1000 Hz.
  bool IsValid(std::string* error) const;
  // Beam angles in the sensor frame (radians), by the rule above.
  std::vector<double> BeamAnglesRadians() const;
  // The angle between neighbouring beams.
  double AngleIncrementRadians() const;
};

// A differential-drive robot following waypoints.
struct RobotOptions {
  double max_speed_mps = 0.5;
  double max_turn_rate_radps = 45.0 * M_PI / 180.0;

  // Checks 0 < speed <= 20 m/s and 0 < turn rate <= 4 pi rad/s.
  bool IsValid(std::string* error) const;
};

// Wheel odometry: the true pose increment between two samples, (dx, dy, dtheta) in the body
// frame at the earlier sample with travelled distance d = |(dx, dy)|, is corrupted as
//   dx'     = dx + n_t,      n_t ~ N(0, trans_noise^2 * d)
//   dtheta' = dtheta + n_r,  n_r ~ N(0, rot_noise_per_m^2 * d + rot_noise_per_rad^2 * |dtheta|)
// (variances grow linearly with the increment: a random walk whose statistics do not depend
// on the sampling rate), and the noisy increments are chained. The odometry frame is the
// world frame at the start: odometry starts at the true initial pose and then drifts.
struct OdometryOptions {
  double rate_hz = 20.0;                              // ODOM lines per second
  double trans_noise_meters_per_sqrt_meter = 0.02;
  double rot_noise_radians_per_sqrt_meter = 0.5 * M_PI / 180.0;
  double rot_noise_radians_per_sqrt_radian = 0.2 * std::sqrt(M_PI / 180.0);  // 0.2°/sqrt(°)

  // Checks 0 < rate <= 1000 Hz and all noise densities finite and >= 0.
  bool IsValid(std::string* error) const;
};

// ---- Team scenarios ---------------------------------------------------------------------

enum class RobotKind { kWheeled, kUav, kHumanoid };
// "wheeled", "uav", "humanoid" (the robot_kind of core/robot_log.h).
const char* RobotKindName(RobotKind kind);

// MARG unit in the body frame (see datasets/README.md "MARG and attitude"):
//   gyro  = omega_body + b_g(t) + n_g,  b_g(0) ~ N(0, gyro_bias^2) per axis, then a random walk
//           of gyro_bias_walk * sqrt(dt) per sample; n_g ~ N(0, gyro_noise^2)
//   accel = R^T (a_world + g e_z) + b_a + n_a,  b_a ~ N(0, accel_bias^2) once, n_a white
//   mag   = R^T m_world + n_m,  m_world = (horizontal field, 0, -vertical field)
//   attitude (roll, pitch, yaw) = truth + c + n, c ~ N(0, attitude_offset^2) once per angle,
//           n ~ N(0, attitude_noise^2) per sample.
struct MargOptions {
  double rate_hz = 100.0;
  double gyro_noise_radps = 0.1 * M_PI / 180.0;
  double gyro_bias_radps = 0.5 * M_PI / 180.0;
  double gyro_bias_walk_radps_per_sqrt_s = 0.01 * M_PI / 180.0;
  double accel_noise_mps2 = 0.05;
  double accel_bias_mps2 = 0.05;
  double mag_noise_microtesla = 0.5;
  double attitude_noise_radians = 0.2 * M_PI / 180.0;
  double attitude_offset_radians = 0.5 * M_PI / 180.0;
  double gravity_mps2 = 9.81;
  double mag_horizontal_microtesla = 20.0;  // along world x (magnetic north)
  double mag_vertical_microtesla = 44.0;    // pointing down

  // Rate in (0, 1000] Hz, every noise finite and >= 0, gravity > 0, field strengths finite.
  bool IsValid(std::string* error) const;
};

// The camera, rigidly on the laser. laser_T_camera maps OpenCV optical-frame points into the
// laser frame. Default: 3 cm forward and 4 cm above the laser, looking along the laser's x.
struct CameraOptions {
  bool enabled = true;
  double rate_hz = 5.0;
  int width = 640, height = 480;
  double fx = 500.0, fy = 500.0, cx = 319.5, cy = 239.5;  // pixels
  Eigen::Isometry3d laser_T_camera = DefaultLaserTCamera(Eigen::Vector3d(0.03, 0.0, 0.04),
                                                         0.0, 0.0, 0.0);

  // The optical frame at `translation` with a camera body (x forward, y left, z up) rotated by
  // Z-Y-X (roll, pitch, yaw) in the laser frame.
  static Eigen::Isometry3d DefaultLaserTCamera(const Eigen::Vector3d& translation,
                                               double roll_radians, double pitch_radians,
                                               double yaw_radians);
  // Rate in (0, 100] Hz, 16 <= width, height <= 4096, focal lengths > 0, principal point
  // inside the image.
  bool IsValid(std::string* error) const;
};

// UAV downward rangefinder: distance straight down (world -z) from the body origin to the
// first surface (floor, or furniture below), plus N(0, noise^2).
struct AltimeterOptions {
  double rate_hz = 20.0;
  double noise_std_meters = 0.01;
  bool IsValid(std::string* error) const;
};

// One phase of a humanoid's head pitch profile (pitch positive = looking down). The profile
// plays its phases in order and starts again from the first when it ends.
struct HeadPhase {
  enum class Type { kLevel, kHold, kMove, kSweep };
  Type type = Type::kLevel;
  double duration_seconds = 1.0;
  double pitch_radians = 0.0;      // kHold: the pitch; kMove: the pitch reached at the end
  double min_pitch_radians = 0.0;  // kSweep: triangle wave min -> max -> min ...
  double max_pitch_radians = 0.0;
  double period_seconds = 1.0;     // kSweep: one min -> max -> min cycle
};

// One step of a robot's plan, executed in file order.
struct RouteStep {
  enum class Type { kWaypoint, kStand, kCommand };
  Type type = Type::kWaypoint;
  Eigen::Vector2d target = Eigen::Vector2d::Zero();  // kWaypoint (world frame)
  double altitude_meters = std::numeric_limits<double>::quiet_NaN();  // kWaypoint, UAV only
  double duration_seconds = 0.0;  // kStand, kCommand
  double vx_mps = 0.0, vy_mps = 0.0, yaw_rate_radps = 0.0;  // kCommand (body frame)
  int source_line = 0;
};

// One robot of a team scenario (a robot_begin .. robot_end block). Defaults depend on the kind
// (DefaultRobotSpec); see datasets/README.md for the motion models.
struct RobotSpec {
  std::string name;
  RobotKind kind = RobotKind::kWheeled;
  int source_line = 0;
  Pose2 start_pose;                         // world_T_body on the floor (UAV: at altitude)
  bool has_start_pose = false;              // else the first waypoint facing the second
  double altitude_meters = 1.5;             // UAV: start and default cruise altitude
  std::vector<RouteStep> route;             // at least one step
  RobotOptions motion;                      // max speed and yaw rate
  LaserOptions laser;
  Eigen::Isometry3d body_T_laser = Eigen::Isometry3d::Identity();  // humanoid: head level
  double head_joint_height_meters = 0.45;   // humanoid: the head pitch axis (body y) height
  std::vector<HeadPhase> head_profile;      // humanoid; empty = level
  MargOptions marg;
  CameraOptions camera;
  OdometryOptions odometry;                 // wheeled
  AltimeterOptions altimeter;               // UAV

  // Head pitch at time t since the start (radians); 0 without a profile.
  double HeadPitchRadians(double t_seconds) const;
  // body_T_laser at head pitch `head_pitch_radians` (other kinds: body_T_laser).
  Eigen::Isometry3d BodyTLaser(double head_pitch_radians) const;
  // The initial world_T_body (SE(2) part): start pose or the first waypoint facing the next.
  Pose2 InitialPose() const;
  bool IsValid(std::string* error) const;
};

// Kind defaults: wheeled 0.5 m/s, 45 deg/s, laser 0.3 m above the floor, 10 cm forward;
// humanoid 0.15 m/s, 30 deg/s, laser in the head 0.5 m above the floor (joint at 0.45 m);
// UAV 0.6 m/s, 60 deg/s, laser 5 cm above the body origin. All: a 240 deg, 667-beam, 5.6 m,
// 10 Hz laser with 1 cm noise and 0.5 % dropouts, MARG at 100 Hz, camera at 5 Hz.
RobotSpec DefaultRobotSpec(const std::string& name, RobotKind kind);

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

// Parses scenario text; `source_name` prefixes every error message ("name:line: ...").
// On error `*scenario` is left in an unspecified state.
Status ParseScenario(const std::string& text, const std::string& source_name,
                     Scenario* scenario);

// Reads and parses a scenario file; errors name the file (and the line).
Status ReadScenarioFile(const std::string& path, Scenario* scenario);

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_WORLD_H_
