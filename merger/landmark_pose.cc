#include "merger/landmark_pose.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/euler.h"

namespace hetslam {
namespace {

// A tag normal closer to vertical than this has no usable heading (see the header).
const double kMaxNormalFromVerticalCos = std::cos(30.0 * M_PI / 180.0);

// d(R(theta) p) / d(theta) = J R(theta) p with J the 90° rotation.
Eigen::Matrix2d Perp() {
  Eigen::Matrix2d j;
  j << 0, -1, 1, 0;
  return j;
}

}  // namespace

bool TagSightingOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(reference_range_meters > 0 && min_range_meters > 0 && translation_sigma_meters > 0 &&
        rotation_sigma_radians > 0 && max_range_meters > 0))
    msg << "tag sighting ranges and sigmas must be > 0; ";
  if (!(max_view_angle_radians > 0 && max_view_angle_radians < M_PI / 2))
    msg << "max_view_angle_radians must be in (0, pi/2); ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

Status PlanarTagPose(const Eigen::Isometry3d& body_T_camera, const Eigen::Isometry3d& camera_T_tag,
                     double roll_radians, double pitch_radians, const TagSightingOptions& options,
                     PlanarTagSighting* sighting) {
  const Eigen::Vector3d t_camera = camera_T_tag.translation();
  const double range = t_camera.norm();
  if (!(t_camera.z() > 0.0) || !std::isfinite(range)) return Status::Error("tag not in front of the camera");
  if (range > options.max_range_meters) {
    std::ostringstream msg;
    msg << "tag " << range << " m away (max_range_meters " << options.max_range_meters << ")";
    return Status::Error(msg.str());
  }
  // Viewing angle: between the tag's normal and the direction from the tag to the camera.
  const Eigen::Vector3d normal_camera = camera_T_tag.linear().col(2);
  const double cos_view = normal_camera.dot(-t_camera) / range;
  if (!(cos_view > std::cos(options.max_view_angle_radians))) {
    std::ostringstream msg;
    msg << "tag seen " << std::acos(std::clamp(cos_view, -1.0, 1.0)) * 180.0 / M_PI
        << " deg off its normal (max_view_angle_radians " << options.max_view_angle_radians << ")";
    return Status::Error(msg.str());
  }
  // The body's heading frame: level, with the body's yaw (R_y(pitch) R_x(roll)).
  Eigen::Isometry3d heading_T_body = Eigen::Isometry3d::Identity();
  heading_T_body.linear() = RotationFromRollPitchYaw(roll_radians, pitch_radians, 0.0);
  const Eigen::Isometry3d heading_T_camera = heading_T_body * body_T_camera;
  const Eigen::Isometry3d heading_T_tag = heading_T_camera * camera_T_tag;
  const Eigen::Vector3d normal = heading_T_tag.linear().col(2);
  if (std::abs(normal.z()) > kMaxNormalFromVerticalCos) return Status::Error("tag normal too close to vertical");
  const Eigen::Vector2d position = heading_T_tag.translation().head<2>();
  sighting->body_T_tag = Pose2(position, std::atan2(normal.y(), normal.x()));
  sighting->range_meters = range;
  sighting->view_angle_radians = std::acos(std::clamp(cos_view, -1.0, 1.0));

  const double s = std::max(range, options.min_range_meters) / options.reference_range_meters;
  const double f = 1.0 / std::max(cos_view, std::cos(options.max_view_angle_radians));
  const double sigma_along = options.translation_sigma_meters * s * s * f;
  const double sigma_across = options.translation_sigma_meters * s * f;
  const double sigma_theta = options.rotation_sigma_radians * s * f;
  // Line of sight in the plane (camera to tag); a camera right above the tag: along the normal.
  Eigen::Vector2d along = position - heading_T_camera.translation().head<2>();
  if (along.norm() < 1e-6) along = -normal.head<2>();
  along.normalize();
  Eigen::Matrix2d axes;
  axes.col(0) = along;
  axes.col(1) = Eigen::Vector2d(-along.y(), along.x());
  sighting->covariance.setZero();
  sighting->covariance.topLeftCorner<2, 2>() =
      axes * Eigen::Vector2d(sigma_along * sigma_along, sigma_across * sigma_across).asDiagonal() *
      axes.transpose();
  sighting->covariance(2, 2) = sigma_theta * sigma_theta;
  return Status::Ok();
}

Eigen::Matrix3d RotateCovariance(const Pose2& b_T_a, const Eigen::Matrix3d& covariance_in_a) {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  rotation.topLeftCorner<2, 2>() = b_T_a.rotation();
  return rotation * covariance_in_a * rotation.transpose();
}

RelativePoseEstimate RelativePoseFromLandmark(const Pose2& robot1_T_landmark, const Eigen::Matrix3d& covariance1,
                                              const Pose2& robot2_T_landmark, const Eigen::Matrix3d& covariance2) {
  // T = A · B^-1 with A = robot1_T_L, B = robot2_T_L:
  //   t_T = t_A - R_A R_B^T t_B,   theta_T = theta_A - theta_B.
  const Pose2& a = robot1_T_landmark;
  const Pose2& b = robot2_T_landmark;
  RelativePoseEstimate estimate;
  estimate.robot1_T_robot2 = a * b.inverse();
  const Eigen::Matrix2d r_t = estimate.robot1_T_robot2.rotation();
  const Eigen::Matrix2d j = Perp();
  Eigen::Matrix3d jacobian_a = Eigen::Matrix3d::Identity();
  jacobian_a.block<2, 1>(0, 2) = j * (estimate.robot1_T_robot2.translation() - a.translation());
  Eigen::Matrix3d jacobian_b = Eigen::Matrix3d::Zero();
  jacobian_b.topLeftCorner<2, 2>() = -r_t;
  jacobian_b.block<2, 1>(0, 2) = r_t * j * b.translation();
  jacobian_b(2, 2) = -1.0;
  estimate.covariance = jacobian_a * covariance1 * jacobian_a.transpose() + jacobian_b * covariance2 * jacobian_b.transpose();
  return estimate;
}

}  // namespace hetslam
