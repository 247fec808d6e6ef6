// ROS 1 bags (rosbag format 2.0, plain or bz2/lz4-compressed chunks) in and out, through Debian's
// own rosbag_storage library and message headers: no ROS installation and no hand-written
// parser. ReadMeasurementLog (core/measurement_log.h) calls ReadRosBag for a file that starts
// with `#ROSBAG V2.0`; this header names no ROS type, so embedders need no ROS headers, and
// hetslam_core links no ROS library: the ROS libraries are linked by a plugin loaded when a bag
// is first read or written (CheckRosBagSupport below, core/ros_bag_plugin.h).
//
// What becomes what (frames: REP-103, body x forward, y left, z up, like core/measurement.h):
//   sensor_msgs/LaserScan        -> LaserReading; beam i at angle_min + i * angle_increment,
//                                   range_min/range_max kept; robot_T_sensor is the laser mount
//                                   (options, else /tf_static base_frame -> scan frame, else
//                                   identity with a warning).
//   sensor_msgs/Imu              -> MargSample (angular_velocity, linear_acceleration as specific
//                                   force; no magnetometer), rotated into base_frame when
//                                   /tf_static has the IMU's mount; and, when the message carries
//                                   an orientation (orientation_covariance[0] != -1), an
//                                   AttitudeReading (roll, pitch, yaw of base_frame).
//   nav_msgs/Odometry            -> OdometryReading (x, y and yaw of pose.pose).
//   geometry_msgs/Twist(Stamped) -> VelocityCommand (linear.x, linear.y, angular.z); a bare
//                                   Twist has no header and takes the bag's record time.
//   sensor_msgs/Image            -> CameraImage: written as an 8-bit grey PGM into
//                                   image_directory (mono8, mono16, rgb8, bgr8, rgba8, bgra8);
//                                   read only when image_directory is set.
// Stamps are header.stamp in seconds (the bag's record time when a header stamp is zero).
// Each measurement's `line_number` is the message's 1-based position in the bag (record-time
// order over all topics), the "offset" that errors and warnings name.
//
// Topic choice per kind: "" = automatic (the bag's only topic of that type; among several, the
// conventional name /scan, /imu/data or /imu, /odom, /cmd_vel, else: scans an error listing
// them, other kinds a warning and none read); "none" = do not read that kind; any other value
// must be a topic of the bag with an accepted type (else an error listing the bag's topics);
// a name without the leading '/' matches the global topic ("scan" is "/scan").
#ifndef HETSLAM_CORE_ROS_BAG_H_
#define HETSLAM_CORE_ROS_BAG_H_

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "Eigen/Geometry"
#include "core/measurement.h"
#include "core/status.h"
#include "core/trajectory_io.h"

namespace hetslam {

// Ok when bags can be read and written here: this build has the ROS 1 bag support (CMake
// option HETSLAM_WITH_ROSBAG and the Debian packages found) and its plugin,
// libhetslam_rosbag_plugin.so, loads. The ROS libraries are only in the plugin, which is loaded
// (dlopen) on the first call of this or a function below, so a program that never touches a bag
// never maps them. Looked for in this order: $HETSLAM_ROSBAG_PLUGIN (its full path; nothing else
// is tried when set), the build tree's plugin, the installed one (<libdir>/hetslam/). Otherwise
// the error every function below returns: built without the support (the packages to install),
// or the plugin not loaded (every path tried, with dlerror()'s reason).
Status CheckRosBagSupport();

// CheckRosBagSupport().ok().
bool RosBagSupported();

struct RosBagReadOptions {
  std::string scan_topic;   // sensor_msgs/LaserScan; "" = automatic, see above
  std::string imu_topic;    // sensor_msgs/Imu; "none" = no MARG samples
  std::string odom_topic;   // nav_msgs/Odometry
  std::string cmd_topic;    // geometry_msgs/Twist or geometry_msgs/TwistStamped
  std::string image_topic;  // sensor_msgs/Image; used only with image_directory
  // Folder that receives the images as <message number>.pgm (created if missing); "" = no
  // images are read.
  std::string image_directory;
  // The robot body frame the laser and IMU mounts are looked up against in /tf_static.
  std::string base_frame = "base_link";
  // The laser mount (base_frame <- laser frame); when set it wins over /tf_static.
  std::optional<Eigen::Isometry3d> robot_T_laser;
  bool lenient = false;  // skip unusable messages with a count instead of failing
  int max_warnings_kept = 10;

  bool IsValid(std::string* error) const;
};

struct RosBagContents {
  // Each kind in the bag's record-time order; ReadMeasurementLog merges them by stamp.
  std::vector<LaserReading> lasers;
  std::vector<MargSample> marg;
  std::vector<AttitudeReading> attitudes;
  std::vector<OdometryReading> odometry;
  std::vector<VelocityCommand> commands;
  std::vector<CameraImage> images;
  // What was read: "scan_topic", "imu_topic", "odom_topic", "cmd_topic", "image_topic" (the
  // topic or "none"), "laser_frame" and "laser_mount" ("options", "tf_static" or "identity").
  std::map<std::string, std::string> params;
  std::vector<std::string> warnings;  // first few, "file: message N (topic): text"
  int malformed_messages_skipped = 0;  // lenient mode only
};

// Reads the ROS 1 bag at `path`. Errors name the file: it cannot be opened or is not a bag,
// it is truncated or corrupt (the library's reason), a requested topic is missing or has the
// wrong type (both list the bag's topics with their types), no LaserScan topic or no scan.
Status ReadRosBag(const std::string& path, const RosBagReadOptions& options, RosBagContents* contents);

struct TrajectoryBagOptions {
  std::string pose_topic = "/hetslam/pose";  // one geometry_msgs/PoseStamped per pose
  std::string path_topic = "/hetslam/path";  // one nav_msgs/Path with every pose, at the end
  std::string frame_id = "map";              // header.frame_id of both
  bool IsValid(std::string* error) const;
};

// Writes `trajectory` (planar world_T_body poses, z = 0) as a ROS 1 bag that RViz and the rqt
// tools can play: each pose as a PoseStamped stamped with its own time, then one Path. A stamp
// before ROS's smallest time (1 ns) is recorded at that time (header stamps keep the pose's).
Status WriteTrajectoryBag(const std::string& path, const std::vector<StampedPose2>& trajectory,
                          const TrajectoryBagOptions& options);

}  // namespace hetslam

#endif  // HETSLAM_CORE_ROS_BAG_H_
