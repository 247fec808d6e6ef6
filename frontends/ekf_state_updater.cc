#include "frontends/ekf_state_updater.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "Eigen/Cholesky"
#include "glog/logging.h"

namespace hetslam {
namespace {

// Rows of the MARG measurement vector (ψ θ φ ψ̇ θ̇ φ̇) in the state.
constexpr int kMargStateRows[6] = {kRoll, kPitch, kYaw, kRollRate, kPitchRate, kYawRate};

bool IsAngleRow(int state_index) {
  return state_index == kRoll || state_index == kPitch || state_index == kYaw;
}

// A measurement covariance must be finite, symmetric and positive semi-definite; the
// innovation covariance S = H P Hᵀ + R is then positive definite whenever P is.
template <int M>
Status CheckCovariance(const Eigen::Matrix<double, M, M>& covariance, const char* what,
                       double stamp_seconds) {
  std::ostringstream message;
  if (!covariance.allFinite()) {
    message << what << " at t=" << stamp_seconds << " has a non-finite covariance";
    return Status::Error(message.str());
  }
  const double scale = std::max(1.0, covariance.cwiseAbs().maxCoeff());
  if (!covariance.isApprox(covariance.transpose(), 1e-9) &&
      (covariance - covariance.transpose()).cwiseAbs().maxCoeff() > 1e-12 * scale) {
    message << what << " at t=" << stamp_seconds << " has a non-symmetric covariance";
    return Status::Error(message.str());
  }
  // Pivoted LDLᵀ is cheap at these sizes (an eigen-decomposition would cost more than the
  // filter update) and exposes a negative or all-zero diagonal.
  const Eigen::LDLT<Eigen::Matrix<double, M, M>> ldlt(covariance);
  const auto d = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || d.minCoeff() < -1e-12 * scale || d.maxCoeff() <= 0.0) {
    message << what << " at t=" << stamp_seconds
            << " has a covariance that is not positive semi-definite (LDLT pivots "
            << d.transpose() << ")";
    return Status::Error(message.str());
  }
  return Status::Ok();
}

void WrapAngles(EkfVector* state) {
  for (int i : {kRoll, kPitch, kYaw}) (*state)[i] = WrapAngle((*state)[i]);
}

// One EKF update with an M-row linear measurement z = H X (all our measurement functions
// select state components). `rows[i]` is the state index measured by row i.
template <int M>
void UpdateSelected(const Eigen::Matrix<double, M, 1>& z, const int* rows,
                    const Eigen::Matrix<double, M, M>& R, StateEstimate* estimate) {
  EkfVector& X = estimate->state;
  EkfMatrix& P = estimate->covariance;
  Eigen::Matrix<double, M, 1> nu;  // ν = z - H X, angle rows wrapped
  for (int i = 0; i < M; ++i) {
    nu[i] = z[i] - X[rows[i]];
    if (IsAngleRow(rows[i])) nu[i] = WrapAngle(nu[i]);
  }
  // P Hᵀ and H P Hᵀ pick columns/rows of P: no multiplication by the sparse H.
  Eigen::Matrix<double, kEkfStateSize, M> PHt;
  for (int i = 0; i < M; ++i) PHt.col(i) = P.col(rows[i]);
  Eigen::Matrix<double, M, M> S = R;
  for (int i = 0; i < M; ++i) {
    for (int j = 0; j < M; ++j) S(i, j) += P(rows[i], rows[j]);
  }
  const Eigen::LLT<Eigen::Matrix<double, M, M>> llt(S);
  CHECK(llt.info() == Eigen::Success) << "innovation covariance not positive definite:\n" << S;
  // K = P Hᵀ S⁻¹, computed as (S⁻¹ H P)ᵀ since S is symmetric.
  const Eigen::Matrix<double, kEkfStateSize, M> K = llt.solve(PHt.transpose()).transpose();
  X += K * nu;
  WrapAngles(&X);
  // Joseph form P = (I - K H) P (I - K H)ᵀ + K R Kᵀ, using the selection structure of H:
  // A = P - K (H P), then A (I - K H)ᵀ = A - (A Hᵀ) Kᵀ. 12×M×12 work instead of 12³.
  Eigen::Matrix<double, M, kEkfStateSize> HP;
  for (int i = 0; i < M; ++i) HP.row(i) = P.row(rows[i]);
  // lazyProduct: coefficient-wise products; Eigen's blocked GEMM path costs more than the
  // arithmetic at 12×6×12.
  const EkfMatrix A = P - K.lazyProduct(HP);
  Eigen::Matrix<double, kEkfStateSize, M> AHt;
  for (int i = 0; i < M; ++i) AHt.col(i) = A.col(rows[i]);
  const Eigen::Matrix<double, kEkfStateSize, M> KR = K.lazyProduct(R);
  P = A - AHt.lazyProduct(K.transpose()) + KR.lazyProduct(K.transpose());
  P = 0.5 * (P + P.transpose()).eval();
}

// White-acceleration noise of a (position, rate) pair over dt with spectral density q.
void AddConstantVelocityNoise(int p, int v, double q, double dt, EkfMatrix* Q) {
  const double dt2 = dt * dt;
  (*Q)(p, p) += q * dt2 * dt / 3.0;
  (*Q)(p, v) += q * dt2 / 2.0;
  (*Q)(v, p) += q * dt2 / 2.0;
  (*Q)(v, v) += q * dt;
}

std::string PositiveMessage(const char* name, double value) {
  std::ostringstream why;
  why << name << " must be > 0, got " << value;
  return why.str();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Options.

bool ScanVelocityOptions::IsValid(std::string* error) const {
  std::string message;
  if (!(window_seconds > 0.0)) {
    message = PositiveMessage("scan_velocity.window_seconds", window_seconds);
  } else if (min_poses < 2) {
    message = "scan_velocity.min_poses must be >= 2, got " + std::to_string(min_poses);
  } else if (!(min_span_seconds > 0.0) || !(min_span_seconds <= window_seconds)) {
    std::ostringstream why;
    why << "scan_velocity.min_span_seconds must be in (0, window_seconds=" << window_seconds
        << "], got " << min_span_seconds;
    message = why.str();
  } else if (!(smoothing_stddev_mps >= 0.0)) {
    std::ostringstream why;
    why << "scan_velocity.smoothing_stddev_mps must be >= 0, got " << smoothing_stddev_mps;
    message = why.str();
  }
  if (error != nullptr) *error = message;
  return message.empty();
}

bool EkfStateUpdaterOptions::IsValid(std::string* error) const {
  std::string message;
  const std::pair<const char*, double> positives[] = {
      {"history_window_seconds", history_window_seconds},
      {"output_period_seconds", output_period_seconds},
      {"horizontal_acceleration_noise_mps2_per_sqrt_hz",
       horizontal_acceleration_noise_mps2_per_sqrt_hz},
      {"vertical_acceleration_noise_mps2_per_sqrt_hz", vertical_acceleration_noise_mps2_per_sqrt_hz},
      {"tilt_acceleration_noise_radps2_per_sqrt_hz", tilt_acceleration_noise_radps2_per_sqrt_hz},
      {"yaw_acceleration_noise_radps2_per_sqrt_hz", yaw_acceleration_noise_radps2_per_sqrt_hz},
      {"command_position_noise_meters_per_sqrt_second",
       command_position_noise_meters_per_sqrt_second},
      {"command_yaw_noise_radians_per_sqrt_second", command_yaw_noise_radians_per_sqrt_second},
      {"command_velocity_noise_mps_per_sqrt_second", command_velocity_noise_mps_per_sqrt_second},
      {"command_yaw_rate_noise_radps_per_sqrt_second",
       command_yaw_rate_noise_radps_per_sqrt_second},
      {"command_timeout_seconds", command_timeout_seconds},
  };
  for (const auto& [name, value] : positives) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      message = PositiveMessage(name, value);
      break;
    }
  }
  if (message.empty() && !(command_response_seconds >= 0.0 && command_response_seconds <= 60.0)) {
    std::ostringstream why;
    why << "command_response_seconds must be in [0, 60], got " << command_response_seconds;
    message = why.str();
  }
  if (message.empty() && max_logged_rejections < 0) {
    message = "max_logged_rejections must be >= 0, got " + std::to_string(max_logged_rejections);
  }
  if (message.empty() && use_scan_velocity) scan_velocity.IsValid(&message);
  if (error != nullptr) *error = message;
  return message.empty();
}

