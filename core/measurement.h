// The measurement vocabulary: one type per kind of sensor reading a robot produces, and
// `Measurement`, the variant an online estimator (frontends/online_estimator.h) is fed one at a
// time. Every log reader (CARMEN, hetslam robot logs: core/measurement_log.h) turns its file
// into a time-ordered stream of these.
//
// Frames and units follow core/robot_log.h: body x forward, y left, z up; SI units, radians;
// Euler angles Z-Y-X (core/robot_log.h). `stamp_seconds` is the time the reading describes (not
// when it arrived); `line_number` is the line of the file it was read from (0 otherwise), so
// that a data error can name it.
#ifndef HETSLAM_CORE_MEASUREMENT_H_
#define HETSLAM_CORE_MEASUREMENT_H_

#include <string>
#include <variant>

#include "Eigen/Core"
#include "core/laser_scan.h"
#include "core/se2.h"

namespace hetslam {

// A 2D laser scan; scan.robot_T_sensor is the mount in force at the scan (a humanoid's head
// joint moves it). CARMEN logs store a pose with each scan (FLASER: raw odometry), kept here.
struct LaserReading {
  LaserScan scan;
  Pose2 odometry_pose;  // odometry frame; meaningful only when has_odometry_pose
  bool has_odometry_pose = false;
  int line_number = 0;
};

// Wheel odometry: the robot's pose in the (drifting) odometry frame.
struct OdometryReading {
  double stamp_seconds = 0.0;
  Pose2 pose;
  int line_number = 0;
};

// One raw MARG (magnetic, angular rate, gravity) sample in the body frame.
struct MargSample {
  double stamp_seconds = 0.0;
  Eigen::Vector3d gyro_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_mps2 = Eigen::Vector3d::Zero();  // specific force
  // Magnetic field; µT in hetslam logs (the attitude filter uses its direction only).
  Eigen::Vector3d magnetometer = Eigen::Vector3d::Zero();
  bool has_magnetometer = true;
  int line_number = 0;
};

// The body attitude as a sensor's own filter reports it (yaw relative to magnetic north).
struct AttitudeReading {
  double stamp_seconds = 0.0;
  double roll_radians = 0.0;
  double pitch_radians = 0.0;
  double yaw_radians = 0.0;
  int line_number = 0;
};

// Height of the body origin above the floor (a UAV's rangefinder).
struct AltitudeReading {
  double stamp_seconds = 0.0;
  double height_meters = 0.0;
  int line_number = 0;
};

// A controller command in the body frame; it holds until the next one.
struct VelocityCommand {
  double stamp_seconds = 0.0;
  double forward_mps = 0.0;     // v_x
  double left_mps = 0.0;        // v_y
  double yaw_rate_radps = 0.0;  // ω_u
  int line_number = 0;
};

// A camera image on disk (8-bit grey PNG in hetslam logs); `path` as the log wrote it,
// relative to the log's directory.
struct CameraImage {
  double stamp_seconds = 0.0;
  std::string path;
  int line_number = 0;
};

using Measurement = std::variant<LaserReading, OdometryReading, MargSample, AttitudeReading, AltitudeReading,
                                 VelocityCommand, CameraImage>;

inline double StampOf(const LaserReading& m) { return m.scan.stamp_seconds; }
template <typename T>
double StampOf(const T& m) {
  return m.stamp_seconds;
}
inline double StampOf(const Measurement& m) {
  return std::visit([](const auto& x) { return StampOf(x); }, m);
}
inline int LineOf(const Measurement& m) {
  return std::visit([](const auto& x) { return x.line_number; }, m);
}

// "laser", "odometry", "marg", "attitude", "altitude", "command", "image".
const char* MeasurementKindName(const Measurement& m);

}  // namespace hetslam

#endif  // HETSLAM_CORE_MEASUREMENT_H_
