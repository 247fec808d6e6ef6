// What a simulated robot is and carries: its kind, motion limits and plan (route, humanoid head
// profile) and its sensors (2D laser, wheel odometry, MARG unit, camera, altimeter), with the
// defaults of each kind. Scenario files set them (datasets/sim/scenario.h); the simulators
// (simulator.h, team_simulator.h) use them.
//
// Frames and units: world frame x east, y north, z up; body frame x forward, y left, z up;
// lengths in metres, angles in radians (scenario files write degrees), the unit in every field
// name.
#ifndef HETSLAM_DATASETS_SIM_ROBOT_SPEC_H_
#define HETSLAM_DATASETS_SIM_ROBOT_SPEC_H_

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/se2.h"

namespace hetslam {
namespace sim {

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

// ---- Team robots ------------------------------------------------------------------------

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

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_ROBOT_SPEC_H_