bool HumanoidHeadOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(neck_height_meters > 0.0) || !std::isfinite(neck_height_meters)) {
    why << "neck_height_meters must be > 0, got " << neck_height_meters;
  } else if (!std::isfinite(neck_to_laser_forward_meters) ||
             !std::isfinite(neck_to_laser_up_meters)) {
    why << "neck_to_laser_forward_meters and neck_to_laser_up_meters must be finite, got "
        << neck_to_laser_forward_meters << ", " << neck_to_laser_up_meters;
  }
  const std::string message = why.str();
  if (error != nullptr) *error = message;
  return message.empty();
}

double LaserHeightFromHeadPitch(const HumanoidHeadOptions& options, double head_pitch_radians,
                                double body_pitch_radians) {
  // The laser position (f, 0, u) in the head frame, rotated by R_y(θ + β):
  // its z component is -f sin(θ + β) + u cos(θ + β).
  const double tilt = body_pitch_radians + head_pitch_radians;
  return options.neck_height_meters + options.neck_to_laser_up_meters * std::cos(tilt) -
         options.neck_to_laser_forward_meters * std::sin(tilt);
}

Eigen::Matrix3d StateEstimate::pose_covariance() const {
  const int rows[3] = {kX, kY, kYaw};
  Eigen::Matrix3d out;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out(i, j) = covariance(rows[i], rows[j]);
  }
  return out;
}

