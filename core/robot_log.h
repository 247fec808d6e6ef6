// The hetslam multi-sensor robot log (the simulator's output format; any robot can be logged
// into it) and its reader. Full description with examples in datasets/README.md; the writer is
// core/robot_log_writer.h, the team manifest core/team_manifest.h.
//
// A dataset is a directory with a team manifest `team.txt` and one directory per robot holding
// `log.txt` and its camera images. Everything is text, one message per line, fields separated
// by white space, '#' lines and blank lines are comments, numbers in C locale.
//
// Frames and units (SI, radians):
//  - world: the simulator's frame, z up. Only TRUTH and manifest `tag` lines use it; a robot
//    never knows it (its SLAM starts at its own origin).
//  - body: x forward, y left, z up. Wheeled robots and humanoids: origin on the floor under the
//    robot (z = 0 when standing on the floor); UAVs: the airframe centre.
//  - laser: x along the beam of angle 0, z up (the LaserScan sensor frame).
//  - camera: OpenCV optical frame (x right, y down, z forward), rigidly mounted on the laser
//    (a humanoid's camera and laser both sit in its head).
//  - tag: origin at the tag centre, x right and y up as seen when facing the tag, z out of the
//    tag towards the viewer.
//  - Euler angles (roll, pitch, yaw) are Z-Y-X as everywhere in hetslam:
//    R = R_z(yaw) R_y(pitch) R_x(roll), pitch positive nose down (see core/euler.h).
//    A pose "x y z roll pitch yaw" is the transform a_T_b with translation (x, y, z) and that
//    rotation.
//
// Messages of a robot log (the time stamp t, seconds, always comes second):
//   HSLOG version                       first non-comment line; version 1
//   PARAM name value                    robot_name, robot_kind (wheeled | uav | humanoid),
//                                       camera_fx/_fy/_cx/_cy/_width/_height (pixels),
//                                       laser_T_camera "x y z roll pitch yaw", anything else
//   LASER t n angle_min angle_increment range_min range_max r_1 .. r_n
//                                       a 2D scan in the laser frame; a range that is not
//                                       finite ("nan"), <= range_min or >= range_max is "no
//                                       return" and stays in the scan as read (LaserScan drops it)
//   MOUNT t x y z roll pitch yaw        body_T_laser from the robot's kinematics, holds until
//                                       the next MOUNT (humanoid head joint: at every scan;
//                                       fixed mounts: once, before the first LASER)
//   MARG t gx gy gz ax ay az mx my mz   raw MARG sample in the body frame: gyro rad/s,
//                                       specific force m/s², magnetic field µT
//   ATTITUDE t roll pitch yaw           the body attitude the MARG unit's own filter reports
//                                       (yaw relative to magnetic north, i.e. world x)
//   ALTITUDE t z                        body height above the floor from a rangefinder (UAV)
//   ODOM t x y theta                    wheel odometry pose (odometry frame), wheeled robots
//   COMMAND t vx vy yaw_rate            controller command, body frame, m/s and rad/s
//   IMAGE t path                        a camera image (8-bit grey PNG), path relative to the
//                                       log's directory
//   TRUTH t x y z roll pitch yaw        ground truth world_T_body (simulated data only), at
//                                       every LASER and IMAGE stamp
//
// Errors, as for CARMEN logs (core/carmen_log.h): every message names file and line
// ("uav/log.txt:120: MARG needs 9 numbers after the stamp (gx .. mz), found 7"). A malformed
// line (unknown message, wrong field count, a non-numeric or non-finite number where one is
// required, a beam count that is negative, over 100000 or not the number of ranges present,
// LASER range limits not 0 <= range_min < range_max, LASER angles outside the range of
// CheckBeamAngles in core/laser_scan.h (a zero increment, beams spanning more than one turn),
// a number beyond the magnitude limits of core/robot_log_text.h: stamps 1e12 s, positions 1e7 m,
// speeds and rates 1e3 m/s or rad/s, range_max 1e5 m) is an error unless
// `lenient` is set, in which case it is skipped and counted. Time stamps going backwards
// within one message type are counted and the first few reported in `warnings`, never
// reordered. A missing or wrong HSLOG header is an error even when lenient.
#ifndef HETSLAM_CORE_ROBOT_LOG_H_
#define HETSLAM_CORE_ROBOT_LOG_H_

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/camera_model.h"
#include "core/euler.h"
#include "core/laser_scan.h"
#include "core/measurement.h"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

struct StampedPose3 {
  double stamp_seconds = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  int line_number = 0;  // 0 when not read from a file
};

struct RobotLogReadOptions {
  bool lenient = false;        // skip malformed lines with a count instead of failing
  int max_warnings_kept = 10;  // how many warning messages to keep verbatim
};

struct RobotLogStats {
  int lines = 0;
  int comment_lines = 0;
  int malformed_lines_skipped = 0;            // only in lenient mode
  int non_finite_ranges = 0;                  // "nan"/"inf" ranges (kept as no return)
  std::map<std::string, int> timestamps_backwards;  // per message type
  std::map<std::string, int> message_counts;        // per message type
};

struct RobotLog {
  std::string path;       // the file read
  std::string directory;  // its directory, for resolving IMAGE paths
  int version = 0;
  std::map<std::string, std::string> params;
  std::vector<LaserReading> lasers;
  std::vector<StampedPose3> mounts;  // body_T_laser
  std::vector<MargSample> marg;
  std::vector<AttitudeReading> attitudes;
  std::vector<AltitudeReading> altitudes;
  std::vector<OdometryReading> odometry;
  std::vector<VelocityCommand> commands;
  std::vector<CameraImage> images;
  std::vector<StampedPose3> truth;  // world_T_body
  RobotLogStats stats;
  std::vector<std::string> warnings;  // first few, "file:line: message"

  // Camera intrinsics and laser_T_camera from the PARAMs; an error naming the missing or
  // malformed parameter when the log has none or bad ones.
  Status CameraModel(CameraIntrinsics* intrinsics, Eigen::Isometry3d* laser_T_camera) const;
  // `directory`/`image.path`.
  std::string ImagePath(const CameraImage& image) const;
};

Status ReadRobotLog(const std::string& path, const RobotLogReadOptions& options, RobotLog* log);

}  // namespace hetslam

#endif  // HETSLAM_CORE_ROBOT_LOG_H_
