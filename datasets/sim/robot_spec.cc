#include "datasets/sim/robot_spec.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/euler.h"
#include "glog/logging.h"

namespace hetslam {
namespace sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

bool FiniteNonNegative(double v) { return std::isfinite(v) && v >= 0.0; }

}  // namespace

// ---- Options --------------------------------------------------------------------------------

bool LaserOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(field_of_view_radians > 0.0 && field_of_view_radians <= 2.0 * M_PI + 1e-12)) {
    why << "laser field of view must be in (0, 360] degrees, got "
        << field_of_view_radians / kDegToRad;
  } else if (num_beams < 2 || num_beams > 100000) {
    why << "laser num_beams must be in [2, 100000], got " << num_beams;
  } else if (!(max_range_meters > 0.0 && max_range_meters <= 1000.0)) {
    why << "laser max range must be in (0, 1000] m, got " << max_range_meters;
  } else if (!(range_noise_std_meters >= 0.0 && range_noise_std_meters < max_range_meters)) {
    why << "laser range noise std must be in [0, max range), got " << range_noise_std_meters;
  } else if (!(dropout_probability >= 0.0 && dropout_probability < 1.0)) {
    why << "laser dropout probability must be in [0, 1), got " << dropout_probability;
  } else if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "laser rate must be in (0, 1000] Hz, got " << rate_hz;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

double LaserOptions::AngleIncrementRadians() const {
  CHECK_GE(num_beams, 2) << "num_beams=" << num_beams;
  return num_beams % 2 == 1 ? field_of_view_radians / (num_beams - 1)
                            : field_of_view_radians / num_beams;
}

std::vector<double> LaserOptions::BeamAnglesRadians() const {
  const double increment = AngleIncrementRadians();
  std::vector<double> angles(num_beams);
  for (int i = 0; i < num_beams; ++i) angles[i] = -0.5 * field_of_view_radians + i * increment;
  return angles;
}