MargMeasurement MargMeasurementFromAttitude(const MargAttitude& attitude, bool use_heading,
                                            double heading_offset_radians) {
  MargMeasurement m;
  m.stamp_seconds = attitude.stamp_seconds;
  m.roll_radians = attitude.roll_radians;
  m.pitch_radians = attitude.pitch_radians;
  m.heading_radians = WrapAngle(attitude.heading_radians + heading_offset_radians);
  m.euler_rates_radps = attitude.euler_rates_radps;
  m.has_heading = use_heading;
  m.covariance.setZero();
  const double tilt_var = attitude.roll_pitch_stddev_radians * attitude.roll_pitch_stddev_radians;
  const double rate_var = attitude.rate_stddev_radps * attitude.rate_stddev_radps;
  m.covariance.diagonal() << tilt_var, tilt_var,
      attitude.heading_stddev_radians * attitude.heading_stddev_radians, rate_var, rate_var,
      rate_var;
  return m;
}

// ---------------------------------------------------------------------------------------------
// ScanVelocityEstimator.

ScanVelocityEstimator::ScanVelocityEstimator(const ScanVelocityOptions& options)
    : options_(options) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid ScanVelocityOptions: " << error;
}

void ScanVelocityEstimator::AddPose(double stamp_seconds, const Eigen::Vector2d& position_meters,
                                    const Eigen::Matrix2d& position_covariance) {
  // Late poses go in place; equal stamps keep arrival order.
  auto it = std::upper_bound(
      poses_.begin(), poses_.end(), stamp_seconds,
      [](double t, const StampedPosition& p) { return t < p.stamp_seconds; });
  poses_.insert(it, StampedPosition{stamp_seconds, position_meters, position_covariance});
}

bool ScanVelocityEstimator::VelocityAt(double stamp_seconds,
                                       VelocityObservation* observation) const {
  CHECK(observation != nullptr);
  const double t_begin = stamp_seconds - options_.window_seconds;
  auto first = std::lower_bound(
      poses_.begin(), poses_.end(), t_begin,
      [](const StampedPosition& p, double t) { return p.stamp_seconds < t; });
  auto last = std::upper_bound(
      poses_.begin(), poses_.end(), stamp_seconds,
      [](double t, const StampedPosition& p) { return t < p.stamp_seconds; });
  const int n = static_cast<int>(last - first);
  if (n < options_.min_poses) return false;
  if ((last - 1)->stamp_seconds - first->stamp_seconds < options_.min_span_seconds) return false;

  double t_mean = 0.0;
  for (auto it = first; it != last; ++it) t_mean += it->stamp_seconds;
  t_mean /= n;
  double sum_dt2 = 0.0;
  for (auto it = first; it != last; ++it) {
    const double dt = it->stamp_seconds - t_mean;
    sum_dt2 += dt * dt;
  }
  // Slope = Σ w_i p_i with w_i = (t_i - t̄) / Σ (t_j - t̄)² (Σ w_i = 0, so p̄ drops out).
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  for (auto it = first; it != last; ++it) {
    const double w = (it->stamp_seconds - t_mean) / sum_dt2;
    velocity += w * it->position_meters;
    covariance += w * w * it->covariance;
  }
  covariance +=
      options_.smoothing_stddev_mps * options_.smoothing_stddev_mps * Eigen::Matrix2d::Identity();
  observation->stamp_seconds = stamp_seconds;
  observation->velocity_mps = velocity;
  observation->covariance = covariance;
  return true;
}

