// MARG attitude filter: raw gyro, accelerometer and magnetometer samples to roll, pitch,
// heading and gyro bias, for logs that carry raw MARG data rather than attitude.
//
// Choice: a Mahony explicit complementary filter on SO(3) with a bias integral
// (Mahony, Hamel, Pflimlin 2008, "Nonlinear complementary filters on the special orthogonal
// group"). Why this one rather than Madgwick or an error-state EKF:
//  - its proportional-integral correction estimates the gyro bias explicitly (Madgwick's basic
//    form does not), which is what makes tilt hold below half a degree with MEMS gyros;
//  - two gains with a physical reading (k_P: crossover frequency in rad/s between gyro and
//    accelerometer; k_I: bias-tracking bandwidth squared), no covariance tuning, no matrix
//    algebra: cheap at 100 Hz+ and deterministic;
//  - its stability is proven on SO(3) for any initial attitude;
//  - the state EKF downstream (ekf_state_updater.h) already carries the uncertainty model, so an
//    attitude covariance here would be double bookkeeping; the filter reports a configured
//    standard deviation instead.
// Pitfall of every gyro + accelerometer filter: a sustained horizontal acceleration a looks like
// a tilt of a/g; the crossover k_P sets how much of it leaks in (defaults k_P = 0.5 /s,
// k_I = 0.05 /s²: 0.2° RMS tilt error in the test's start/stop manoeuvres at 0.2 m/s²,
// bias settled in ~20 s). Lower k_P rejects longer manoeuvres but tracks the gyro bias
// transient more slowly.
// The magnetometer correction is restricted to rotations about the world z axis, so magnetic
// disturbances (common indoors) can bias the heading but never roll or pitch.
//
// Frames and conventions:
//  - world: z up, x along the horizontal component of the magnetic field (heading 0 when the
//    body x axis points to magnetic north), y = z × x. A caller whose map frame differs adds its
//    own heading offset.
//  - body: x forward, y left, z up. `world_R_body` maps body vectors into the world.
//  - Euler angles, Z-Y-X: world_R_body = R_z(heading) R_y(pitch) R_x(roll) (core/euler.h, where
//    heading is called yaw); the same symbols as the EKF (ψ roll, θ pitch, φ heading). Pitch is
//    positive nose down (right-handed about y).
//  - Gyro: body angular rate in rad/s, sample = ω + b + noise, b the bias this filter estimates.
//  - Accelerometer: specific force in m/s² in the body frame; at rest it reads
//    world_R_body^T (0, 0, +g).
//  - Magnetometer: any unit (only its direction is used), body frame, hard/soft iron already
//    calibrated.
//
// Update per sample of period dt: predict with the gyro, then correct with the vectors
// measured at the same time (v̂_a = R̂⁻^T e_z the predicted "up" in the body, a the normalised
// accelerometer, m_h the horizontal part of R̂⁻ m, normalised):
//   R̂⁻    = R̂ Exp((ω_gyro - b̂) dt)
//   e      = a × v̂_a + w_m R̂⁻^T (0, 0, -m_h,y)        (correction, rad/s per unit gain)
//   R̂     ← R̂⁻ Exp(k_P e dt),   b̂ ← b̂ - k_I e dt
// (Correcting the previous attitude with the new vectors, as a single-step form does, lags
// by one sample: a tilt error of k_P dt times the rotation per sample.)
// The accelerometer term is skipped while | |a| - g | exceeds a gate (strong linear acceleration)
// and the magnetometer term when the sample has no magnetometer reading.
#ifndef HETSLAM_FRONTENDS_MARG_FILTER_H_
#define HETSLAM_FRONTENDS_MARG_FILTER_H_

#include <string>

#include "Eigen/Core"
#include "Eigen/Geometry"
#include "core/measurement.h"
#include "core/status.h"

namespace hetslam {

struct MargFilterOptions {
  // k_P: crossover between gyro integration and the vector corrections, rad/s (1/s).
  double proportional_gain_per_second = 0.5;
  // k_I: bias integral gain, 1/s². 0 disables bias estimation.
  double integral_gain_per_second_squared = 0.05;
  // Relative weight w_m of the magnetometer heading correction (1 = as strong as gravity).
  double magnetometer_weight = 1.0;
  double gravity_mps2 = 9.80665;
  // The accelerometer correction is skipped while | |a| - g | exceeds this (m/s²).
  double accelerometer_gate_mps2 = 1.5;
  // |b̂| is clamped per axis to this (rad/s): a real MEMS bias is a few deg/s at most.
  double max_gyro_bias_radps = 0.2;
  // A gap between samples longer than this is an error (no blind integration over it).
  double max_sample_gap_seconds = 0.2;
  // One-sigma attitude and rate uncertainty reported with every output (for the state EKF).
  double roll_pitch_stddev_radians = 0.01;
  double heading_stddev_radians = 0.05;
  double rate_stddev_radps = 0.01;

  bool IsValid(std::string* error) const;
};

struct MargAttitude {
  double stamp_seconds = 0.0;
  Eigen::Quaterniond world_R_body = Eigen::Quaterniond::Identity();
  double roll_radians = 0.0;     // ψ
  double pitch_radians = 0.0;    // θ
  double heading_radians = 0.0;  // φ, wrapped to [-pi, pi)
  Eigen::Vector3d gyro_bias_radps = Eigen::Vector3d::Zero();  // b̂, body frame
  Eigen::Vector3d body_rate_radps = Eigen::Vector3d::Zero();  // ω_gyro - b̂, body frame
  Eigen::Vector3d euler_rates_radps = Eigen::Vector3d::Zero();  // (ψ̇, θ̇, φ̇)
  // Reported one-sigma values from the options.
  double roll_pitch_stddev_radians = 0.0;
  double heading_stddev_radians = 0.0;
  double rate_stddev_radps = 0.0;
};

// Z-Y-X Euler angle rates (ψ̇, θ̇, φ̇) from the body angular rate ω = (p, q, r):
//   ψ̇ = p + (q sin ψ + r cos ψ) tan θ,  θ̇ = q cos ψ - r sin ψ,  φ̇ = (q sin ψ + r cos ψ) / cos θ.
// Singular at |θ| = pi/2 (CHECKed away from it).
Eigen::Vector3d EulerRatesFromBodyRate(double roll_radians, double pitch_radians,
                                       const Eigen::Vector3d& body_rate_radps);

class MargFilter {
 public:
  // CHECK-fails on invalid options (validate user input with IsValid first).
  explicit MargFilter(const MargFilterOptions& options);

  // Processes one sample. The first valid sample initialises the attitude from the
  // accelerometer (roll, pitch) and magnetometer (heading; 0 without one), bias zero.
  // Errors (state unchanged): non-finite values, a zero accelerometer on the first sample,
  // a stamp not after the previous one, a gap longer than max_sample_gap_seconds.
  Status Add(const MargSample& sample, MargAttitude* attitude);

  bool initialized() const { return initialized_; }
  // Restarts from the next sample (e.g. after a gap).
  void Reset();

 private:
  MargAttitude MakeOutput(double stamp_seconds, const Eigen::Vector3d& gyro_radps) const;

  MargFilterOptions options_;
  bool initialized_ = false;
  double last_stamp_seconds_ = 0.0;
  Eigen::Quaterniond world_R_body_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d gyro_bias_radps_ = Eigen::Vector3d::Zero();
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_MARG_FILTER_H_
