// Landmark-based relative pose between two robots (paper §V-A, eq. 4).
//
// A robot that sees a fiducial (an AprilTag, merger/tag_detector.h) learns the tag's pose in its
// own planar frame, T_L^robot. Two robots that have seen the same tag L then know how their frames
// sit relative to each other:
//   T_robot2^robot1 = T_L^robot1 · T_robot2^L = robot1_T_L · (robot2_T_L)^-1      (eq. 4)
//
// The planar landmark frame L: origin at the tag centre projected onto the floor plane, x along
// the tag's outward normal (from the wall into the room, towards whoever can see it) projected
// onto the floor, z up. Tags hang on vertical walls, so the normal is horizontal and its heading
// is well defined; a tag seen nearly flat (normal within 30° of vertical) has none and is refused.
//
// Frames of a sighting (core/robot_log.h): camera (OpenCV optical) -> laser (laser_T_camera, a
// PARAM) -> body (body_T_laser, the MOUNT in force: a humanoid's head joint) -> the body's
// heading frame (level, the body's yaw: R_y(pitch) R_x(roll), the body attitude) = the planar
// robot frame of SLAM at the image's stamp.
//
// Uncertainty model of a sighting (1 sigma, in the planar frame, growing with the range r from
// camera to tag and the viewing angle v between the tag's normal and the line of sight):
//   s = max(r, min_range) / reference_range,  f = 1 / max(cos v, cos max_view_angle)
//   along the line of sight   sigma_t * s^2 * f   (depth from the tag's apparent size)
//   across it                 sigma_t * s * f
//   heading of the normal     sigma_theta * s * f
// (tag_detector.h measures ~0.4° median and 3 mm at 2 m; the defaults leave room for the robot's
// pose at the image stamp and the camera mount, which the sighting inherits.)
#ifndef HETSLAM_MERGER_LANDMARK_POSE_H_
#define HETSLAM_MERGER_LANDMARK_POSE_H_

#include <string>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

struct TagSightingOptions {
  double reference_range_meters = 2.0;
  double min_range_meters = 0.5;
  double translation_sigma_meters = 0.02;   // sigma_t: at the reference range, head-on
  double rotation_sigma_radians = 0.0175;   // sigma_theta: 1° at the reference range, head-on
  // Sightings farther or more oblique than this are refused (too few pixels to trust).
  double max_range_meters = 8.0;
  double max_view_angle_radians = 70.0 * M_PI / 180.0;

  bool IsValid(std::string* error) const;
};

// One tag seen from a body: the planar landmark frame L in the body's heading frame.
struct PlanarTagSighting {
  Pose2 body_T_tag;                                           // planar, heading frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();   // of (x, y, theta): m², rad²
  double range_meters = 0.0;       // camera to tag centre
  double view_angle_radians = 0.0; // tag normal vs line of sight (0 = head-on)
};

// The planar pose of a tag seen by a camera at body_T_camera (= body_T_laser · laser_T_camera)
// with the body at roll/pitch (radians, core/euler.h), from the detector's camera_T_tag (tag frame
// of tag_detector.h: z out of the tag). Errors: the tag lies behind the camera, farther or more
// oblique than the options allow, or its normal is within 30° of vertical.
Status PlanarTagPose(const Eigen::Isometry3d& body_T_camera, const Eigen::Isometry3d& camera_T_tag,
                     double roll_radians, double pitch_radians, const TagSightingOptions& options,
                     PlanarTagSighting* sighting);

// The covariance of `a_T_tag` after composing with an exact transform `b_T_a` (b_T_a · a_T_tag):
// the translation block turns with b_T_a's rotation.
Eigen::Matrix3d RotateCovariance(const Pose2& b_T_a, const Eigen::Matrix3d& covariance_in_a);

// Eq. 4 with first-order covariance propagation: robot1_T_robot2 = robot1_T_L · (robot2_T_L)^-1,
// the two sightings independent, covariances over (x, y, theta) of each pose's own parameters.
struct RelativePoseEstimate {
  Pose2 robot1_T_robot2;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};
RelativePoseEstimate RelativePoseFromLandmark(const Pose2& robot1_T_landmark, const Eigen::Matrix3d& covariance1,
                                              const Pose2& robot2_T_landmark, const Eigen::Matrix3d& covariance2);

}  // namespace hetslam

#endif  // HETSLAM_MERGER_LANDMARK_POSE_H_