void ScanVelocityEstimator::DropBefore(double stamp_seconds) {
  while (!poses_.empty() && poses_.front().stamp_seconds < stamp_seconds) poses_.pop_front();
}

// ---------------------------------------------------------------------------------------------
// EkfStateUpdater.

EkfStateUpdater::EkfStateUpdater(const EkfStateUpdaterOptions& options)
    : options_(options), scan_velocity_(options.scan_velocity) {
  std::string error;
  CHECK(options_.IsValid(&error)) << "invalid EkfStateUpdaterOptions: " << error;
}

void EkfStateUpdater::Initialize(const StateEstimate& initial) {
  CHECK(initial.state.allFinite() && initial.covariance.allFinite())
      << "initial state or covariance is not finite";
  base_ = FilterState();
  base_.estimate = initial;
  WrapAngles(&base_.estimate.state);
  base_stamp_seconds_ = initial.stamp_seconds;
  base_kind_ = -1;
  events_.clear();
  latest_ = base_.estimate;
  scan_velocity_ = ScanVelocityEstimator(options_.scan_velocity);
  last_output_stamp_seconds_ = initial.stamp_seconds;
  num_rejected_too_old_ = 0;
  num_out_of_sequence_ = 0;
  num_replayed_ = 0;
  initialized_ = true;
}

void EkfStateUpdater::PredictConstantVelocity(double dt, StateEstimate* estimate) const {
  EkfVector& X = estimate->state;
  EkfMatrix& P = estimate->covariance;
  // F = I with δt in the (position, rate) blocks; applied as sparse row/column operations.
  const int pairs[6][2] = {{kX, kVx},   {kY, kVy},     {kZ, kVz},
                           {kRoll, kRollRate}, {kPitch, kPitchRate}, {kYaw, kYawRate}};
  for (const auto& pair : pairs) X[pair[0]] += dt * X[pair[1]];
  // P = F P Fᵀ: rows then columns.
  for (const auto& pair : pairs) P.row(pair[0]) += dt * P.row(pair[1]);
  for (const auto& pair : pairs) P.col(pair[0]) += dt * P.col(pair[1]);
  EkfMatrix& Q = P;  // the noise is added in place
  const double q_xy = std::pow(options_.horizontal_acceleration_noise_mps2_per_sqrt_hz, 2);
  const double q_z = std::pow(options_.vertical_acceleration_noise_mps2_per_sqrt_hz, 2);
  const double q_tilt = std::pow(options_.tilt_acceleration_noise_radps2_per_sqrt_hz, 2);
  const double q_yaw = std::pow(options_.yaw_acceleration_noise_radps2_per_sqrt_hz, 2);
  AddConstantVelocityNoise(kX, kVx, q_xy, dt, &Q);
  AddConstantVelocityNoise(kY, kVy, q_xy, dt, &Q);
  AddConstantVelocityNoise(kZ, kVz, q_z, dt, &Q);
  AddConstantVelocityNoise(kRoll, kRollRate, q_tilt, dt, &Q);
  AddConstantVelocityNoise(kPitch, kPitchRate, q_tilt, dt, &Q);
  AddConstantVelocityNoise(kYaw, kYawRate, q_yaw, dt, &Q);
  WrapAngles(&X);
}

