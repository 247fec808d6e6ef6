// A small ROS 1 bag whose content is known by construction, written with Debian's rosbag_storage
// (the library the reader uses): a level robot driving through a 6 m x 4 m rectangular room.
//
// World: walls at x = ±3 m, y = ±2 m. Scan k (10 Hz, k = 0..num_scans-1, stamp kT0 + 0.1 k)
// is taken at the true body pose world_T_body(k) = (0.03 k, 0, 0.01 k) (0.3 m/s forward,
// 0.1 rad/s turn). The laser is mounted at base_link_T_laser = (0.1, 0, 0.3), level, and its
// 181 beams span -135°..135° up to 10 m (ranges ray-cast in 3D to the walls and the floor z = 0,
// float32).
// The IMU is mounted tilted: base_link_T_imu_link = roll 20°, pitch -10°, yaw 90°, so the raw
// samples are nowhere near level while the body is; the body itself may be tilted statically
// by `body_roll_radians`, `body_pitch_radians` (the scans then see the room tilted). IMU at
// 100 Hz: angular velocity R_wb^T (0, 0, 0.1) and specific force R_wb^T (0, 0, 9.81) in the
// body frame, both expressed in the IMU frame; orientation world_q_imu = R_wb base_R_imu, with
// R_wb = R(roll, pitch, yaw(t)).
// Odometry (/odom, 10 Hz at the scan stamps) holds the true pose; /cmd_vel holds a Twist
// (0.3, 0, 0.1) recorded at every scan stamp. /tf_static holds both mounts.
#ifndef HETSLAM_TESTS_CORE_ROS_BAG_TEST_UTIL_H_
#define HETSLAM_TESTS_CORE_ROS_BAG_TEST_UTIL_H_

#include <cmath>
#include <limits>
#include <string>

#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include "Eigen/Geometry"
#include "core/euler.h"
#include "core/se2.h"

namespace hetslam {
namespace testing_bag {

constexpr double kT0 = 1000.0;  // stamp of the first scan, seconds
constexpr double kScanPeriod = 0.1;
constexpr double kImuPeriod = 0.01;
constexpr double kForwardMps = 0.3;
constexpr double kYawRateRadps = 0.1;
constexpr int kBeams = 181;
constexpr double kAngleMin = -135.0 * M_PI / 180.0;
constexpr double kAngleIncrement = 1.5 * M_PI / 180.0;
constexpr double kRangeMax = 10.0;
constexpr double kGravity = 9.81;

struct SyntheticBagOptions {
  int num_scans = 20;
  double body_roll_radians = 0.0;
  double body_pitch_radians = 0.0;
  uint32_t compression = rosbag::compression::Uncompressed;
  bool with_scans = true;
};

inline Pose2 TrueBodyPose(double t_since_start) {
  const double yaw = kYawRateRadps * t_since_start;
  // Constant forward speed and turn rate: the exact arc.
  const double x = kYawRateRadps > 0 ? kForwardMps / kYawRateRadps * std::sin(yaw) : kForwardMps * t_since_start;
  const double y = kYawRateRadps > 0 ? kForwardMps / kYawRateRadps * (1.0 - std::cos(yaw)) : 0.0;
  return Pose2(x, y, yaw);
}

inline Eigen::Isometry3d LaserMount() {
  Eigen::Isometry3d base_T_laser = Eigen::Isometry3d::Identity();
  base_T_laser.translation() = Eigen::Vector3d(0.1, 0.0, 0.3);
  return base_T_laser;
}

inline Eigen::Matrix3d ImuMountRotation() {
  return RotationFromRollPitchYaw(20.0 * M_PI / 180.0, -10.0 * M_PI / 180.0, 90.0 * M_PI / 180.0);
}

// Distance from `origin` along the unit vector `direction` to the room: walls x = ±3, y = ±2,
// floor z = 0.
inline double RayToRoom(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
  double best = std::numeric_limits<double>::infinity();
  if (std::abs(direction.x()) > 1e-12) best = std::min(best, ((direction.x() > 0 ? 3.0 : -3.0) - origin.x()) / direction.x());
  if (std::abs(direction.y()) > 1e-12) best = std::min(best, ((direction.y() > 0 ? 2.0 : -2.0) - origin.y()) / direction.y());
  if (direction.z() < -1e-12) best = std::min(best, -origin.z() / direction.z());
  return best;
}

inline geometry_msgs::TransformStamped MountMessage(const std::string& child, const Eigen::Isometry3d& base_T_child) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time(kT0);
  t.header.frame_id = "base_link";
  t.child_frame_id = child;
  t.transform.translation.x = base_T_child.translation().x();
  t.transform.translation.y = base_T_child.translation().y();
  t.transform.translation.z = base_T_child.translation().z();
  const Eigen::Quaterniond q(base_T_child.linear());
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  t.transform.rotation.w = q.w();
  return t;
}

inline void SetQuaternion(const Eigen::Quaterniond& q, geometry_msgs::Quaternion* out) {
  out->x = q.x();
  out->y = q.y();
  out->z = q.z();
  out->w = q.w();
}

// The expected range of beam `i` of scan `k` (float32, as recorded): cast in 3D from the laser
// on the (possibly tilted) body, so a tilted body's beams reach the walls farther away and the
// floor behind.
inline float ExpectedRange(int k, int i, double body_roll_radians = 0.0, double body_pitch_radians = 0.0) {
  const Pose2 body = TrueBodyPose(k * kScanPeriod);
  Eigen::Isometry3d world_T_body = Eigen::Isometry3d::Identity();
  world_T_body.linear() = RotationFromRollPitchYaw(body_roll_radians, body_pitch_radians, body.theta());
  world_T_body.translation() = Eigen::Vector3d(body.x(), body.y(), 0.0);
  const Eigen::Isometry3d world_T_laser = world_T_body * LaserMount();
  const double angle = kAngleMin + i * kAngleIncrement;
  return static_cast<float>(
      RayToRoom(world_T_laser.translation(), world_T_laser.linear() * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0)));
}

