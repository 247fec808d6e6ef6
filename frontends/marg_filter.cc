#include "frontends/marg_filter.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/euler.h"
#include "core/se2.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

bool AllFinite(const Eigen::Vector3d& v) { return v.allFinite(); }

// Rotation by the rotation vector w (exponential map of SO(3)) as a unit quaternion.
Eigen::Quaterniond QuaternionExp(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-12) {
    // First-order; normalised by the caller.
    return Eigen::Quaterniond(1.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z());
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
}

}  // namespace

bool MargFilterOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(proportional_gain_per_second > 0.0)) {
    why << "proportional_gain_per_second must be > 0, got " << proportional_gain_per_second;
  } else if (!(integral_gain_per_second_squared >= 0.0)) {
    why << "integral_gain_per_second_squared must be >= 0, got "
        << integral_gain_per_second_squared;
  } else if (!(magnetometer_weight >= 0.0)) {
    why << "magnetometer_weight must be >= 0, got " << magnetometer_weight;
  } else if (!(gravity_mps2 > 0.0)) {
    why << "gravity_mps2 must be > 0, got " << gravity_mps2;
  } else if (!(accelerometer_gate_mps2 > 0.0)) {
    why << "accelerometer_gate_mps2 must be > 0, got " << accelerometer_gate_mps2;
  } else if (!(max_gyro_bias_radps > 0.0)) {
    why << "max_gyro_bias_radps must be > 0, got " << max_gyro_bias_radps;
  } else if (!(max_sample_gap_seconds > 0.0)) {
    why << "max_sample_gap_seconds must be > 0, got " << max_sample_gap_seconds;
  } else if (!(roll_pitch_stddev_radians > 0.0) || !(heading_stddev_radians > 0.0) ||
             !(rate_stddev_radps > 0.0)) {
    why << "roll_pitch_stddev_radians, heading_stddev_radians and rate_stddev_radps must be "
           "> 0, got "
        << roll_pitch_stddev_radians << ", " << heading_stddev_radians << ", "
        << rate_stddev_radps;
  }
  const std::string message = why.str();
  if (error != nullptr) *error = message;
  return message.empty();
}

Eigen::Vector3d EulerRatesFromBodyRate(double roll_radians, double pitch_radians,
                                       const Eigen::Vector3d& body_rate_radps) {
  const double cos_pitch = std::cos(pitch_radians);
  CHECK_GT(std::abs(cos_pitch), 1e-6) << "pitch " << pitch_radians
                                      << " rad is at the Z-Y-X Euler singularity";
  const double p = body_rate_radps.x(), q = body_rate_radps.y(), r = body_rate_radps.z();
  const double s_roll = std::sin(roll_radians), c_roll = std::cos(roll_radians);
  const double q_s_r_c = q * s_roll + r * c_roll;
  return Eigen::Vector3d(p + q_s_r_c * std::tan(pitch_radians), q * c_roll - r * s_roll,
                         q_s_r_c / cos_pitch);
}

MargFilter::MargFilter(const MargFilterOptions& options) : options_(options) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid MargFilterOptions: " << error;
}

void MargFilter::Reset() {
  initialized_ = false;
  world_R_body_ = Eigen::Quaterniond::Identity();
  gyro_bias_radps_.setZero();
}

MargAttitude MargFilter::MakeOutput(double stamp_seconds, const Eigen::Vector3d& gyro_radps) const {
  MargAttitude out;
  out.stamp_seconds = stamp_seconds;
  out.world_R_body = world_R_body_;
  const Eigen::Vector3d rph = RollPitchYawFromRotation(world_R_body_.toRotationMatrix());
  out.roll_radians = rph.x();
  out.pitch_radians = rph.y();
  out.heading_radians = WrapAngle(rph.z());
  out.gyro_bias_radps = gyro_bias_radps_;
  out.body_rate_radps = gyro_radps - gyro_bias_radps_;
  out.euler_rates_radps = EulerRatesFromBodyRate(rph.x(), rph.y(), out.body_rate_radps);
  out.roll_pitch_stddev_radians = options_.roll_pitch_stddev_radians;
  out.heading_stddev_radians = options_.heading_stddev_radians;
  out.rate_stddev_radps = options_.rate_stddev_radps;
  return out;
}