void EkfStateUpdater::PredictWithCommand(double dt, const VelocityCommand& command,
                                         StateEstimate* estimate) const {
  EkfVector& X = estimate->state;
  EkfMatrix& P = estimate->covariance;
  const double v_x = command.forward_mps, v_y = command.left_mps;
  const double phi = X[kYaw];
  const double c = std::cos(phi), s = std::sin(phi);
  const int cv_pairs[3][2] = {{kZ, kVz}, {kRoll, kRollRate}, {kPitch, kPitchRate}};
  const double tau = options_.command_response_seconds;
  if (tau > 0.0) {
    // The velocity follows the command with a first-order lag (see the option): with the
    // commanded world velocity v = R(φ) (v_x, v_y), a = e^(-δt/τ) and b = τ (1 - a),
    //   x += δt v + b (ẋ - v),  ẋ = v + a (ẋ - v).
    const double a = std::exp(-dt / tau), b = tau * (1.0 - a);
    const Eigen::Vector2d v(c * v_x - s * v_y, s * v_x + c * v_y);
    const Eigen::Vector2d dv_dphi(-s * v_x - c * v_y, c * v_x - s * v_y);
    const Eigen::Vector2d lag(X[kVx] - v.x(), X[kVy] - v.y());
    X[kX] += dt * v.x() + b * lag.x();
    X[kY] += dt * v.y() + b * lag.y();
    X[kVx] = v.x() + a * lag.x();
    X[kVy] = v.y() + a * lag.y();
    X[kYaw] += dt * command.yaw_rate_radps;
    for (const auto& pair : cv_pairs) X[pair[0]] += dt * X[pair[1]];
    // A dense F P Fᵀ (12 x 12: ~1 µs a prediction; uav_flight's real-time factor is the same
    // with sparse row/column operations, whose different rounding moved team_three seed 5's
    // merged-map precision 0.937 -> 0.884: the dense product keeps the measured figures).
    EkfMatrix F = EkfMatrix::Identity();
    F(kX, kVx) = b;
    F(kY, kVy) = b;
    F(kVx, kVx) = a;
    F(kVy, kVy) = a;
    F(kX, kYaw) = (dt - b) * dv_dphi.x();
    F(kY, kYaw) = (dt - b) * dv_dphi.y();
    F(kVx, kYaw) = (1.0 - a) * dv_dphi.x();
    F(kVy, kYaw) = (1.0 - a) * dv_dphi.y();
    for (const auto& pair : cv_pairs) F(pair[0], pair[1]) = dt;
    P = F * P * F.transpose();
  } else {
    // Paper eq. 3 for x, y (ẋ, ẏ are random walks), φ driven by the commanded yaw rate; z, ψ,
    // θ keep the constant-velocity model.
    X[kX] += dt * (c * v_x - s * v_y);
    X[kY] += dt * (s * v_x + c * v_y);
    X[kYaw] += dt * command.yaw_rate_radps;
    for (const auto& pair : cv_pairs) X[pair[0]] += dt * X[pair[1]];

    // F: identity plus ∂x/∂φ, ∂y/∂φ and the constant-velocity couplings.
    const double dx_dphi = dt * (-s * v_x - c * v_y);
    const double dy_dphi = dt * (c * v_x - s * v_y);
    P.row(kX) += dx_dphi * P.row(kYaw);
    P.row(kY) += dy_dphi * P.row(kYaw);
    for (const auto& pair : cv_pairs) P.row(pair[0]) += dt * P.row(pair[1]);
    P.col(kX) += dx_dphi * P.col(kYaw);
    P.col(kY) += dy_dphi * P.col(kYaw);
    for (const auto& pair : cv_pairs) P.col(pair[0]) += dt * P.col(pair[1]);
  }

  EkfMatrix& Q = P;  // the noise is added in place
  const double q_pos = std::pow(options_.command_position_noise_meters_per_sqrt_second, 2);
  const double q_vel = std::pow(options_.command_velocity_noise_mps_per_sqrt_second, 2);
  Q(kX, kX) += q_pos * dt;
  Q(kY, kY) += q_pos * dt;
  Q(kVx, kVx) += q_vel * dt;
  Q(kVy, kVy) += q_vel * dt;
  Q(kYaw, kYaw) += std::pow(options_.command_yaw_noise_radians_per_sqrt_second, 2) * dt;
  Q(kYawRate, kYawRate) +=
      std::pow(options_.command_yaw_rate_noise_radps_per_sqrt_second, 2) * dt;
  AddConstantVelocityNoise(kZ, kVz,
                           std::pow(options_.vertical_acceleration_noise_mps2_per_sqrt_hz, 2),
                           dt, &Q);
  const double q_tilt = std::pow(options_.tilt_acceleration_noise_radps2_per_sqrt_hz, 2);
  AddConstantVelocityNoise(kRoll, kRollRate, q_tilt, dt, &Q);
  AddConstantVelocityNoise(kPitch, kPitchRate, q_tilt, dt, &Q);
  WrapAngles(&X);
}

