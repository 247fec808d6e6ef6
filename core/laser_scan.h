// One 2D laser scan and its projection into the robot's ground plane.
//
// Frames: the sensor frame has x along the beam of angle 0, z up; `robot_T_sensor` is the
// sensor mount (SE(3)) in the robot body frame. Invalid beams (NaN or infinite, <= range_min,
// >= range_max) are dropped by every function here: they are never matched or ray-cast.
#ifndef HETSLAM_CORE_LASER_SCAN_H_
#define HETSLAM_CORE_LASER_SCAN_H_

#include <cstdint>
#include <vector>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/status.h"

namespace hetslam {

struct LaserScan {
  double stamp_seconds = 0.0;
  std::vector<double> angles_radians;  // per beam, in the sensor frame
  std::vector<double> ranges_meters;   // per beam; same length as angles_radians
  double range_min_meters = 0.0;
  double range_max_meters = 30.0;
  Eigen::Isometry3d robot_T_sensor = Eigen::Isometry3d::Identity();

  bool IsValidRange(double range_meters) const {
    return range_meters == range_meters && range_meters > range_min_meters &&
           range_meters < range_max_meters;
  }
  int NumValidBeams() const;
};

// The valid range of an evenly spaced scan's angles, as every reader checks them before
// EvenlySpacedAngles: both finite, |first angle| <= 2 pi, and with two or more beams a non-zero
// increment whose beams span at most one turn (|increment| (n - 1) <= 2 pi). An error names the
// fields ("angle_increment 0 with 181 beams: ..."); the caller adds file and line.
Status CheckBeamAngles(int num_beams, double first_angle_radians, double increment_radians,
                       const char* first_name = "angle_min", const char* increment_name = "angle_increment");

// Builds evenly spaced beam angles: angle_i = first_angle + i * increment.
std::vector<double> EvenlySpacedAngles(int num_beams, double first_angle_radians,
                                       double increment_radians);

// A beam end point projected into the robot's ground plane (paper §III-D): `p_robot` is
// the orthographic projection onto the plane z = 0 of the navigation frame (robot
// position, heading only), `z_meters` its height above the floor.
struct ProjectedPoint {
  Eigen::Vector2f p_robot;
  float z_meters;
  int beam_index;
};

// What a scan point is (paper §III-E), as the front end labels it and the map's label layer
// (core/occupancy_grid.h) records it; values are bit positions of that layer. Today the 2.5D
// projection tells floor hits (dropped) from structure; the semantics work adds floor
// obstacles and walls.
enum class PointLabel : uint8_t { kStructure = 0, kFloor = 1, kFloorObstacle = 2, kWall = 3 };

// Attitude and height of the robot body used by the 2.5D projection. A level wheeled
// robot uses the defaults.
struct BodyAttitude {
  double roll_radians = 0.0;
  double pitch_radians = 0.0;
  double base_height_meters = 0.0;  // height of the body frame origin above the floor
};

// Projects the valid beams of `scan` under the 2.5D assumption:
//   p_nav = R_y(pitch) R_x(roll) (robot_T_sensor * e_sensor) + (0, 0, base_height),
// keeping (x, y) and reporting z (paper §III-D, T * T_nav^global * O(T_βγ E)).
std::vector<ProjectedPoint> ProjectScan(const LaserScan& scan, const BodyAttitude& attitude);

// Convenience for a level robot: the 2D end points of the valid beams in the robot frame.
std::vector<Eigen::Vector2f> ScanPointsInRobotFrame(const LaserScan& scan);

// Which of a voxel's points VoxelFilter keeps, by input (beam) order.
enum class VoxelPoint {
  kFirst,   // the first
  // The middle of its n points: the (n / 2)-th (0-based) for an odd n, the midpoint of the two
  // middle ones for an even n. The same point whichever way the beams run; the (n / 2)-th alone
  // would be the last of two, as one-sided as the first where beams are sparse (two a voxel).
  kMiddle,
  // Its first and its last (one point where it has one): where a surface ends in a voxel, its
  // end is kept whichever side of the scan the voxel lies on, and a point inside the surface
  // besides. Up to twice kFirst's points.
  kFirstAndLast,
};

// Keeps one point (`keep`) of every square voxel of side `voxel_size_meters`, so that dense
// near walls do not outvote sparse far structure; the voxels in the order of their first point.
// Non-finite points are left out. Deterministic.
// The first beam of a voxel lies at the same side of it in every voxel: where a surface ends
// in a voxel (a wall's end, an occlusion), the kept point is the end itself on one side of the
// scan and a point inside the surface on the other. Matched, such points turn the pose a
// little towards that side, the same way scan after scan (measured: 1.2 degrees in 60 s on a
// simulated rover's front end). The middle beam has no side; the first and the last have
// both.
std::vector<Eigen::Vector2f> VoxelFilter(const std::vector<Eigen::Vector2f>& points, float voxel_size_meters,
                                         VoxelPoint keep = VoxelPoint::kFirst);

}  // namespace hetslam

#endif  // HETSLAM_CORE_LASER_SCAN_H_