Status MargFilter::Add(const MargSample& sample, MargAttitude* attitude) {
  CHECK(attitude != nullptr);
  if (!std::isfinite(sample.stamp_seconds) || !AllFinite(sample.gyro_radps) ||
      !AllFinite(sample.accel_mps2) ||
      (sample.has_magnetometer && !AllFinite(sample.magnetometer))) {
    std::ostringstream message;
    message << "MARG sample at t=" << sample.stamp_seconds << " has non-finite values";
    return Status::Error(message.str());
  }
  const double accel_norm = sample.accel_mps2.norm();

  if (!initialized_) {
    if (accel_norm < 1e-6) {
      std::ostringstream message;
      message << "MARG sample at t=" << sample.stamp_seconds
              << ": cannot initialise attitude from a zero accelerometer reading";
      return Status::Error(message.str());
    }
    // Tilt from gravity: a = R^T (0,0,g) = g (-sin θ, sin ψ cos θ, cos ψ cos θ).
    const Eigen::Vector3d a = sample.accel_mps2 / accel_norm;
    const double roll = std::atan2(a.y(), a.z());
    const double pitch = std::atan2(-a.x(), std::hypot(a.y(), a.z()));
    double heading = 0.0;
    if (sample.has_magnetometer && sample.magnetometer.norm() > 0.0) {
      // Tilt-compensate: rotate the body reading by R_y(θ) R_x(ψ) into the level frame,
      // where it is R_z(φ)^T m_world with m_world along +x (plus z).
      const Eigen::Matrix3d level_R_body = RotationFromRollPitchYaw(roll, pitch, 0.0);
      const Eigen::Vector3d m_level = level_R_body * sample.magnetometer;
      heading = std::atan2(-m_level.y(), m_level.x());
    }
    world_R_body_ = Eigen::Quaterniond(RotationFromRollPitchYaw(roll, pitch, heading));
    gyro_bias_radps_.setZero();
    last_stamp_seconds_ = sample.stamp_seconds;
    initialized_ = true;
    *attitude = MakeOutput(sample.stamp_seconds, sample.gyro_radps);
    return Status::Ok();
  }

  const double dt = sample.stamp_seconds - last_stamp_seconds_;
  if (!(dt > 0.0) || dt > options_.max_sample_gap_seconds) {
    std::ostringstream message;
    message << "MARG sample at t=" << sample.stamp_seconds << " follows the previous one at t="
            << last_stamp_seconds_ << " (dt=" << dt << " s, must be in (0, "
            << options_.max_sample_gap_seconds << "]); call Reset() after a gap";
    return Status::Error(message.str());
  }

  // Predict with the bias-corrected gyro over (t_prev, t], then correct with the vectors
  // measured at t. Correcting the prior attitude (of t_prev) with vectors of t instead would
  // lag by one sample: a tilt error of k_P dt times the rotation per sample.
  world_R_body_ = (world_R_body_ * QuaternionExp((sample.gyro_radps - gyro_bias_radps_) * dt))
                      .normalized();
  const Eigen::Matrix3d R = world_R_body_.toRotationMatrix();
  Eigen::Vector3d correction = Eigen::Vector3d::Zero();
  // Gravity: measured up direction a versus predicted v̂ = R^T e_z; a × v̂ rotates v̂ toward a.
  if (std::abs(accel_norm - options_.gravity_mps2) <= options_.accelerometer_gate_mps2) {
    const Eigen::Vector3d a = sample.accel_mps2 / accel_norm;
    const Eigen::Vector3d up_predicted = R.transpose().col(2);
    correction += a.cross(up_predicted);
  }
  // Heading: the measured field in the world, projected on the horizontal plane, should lie
  // along +x; the world-frame correction (0, 0, -m_h,y) turns it there about z only.
  if (sample.has_magnetometer && options_.magnetometer_weight > 0.0) {
    const Eigen::Vector3d m_world = R * sample.magnetometer;
    const double horizontal_norm = std::hypot(m_world.x(), m_world.y());
    if (horizontal_norm > 1e-9 * (sample.magnetometer.norm() + 1e-300)) {
      const double sin_error = m_world.y() / horizontal_norm;
      correction += options_.magnetometer_weight *
                    (R.transpose() * Eigen::Vector3d(0.0, 0.0, -sin_error));
    }
  }
  world_R_body_ =
      (world_R_body_ * QuaternionExp(options_.proportional_gain_per_second * correction * dt))
          .normalized();
  gyro_bias_radps_ -= options_.integral_gain_per_second_squared * correction * dt;
  for (int i = 0; i < 3; ++i) {
    gyro_bias_radps_[i] = std::clamp(gyro_bias_radps_[i], -options_.max_gyro_bias_radps,
                                     options_.max_gyro_bias_radps);
  }
  last_stamp_seconds_ = sample.stamp_seconds;
  *attitude = MakeOutput(sample.stamp_seconds, sample.gyro_radps);
  return Status::Ok();
}

}  // namespace hetslam