void EkfStateUpdater::Predict(double stamp_seconds, FilterState* filter) const {
  StateEstimate& estimate = filter->estimate;
  CHECK_GE(stamp_seconds, estimate.stamp_seconds) << "prediction backwards in time";
  double t = estimate.stamp_seconds;
  // A command drives [command stamp, + timeout]; the remainder is constant velocity. Splitting
  // at the expiry keeps the result a function of the stamps only.
  if (filter->has_command) {
    const double t_expiry = filter->command.stamp_seconds + options_.command_timeout_seconds;
    const double t_end = std::min(stamp_seconds, t_expiry);
    if (t_end > t) {
      PredictWithCommand(t_end - t, filter->command, &estimate);
      t = t_end;
    }
  }
  if (stamp_seconds > t) PredictConstantVelocity(stamp_seconds - t, &estimate);
  estimate.stamp_seconds = stamp_seconds;
}

void EkfStateUpdater::Apply(const Measurement& measurement, double stamp_seconds,
                            FilterState* filter) const {
  Predict(stamp_seconds, filter);
  StateEstimate* estimate = &filter->estimate;
  if (const auto* command = std::get_if<VelocityCommand>(&measurement)) {
    filter->has_command = true;
    filter->command = *command;
  } else if (const auto* marg = std::get_if<MargMeasurement>(&measurement)) {
    const Eigen::Matrix<double, 6, 1> z =
        (Eigen::Matrix<double, 6, 1>() << marg->roll_radians, marg->pitch_radians,
         marg->heading_radians, marg->euler_rates_radps)
            .finished();
    if (marg->has_heading) {
      UpdateSelected<6>(z, kMargStateRows, marg->covariance, estimate);
    } else {
      // Drop row/column 2 (heading).
      const int keep[5] = {0, 1, 3, 4, 5};
      int rows[5];
      Eigen::Matrix<double, 5, 1> z5;
      Eigen::Matrix<double, 5, 5> R5;
      for (int i = 0; i < 5; ++i) {
        rows[i] = kMargStateRows[keep[i]];
        z5[i] = z[keep[i]];
        for (int j = 0; j < 5; ++j) R5(i, j) = marg->covariance(keep[i], keep[j]);
      }
      UpdateSelected<5>(z5, rows, R5, estimate);
    }
  } else if (const auto* altitude = std::get_if<AltitudeMeasurement>(&measurement)) {
    const int rows[1] = {kZ};
    UpdateSelected<1>(Eigen::Matrix<double, 1, 1>(altitude->z_meters), rows,
                      Eigen::Matrix<double, 1, 1>(altitude->variance_meters2), estimate);
  } else if (const auto* scan = std::get_if<ScanMatchPose>(&measurement)) {
    const int rows[3] = {kX, kY, kYaw};
    UpdateSelected<3>(scan->world_T_robot.ToVector(), rows, scan->covariance, estimate);
    // Not while a command drives a lagged velocity (command_response_seconds): the line fit
    // averages the velocity over its window, half a window behind it, and the lag model
    // carries that error into the position. There the scan matches observe the velocity
    // through the position they measure.
    const bool lagged_command = options_.command_response_seconds > 0 && filter->has_command &&
                                stamp_seconds <= filter->command.stamp_seconds + options_.command_timeout_seconds;
    VelocityObservation velocity;
    if (options_.use_scan_velocity && !lagged_command && scan_velocity_.VelocityAt(stamp_seconds, &velocity)) {
      const int velocity_rows[2] = {kVx, kVy};
      UpdateSelected<2>(velocity.velocity_mps, velocity_rows, velocity.covariance, estimate);
    }
  }
}

