// The simulator's world and scenario: a 2D floor plan made of wall segments, a waypoint route,
// and the robot and sensor settings, read from a small text format.
//
// Frames and units: the world frame is right-handed, x east, y north, z up; all lengths in
// metres. Scenario files write angles in degrees (easier to author); every struct here holds
// radians, with the unit in the field name.
//
// Scenario file format (full description in datasets/README.md). One statement per line,
// fields separated by white space, '#' starts a comment (to the end of the line), blank lines
// are ignored:
//   wall x1 y1 x2 y2                       a wall from (x1, y1) to (x2, y2)
//   box cx cy w h [yaw_deg]                four walls around a w x h rectangle centred at
//                                          (cx, cy), rotated by yaw_deg (default 0)
//   waypoint x y                           the route, in order (at least one)
//   start x y yaw_deg                      optional initial pose; default: the first
//                                          waypoint, facing the second
//   laser fov_deg num_beams max_range_m noise_std_m dropout_prob rate_hz
//   robot speed_mps turn_rate_dps
//   odometry rate_hz trans_noise_m_per_sqrt_m rot_noise_deg_per_sqrt_m rot_noise_deg_per_sqrt_deg
//   duration_limit_s seconds
// `laser`, `robot`, `odometry` and `duration_limit_s` are optional (defaults below) and may
// appear at most once. Any error (unknown keyword, wrong field count, a non-numeric or
// non-finite number, a value out of range, a repeated singleton) is reported as
// "file:line: message"; a scenario-level error (no waypoints) names the file.
//
// The world is meant to grow (wall heights, floor obstacles, fiducial tags, several robots);
// today it is strictly 2D: walls are infinitely tall, zero-thickness segments.
#ifndef HETSLAM_DATASETS_SIM_WORLD_H_
#define HETSLAM_DATASETS_SIM_WORLD_H_

#include <cmath>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {
namespace sim {

// A wall: the segment from `a` to `b` in the world frame (metres), infinitely tall, zero
// thickness. `source_line` is the scenario line it came from (0 when added in code).
struct WallSegment {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  int source_line = 0;
};

// A floor plan of wall segments with exact ray casting. Queries are brute force over all
// walls (O(walls) per ray): a few hundred walls and a few hundred thousand rays take well
// under a second.
class World {
 public:
  // Adds one wall. CHECK-fails on a non-finite or zero-length segment (the parser reports
  // those as user errors before calling this).
  void AddWall(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int source_line = 0);
  // Adds the four walls of a `size_meters.x() x size_meters.y()` rectangle centred at
  // `center`, rotated by `yaw_radians` about its centre.
  void AddBox(const Eigen::Vector2d& center, const Eigen::Vector2d& size_meters,
              double yaw_radians, int source_line = 0);

  const std::vector<WallSegment>& walls() const { return walls_; }
  bool empty() const { return walls_.empty(); }

  // Casts the ray origin + t * (cos(angle), sin(angle)), t >= 0 (world frame), and returns
  // true with the distance `*range_meters` to the nearest wall hit with t <= max_range_meters.
  // Exact segment intersection; a ray parallel to a wall never hits it (grazing), a ray
  // through a wall end point hits it. Returns false when nothing is hit within range.
  bool CastRay(const Eigen::Vector2d& origin, double angle_radians, double max_range_meters,
               double* range_meters) const;

  // Casts one ray per entry of `angles_radians` (world frame) from the same origin, with the
  // same result as CastRay for each: `(*ranges_meters)[i]` is the range of ray i, or +infinity
  // when it hits nothing within max range. Faster than calling CastRay per ray: each wall
  // is tested only against the rays inside the angle it subtends at the origin, so a scan
  // costs O(walls log rays + rays + hits) instead of O(walls * rays).
  void CastRays(const Eigen::Vector2d& origin, const std::vector<double>& angles_radians,
                double max_range_meters, std::vector<double>* ranges_meters) const;

  // True when the closed segment p..q crosses or touches any wall.
  bool SegmentHitsWall(const Eigen::Vector2d& p, const Eigen::Vector2d& q) const;

  // Euclidean distance from `p` to the nearest wall (infinity for an empty world).
  double DistanceToNearestWall(const Eigen::Vector2d& p) const;

  // Axis-aligned bounds of all wall end points (an empty box for an empty world).
  Eigen::AlignedBox2d Bounds() const;

 private:
  std::vector<WallSegment> walls_;
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

  // The initial pose: `start_pose` if given, else the first waypoint facing the second
  // (facing +x when there is only one waypoint).
  Pose2 InitialPose() const;
  // Index of the first waypoint still to be reached: 1 when the start is the implied first
  // waypoint, 0 when an explicit start pose is given.
  int FirstWaypointToReach() const;

  // Checks every option struct, at least one waypoint, a non-empty world and a positive
  // duration limit.
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