bool RobotOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(max_speed_mps > 0.0 && max_speed_mps <= 20.0)) {
    why << "robot speed must be in (0, 20] m/s, got " << max_speed_mps;
  } else if (!(max_turn_rate_radps > 0.0 && max_turn_rate_radps <= 4.0 * M_PI)) {
    why << "robot turn rate must be in (0, 720] deg/s, got " << max_turn_rate_radps / kDegToRad;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

bool OdometryOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "odometry rate must be in (0, 1000] Hz, got " << rate_hz;
  } else if (!(trans_noise_meters_per_sqrt_meter >= 0.0 &&
               std::isfinite(trans_noise_meters_per_sqrt_meter))) {
    why << "odometry translation noise must be finite and >= 0, got "
        << trans_noise_meters_per_sqrt_meter;
  } else if (!(rot_noise_radians_per_sqrt_meter >= 0.0 &&
               std::isfinite(rot_noise_radians_per_sqrt_meter))) {
    why << "odometry rotation noise per sqrt(m) must be finite and >= 0, got "
        << rot_noise_radians_per_sqrt_meter;
  } else if (!(rot_noise_radians_per_sqrt_radian >= 0.0 &&
               std::isfinite(rot_noise_radians_per_sqrt_radian))) {
    why << "odometry rotation noise per sqrt(rad) must be finite and >= 0, got "
        << rot_noise_radians_per_sqrt_radian;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

// ---- Team robots ----------------------------------------------------------------------------

const char* RobotKindName(RobotKind kind) {
  switch (kind) {
    case RobotKind::kWheeled: return "wheeled";
    case RobotKind::kUav: return "uav";
    case RobotKind::kHumanoid: return "humanoid";
  }
  return "unknown";
}

bool MargOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "marg rate must be in (0, 1000] Hz, got " << rate_hz;
  } else if (!(FiniteNonNegative(gyro_noise_radps) && FiniteNonNegative(gyro_bias_radps) &&
               FiniteNonNegative(gyro_bias_walk_radps_per_sqrt_s) &&
               FiniteNonNegative(accel_noise_mps2) && FiniteNonNegative(accel_bias_mps2) &&
               FiniteNonNegative(mag_noise_microtesla) &&
               FiniteNonNegative(attitude_noise_radians) &&
               FiniteNonNegative(attitude_offset_radians))) {
    why << "marg noise and bias values must be finite and >= 0";
  } else if (!(gravity_mps2 > 0.0 && std::isfinite(gravity_mps2))) {
    why << "gravity must be positive, got " << gravity_mps2;
  } else if (!(std::isfinite(mag_horizontal_microtesla) &&
               std::isfinite(mag_vertical_microtesla))) {
    why << "magnetic field must be finite";
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

Eigen::Isometry3d CameraOptions::DefaultLaserTCamera(const Eigen::Vector3d& translation,
                                                     double roll_radians, double pitch_radians,
                                                     double yaw_radians) {
  // Columns: the optical x (right), y (down), z (forward) axes in the camera body frame
  // (x forward, y left, z up).
  Eigen::Matrix3d body_R_optical;
  body_R_optical << 0.0, 0.0, 1.0,  //
      -1.0, 0.0, 0.0,               //
      0.0, -1.0, 0.0;
  Eigen::Isometry3d laser_T_camera = Eigen::Isometry3d::Identity();
  laser_T_camera.linear() = RotationFromRollPitchYaw(roll_radians, pitch_radians, yaw_radians) * body_R_optical;
  laser_T_camera.translation() = translation;
  return laser_T_camera;
}

bool CameraOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!enabled) return true;
  if (!(rate_hz > 0.0 && rate_hz <= 100.0)) {
    why << "camera rate must be in (0, 100] Hz, got " << rate_hz;
  } else if (width < 16 || width > 4096 || height < 16 || height > 4096) {
    why << "camera size must be in [16, 4096] pixels, got " << width << " x " << height;
  } else if (!(fx > 0.0 && fy > 0.0 && std::isfinite(fx) && std::isfinite(fy))) {
    why << "camera focal lengths must be positive, got " << fx << " " << fy;
  } else if (!(cx >= 0.0 && cx <= width && cy >= 0.0 && cy <= height)) {
    why << "camera principal point (" << cx << ", " << cy << ") must be inside the image";
  } else if (!laser_T_camera.matrix().allFinite()) {
    why << "camera mount must be finite";
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

bool AltimeterOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) {
    why << "altimeter rate must be in (0, 1000] Hz, got " << rate_hz;
  } else if (!FiniteNonNegative(noise_std_meters)) {
    why << "altimeter noise must be finite and >= 0, got " << noise_std_meters;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

RobotSpec DefaultRobotSpec(const std::string& name, RobotKind kind) {
  RobotSpec spec;
  spec.name = name;
  spec.kind = kind;
  spec.laser.field_of_view_radians = 240.0 * kDegToRad;
  spec.laser.num_beams = 667;  // 0.36° steps
  spec.laser.max_range_meters = 5.6;
  spec.laser.range_noise_std_meters = 0.01;
  spec.laser.dropout_probability = 0.005;
  spec.laser.rate_hz = 10.0;
  switch (kind) {
    case RobotKind::kWheeled:
      spec.motion.max_speed_mps = 0.5;
      spec.motion.max_turn_rate_radps = 45.0 * kDegToRad;
      spec.body_T_laser.translation() = Eigen::Vector3d(0.1, 0.0, 0.3);
      break;
    case RobotKind::kHumanoid:
      spec.motion.max_speed_mps = 0.15;
      spec.motion.max_turn_rate_radps = 30.0 * kDegToRad;
      // Level head: the laser 3 cm in front of and 5 cm above the head joint (0.45 m).
      spec.body_T_laser.translation() = Eigen::Vector3d(0.03, 0.0, 0.5);
      spec.head_joint_height_meters = 0.45;
      break;
    case RobotKind::kUav:
      spec.motion.max_speed_mps = 0.6;
      spec.motion.max_turn_rate_radps = 60.0 * kDegToRad;
      spec.body_T_laser.translation() = Eigen::Vector3d(0.0, 0.0, 0.05);
      break;
  }
  return spec;
}

double RobotSpec::HeadPitchRadians(double t_seconds) const {
  if (head_profile.empty()) return 0.0;
  double total = 0.0;
  for (const HeadPhase& phase : head_profile) total += phase.duration_seconds;
  double tau = std::fmod(std::max(0.0, t_seconds), total);
  double pitch = 0.0;  // at the start of the current phase
  for (const HeadPhase& phase : head_profile) {
    const bool inside = tau < phase.duration_seconds;
    const double local = inside ? tau : phase.duration_seconds;
    switch (phase.type) {
      case HeadPhase::Type::kLevel:
        pitch = 0.0;
        break;
      case HeadPhase::Type::kHold:
        pitch = phase.pitch_radians;
        break;
      case HeadPhase::Type::kMove:
        pitch += (phase.pitch_radians - pitch) * (local / phase.duration_seconds);
        break;
      case HeadPhase::Type::kSweep: {
        const double u = std::fmod(local, phase.period_seconds) / phase.period_seconds;
        const double triangle = u < 0.5 ? 2.0 * u : 2.0 - 2.0 * u;
        pitch = phase.min_pitch_radians +
                (phase.max_pitch_radians - phase.min_pitch_radians) * triangle;
        break;
      }
    }
    if (inside) return pitch;
    tau -= phase.duration_seconds;
  }
  return pitch;
}

Eigen::Isometry3d RobotSpec::BodyTLaser(double head_pitch_radians) const {
  if (kind != RobotKind::kHumanoid) return body_T_laser;
  // Rotation about the body y axis through the joint point (0, 0, joint height).
  Eigen::Isometry3d joint = Eigen::Isometry3d::Identity();
  joint.translation() = Eigen::Vector3d(0.0, 0.0, head_joint_height_meters);
  Eigen::Isometry3d pitch = Eigen::Isometry3d::Identity();
  pitch.linear() = Eigen::AngleAxisd(head_pitch_radians, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return joint * pitch * joint.inverse() * body_T_laser;
}

Pose2 RobotSpec::InitialPose() const {
  if (has_start_pose) return start_pose;
  std::vector<Eigen::Vector2d> targets;
  for (const RouteStep& step : route) {
    if (step.type == RouteStep::Type::kWaypoint) targets.push_back(step.target);
  }
  CHECK(!targets.empty() && route.front().type == RouteStep::Type::kWaypoint)
      << "robot '" << name << "' has no start pose and does not begin with a waypoint";
  if (targets.size() == 1) return Pose2(targets[0], 0.0);
  const Eigen::Vector2d heading = targets[1] - targets[0];
  return Pose2(targets[0], std::atan2(heading.y(), heading.x()));
}

bool RobotSpec::IsValid(std::string* error) const {
  std::string why;
  std::ostringstream os;
  const bool options_valid = laser.IsValid(&why) && motion.IsValid(&why) &&
                             marg.IsValid(&why) && camera.IsValid(&why) &&
                             odometry.IsValid(&why) && altimeter.IsValid(&why);
  if (!options_valid) {
    os << why;
  } else if (route.empty()) {
    os << "has no waypoint, stand or command lines (at least one is needed)";
  } else if (!has_start_pose && route.front().type != RouteStep::Type::kWaypoint) {
    os << "needs a 'start' line (its plan does not begin with a waypoint)";
  } else if (kind == RobotKind::kHumanoid && motion.max_speed_mps > 0.15 + 1e-12) {
    os << "a humanoid walks at most 0.15 m/s, got speed " << motion.max_speed_mps;
  } else if (kind == RobotKind::kUav && !(altitude_meters >= 0.2 && altitude_meters <= 10.0)) {
    os << "UAV altitude must be in [0.2, 10] m, got " << altitude_meters;
  } else if (!body_T_laser.matrix().allFinite()) {
    os << "laser mount must be finite";
  } else if (!(head_joint_height_meters > 0.0 && head_joint_height_meters < 5.0)) {
    os << "head joint height must be in (0, 5) m, got " << head_joint_height_meters;
  }
  if (os.str().empty()) {
    for (const HeadPhase& phase : head_profile) {
      if (!(phase.duration_seconds > 0.0 && std::isfinite(phase.duration_seconds))) {
        os << "head phase durations must be positive";
        break;
      }
      if (phase.type == HeadPhase::Type::kSweep && !(phase.period_seconds > 0.0)) {
        os << "head sweep period must be positive";
        break;
      }
    }
  }
  if (os.str().empty()) return true;
  if (error != nullptr) *error = "robot '" + name + "' " + os.str();
  return false;
}

}  // namespace sim
}  // namespace hetslam