Status EkfStateUpdater::Insert(double stamp_seconds, Measurement measurement) {
  const int kind = static_cast<int>(measurement.index());
  const double newest_stamp =
      events_.empty() ? base_stamp_seconds_ : events_.back().stamp_seconds;
  const bool before_base =
      stamp_seconds < base_stamp_seconds_ ||
      (stamp_seconds == base_stamp_seconds_ && kind < base_kind_);
  if (before_base || stamp_seconds < newest_stamp - options_.history_window_seconds) {
    ++num_rejected_too_old_;
    std::ostringstream message;
    message << "measurement (kind " << kind << ") at t=" << stamp_seconds
            << " is older than the EKF history (newest t=" << newest_stamp << ", window "
            << options_.history_window_seconds << " s); rejected (" << num_rejected_too_old_
            << " so far)";
    if (num_rejected_too_old_ <= options_.max_logged_rejections) LOG(WARNING) << message.str();
    return Status::Error(message.str());
  }

  // Position: after every event whose (stamp, kind) is not greater (arrival order on ties).
  auto position = std::upper_bound(
      events_.begin(), events_.end(), std::make_pair(stamp_seconds, kind),
      [](const std::pair<double, int>& key, const Event& e) {
        return key.first < e.stamp_seconds ||
               (key.first == e.stamp_seconds && key.second < e.kind);
      });
  const bool out_of_sequence = position != events_.end();
  if (out_of_sequence) ++num_out_of_sequence_;
  if (const auto* scan = std::get_if<ScanMatchPose>(&measurement)) {
    scan_velocity_.AddPose(stamp_seconds, scan->world_T_robot.translation(),
                           scan->covariance.topLeftCorner<2, 2>());
  }
  auto inserted = events_.insert(position, Event{stamp_seconds, kind, std::move(measurement), {}});

  // Rewind to the checkpoint before the new event, apply it, replay the newer ones
  // (paper §III-F: the late measurement becomes a 1-step lag problem, then re-update).
  FilterState filter = inserted == events_.begin() ? base_ : std::prev(inserted)->after;
  for (auto it = inserted; it != events_.end(); ++it) {
    Apply(it->measurement, it->stamp_seconds, &filter);
    it->after = filter;
    if (it != inserted) ++num_replayed_;
  }
  latest_ = events_.back().after.estimate;
  Prune();
  return Status::Ok();
}

void EkfStateUpdater::Prune() {
  const double newest_stamp = events_.back().stamp_seconds;
  const double oldest_kept = newest_stamp - options_.history_window_seconds;
  while (!events_.empty() && events_.front().stamp_seconds < oldest_kept) {
    base_ = events_.front().after;
    base_stamp_seconds_ = events_.front().stamp_seconds;
    base_kind_ = events_.front().kind;
    events_.pop_front();
  }
  // A replay from any accepted stamp (>= oldest_kept) needs the poses of one velocity
  // window before it.
  scan_velocity_.DropBefore(oldest_kept - options_.scan_velocity.window_seconds);
}

Status EkfStateUpdater::AddCommand(const VelocityCommand& command) {
  if (!initialized_) return Status::Error("EkfStateUpdater::AddCommand before Initialize()");
  if (!std::isfinite(command.stamp_seconds) || !std::isfinite(command.forward_mps) ||
      !std::isfinite(command.left_mps) || !std::isfinite(command.yaw_rate_radps)) {
    std::ostringstream message;
    message << "command at t=" << command.stamp_seconds << " has non-finite values";
    return Status::Error(message.str());
  }
  return Insert(command.stamp_seconds, command);
}