inline void WriteSyntheticBag(const std::string& path, const SyntheticBagOptions& options) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  bag.setCompression(static_cast<rosbag::CompressionType>(options.compression));
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(MountMessage("laser", LaserMount()));
  Eigen::Isometry3d base_T_imu = Eigen::Isometry3d::Identity();
  base_T_imu.linear() = ImuMountRotation();
  tf.transforms.push_back(MountMessage("imu_link", base_T_imu));
  bag.write("/tf_static", ros::Time(kT0), tf);

  const double duration = (options.num_scans - 1) * kScanPeriod;
  const int num_imu = static_cast<int>(std::lround(duration / kImuPeriod)) + 1;
  const Eigen::Matrix3d imu_R_base = ImuMountRotation().transpose();
  int next_scan = 0;
  for (int j = 0; j < num_imu; ++j) {
    const double t = j * kImuPeriod;
    sensor_msgs::Imu imu;
    imu.header.stamp = ros::Time(kT0 + t);
    imu.header.frame_id = "imu_link";
    const Eigen::Matrix3d world_R_body =
        RotationFromRollPitchYaw(options.body_roll_radians, options.body_pitch_radians, kYawRateRadps * t);
    const Eigen::Vector3d gyro = imu_R_base * world_R_body.transpose() * Eigen::Vector3d(0.0, 0.0, kYawRateRadps);
    const Eigen::Vector3d accel = imu_R_base * world_R_body.transpose() * Eigen::Vector3d(0.0, 0.0, kGravity);
    imu.angular_velocity.x = gyro.x();
    imu.angular_velocity.y = gyro.y();
    imu.angular_velocity.z = gyro.z();
    imu.linear_acceleration.x = accel.x();
    imu.linear_acceleration.y = accel.y();
    imu.linear_acceleration.z = accel.z();
    SetQuaternion(Eigen::Quaterniond(world_R_body * ImuMountRotation()), &imu.orientation);
    bag.write("/imu", imu.header.stamp, imu);

    // Scans, odometry and commands at every tenth IMU sample, recorded after it.
    if (j % 10 != 0 || next_scan >= options.num_scans) continue;
    const int k = next_scan++;
    const ros::Time stamp(kT0 + k * kScanPeriod);
    const Pose2 body = TrueBodyPose(k * kScanPeriod);
    if (options.with_scans) {
      sensor_msgs::LaserScan scan;
      scan.header.stamp = stamp;
      scan.header.frame_id = "laser";
      scan.angle_min = static_cast<float>(kAngleMin);
      scan.angle_increment = static_cast<float>(kAngleIncrement);
      scan.angle_max = static_cast<float>(kAngleMin + (kBeams - 1) * kAngleIncrement);
      scan.range_min = 0.05f;
      scan.range_max = static_cast<float>(kRangeMax);
      for (int i = 0; i < kBeams; ++i) {
        scan.ranges.push_back(ExpectedRange(k, i, options.body_roll_radians, options.body_pitch_radians));
      }
      bag.write("/scan", stamp, scan);
    }
    nav_msgs::Odometry odom;
    odom.header.stamp = stamp;
    odom.header.frame_id = "odom";
    odom.child_frame_id = "base_link";
    odom.pose.pose.position.x = body.x();
    odom.pose.pose.position.y = body.y();
    SetQuaternion(Eigen::Quaterniond(Eigen::AngleAxisd(body.theta(), Eigen::Vector3d::UnitZ())),
                  &odom.pose.pose.orientation);
    bag.write("/odom", stamp, odom);
    geometry_msgs::Twist twist;
    twist.linear.x = kForwardMps;
    twist.angular.z = kYawRateRadps;
    bag.write("/cmd_vel", stamp, twist);
  }
  bag.close();
}

}  // namespace testing_bag
}  // namespace hetslam

#endif  // HETSLAM_TESTS_CORE_ROS_BAG_TEST_UTIL_H_