Status EkfStateUpdater::AddMarg(const MargMeasurement& measurement) {
  if (!initialized_) return Status::Error("EkfStateUpdater::AddMarg before Initialize()");
  if (!std::isfinite(measurement.stamp_seconds) || !std::isfinite(measurement.roll_radians) ||
      !std::isfinite(measurement.pitch_radians) ||
      (measurement.has_heading && !std::isfinite(measurement.heading_radians)) ||
      !measurement.euler_rates_radps.allFinite()) {
    std::ostringstream message;
    message << "MARG measurement at t=" << measurement.stamp_seconds << " has non-finite values";
    return Status::Error(message.str());
  }
  Eigen::Matrix<double, 6, 6> covariance = measurement.covariance;
  if (!measurement.has_heading) {
    // The heading row is unused: check the rest only.
    covariance.row(2).setZero();
    covariance.col(2).setZero();
    covariance(2, 2) = 1.0;
  }
  Status status = CheckCovariance<6>(covariance, "MARG measurement", measurement.stamp_seconds);
  if (!status.ok()) return status;
  MargMeasurement copy = measurement;
  copy.heading_radians = measurement.has_heading ? WrapAngle(measurement.heading_radians) : 0.0;
  return Insert(measurement.stamp_seconds, copy);
}

Status EkfStateUpdater::AddScanMatchPose(const ScanMatchPose& measurement) {
  if (!initialized_) return Status::Error("EkfStateUpdater::AddScanMatchPose before Initialize()");
  if (!std::isfinite(measurement.stamp_seconds) ||
      !measurement.world_T_robot.ToVector().allFinite()) {
    std::ostringstream message;
    message << "scan-match pose at t=" << measurement.stamp_seconds << " has non-finite values";
    return Status::Error(message.str());
  }
  Status status =
      CheckCovariance<3>(measurement.covariance, "scan-match pose", measurement.stamp_seconds);
  if (!status.ok()) return status;
  return Insert(measurement.stamp_seconds, measurement);
}

Status EkfStateUpdater::AddAltitude(const AltitudeMeasurement& measurement) {
  if (!initialized_) return Status::Error("EkfStateUpdater::AddAltitude before Initialize()");
  if (!std::isfinite(measurement.stamp_seconds) || !std::isfinite(measurement.z_meters) ||
      !(measurement.variance_meters2 > 0.0) || !std::isfinite(measurement.variance_meters2)) {
    std::ostringstream message;
    message << "altitude at t=" << measurement.stamp_seconds
            << " must have a finite height and a finite positive variance, got z="
            << measurement.z_meters << ", variance=" << measurement.variance_meters2;
    return Status::Error(message.str());
  }
  return Insert(measurement.stamp_seconds, measurement);
}

Status EkfStateUpdater::EstimateAt(double stamp_seconds, StateEstimate* estimate) const {
  CHECK(estimate != nullptr);
  if (!initialized_) return Status::Error("EkfStateUpdater::EstimateAt before Initialize()");
  if (!std::isfinite(stamp_seconds) || stamp_seconds < base_stamp_seconds_) {
    std::ostringstream message;
    message << "EstimateAt(" << stamp_seconds << ") is before the kept history (from t="
            << base_stamp_seconds_ << ")";
    return Status::Error(message.str());
  }
  // Newest checkpoint whose stamp is not after the asked time.
  auto after = std::upper_bound(
      events_.begin(), events_.end(), stamp_seconds,
      [](double t, const Event& e) { return t < e.stamp_seconds; });
  FilterState filter = after == events_.begin() ? base_ : std::prev(after)->after;
  Predict(stamp_seconds, &filter);
  *estimate = filter.estimate;
  return Status::Ok();
}

std::vector<StateEstimate> EkfStateUpdater::AdvanceTo(double stamp_seconds) {
  std::vector<StateEstimate> outputs;
  if (!initialized_ || !(stamp_seconds > last_output_stamp_seconds_)) return outputs;
  const double period = options_.output_period_seconds;
  // Ticks are the multiples of the period: the output grid does not depend on call times.
  for (int64_t k = static_cast<int64_t>(std::floor(last_output_stamp_seconds_ / period)) + 1;
       k * period <= stamp_seconds; ++k) {
    const double t = k * period;
    if (t <= last_output_stamp_seconds_) continue;
    StateEstimate estimate;
    if (EstimateAt(t, &estimate).ok()) outputs.push_back(estimate);
  }
  last_output_stamp_seconds_ = stamp_seconds;
  return outputs;
}

}  // namespace hetslam
