// EKF state updater (paper §III-F): a constant-rate estimate of the robot state from MARG
// attitude, scan-match poses, velocities taken from the scan-match history and optional
// controller commands, with out-of-sequence measurements handled by rewinding and replaying.
//
// Symbols (used as variable names in the .cc):
//   X = [x y z ẋ ẏ ż ψ θ φ ψ̇ θ̇ φ̇]ᵀ   the state, indices kX ... kYawRate below.
//   x, y      position of the robot body-frame origin in the world (map) frame, m.
//   z         height above the floor of the robot body-frame origin, m (for a humanoid whose
//             laser is on the head, feed the laser height from LaserHeightFromHeadPitch()).
//   ẋ, ẏ, ż   velocity in the world frame, m/s.
//   ψ         roll, rotation about the body x axis, rad.
//   θ         pitch, rotation about the body y axis (positive nose down), rad.
//   φ         heading (yaw), rotation about the world z axis, rad, wrapped to [-pi, pi).
//             This follows the paper, whose eq. 3 rotates body velocities by φ. Attitude is
//             world_R_body = R_z(φ) R_y(θ) R_x(ψ), as in marg_filter.h and core/laser_scan.h.
//   ψ̇, θ̇, φ̇   Z-Y-X Euler angle rates, rad/s (not body rates: see EulerRatesFromBodyRate).
//   P         12×12 covariance of X.
//   u = (v_x, v_y, ω_u)  controller command: body-frame forward/left velocity (m/s) and yaw
//             rate (rad/s), held from its stamp for command_timeout_seconds.
//   δt        prediction interval, s.   F = ∂f/∂X the transition Jacobian.   Q process noise.
//   z_k, H, R measurement, its Jacobian and covariance.   ν = z_k - h(X) the innovation with
//             its angle rows wrapped.   S = H P Hᵀ + R.   K = P Hᵀ S⁻¹ the gain.
//
// Prediction, X_{k+1} = f(X_k, u) + w:
//   with a live command (paper eq. 3):
//     x += δt (cos φ v_x - sin φ v_y),  y += δt (sin φ v_x + cos φ v_y),  φ += δt ω_u,
//     ẋ, ẏ, φ̇ random walks; w on x, y, φ from the command_* noise densities (random walks,
//     variance ∝ δt).
//   without one (constant velocity): each of (x,ẋ) (y,ẏ) (z,ż) (ψ,ψ̇) (θ,θ̇) (φ,φ̇) is
//     p += δt ṗ with continuous white acceleration noise of spectral density q:
//     Q = q [δt³/3 δt²/2; δt²/2 δt].  (z,ż), (ψ,ψ̇), (θ,θ̇) always use this model.
// Updates (Joseph form P = (I-KH) P (I-KH)ᵀ + K R Kᵀ, angle innovations wrapped):
//   MARG: z = (ψ θ φ ψ̇ θ̇ φ̇) (heading optional), ~100 Hz.
//   scan match: z = (x y φ) with its 3×3 covariance, 10-20 Hz.
//   scan velocity: z = (ẋ ẏ), a least-squares line fit over the scan-match poses of the last
//     window_seconds (~1 s; 5 cm cells make per-scan differences useless, paper §III-F), added
//     right after every scan-match update. These observations reuse the poses the scan updates
//     already used, so they are correlated with them; the fit's covariance is exact for
//     independent pose errors, plus smoothing_stddev_mps² for the lag of the window average.
//   altitude: z = z.
//
// Time and out-of-sequence measurements: the filter is only ever predicted exactly to a
// measurement's stamp, so its result is a deterministic function of the set of measurements.
// Every applied measurement is kept with the (X, P, command) checkpoint after it for
// history_window_seconds behind the newest stamp. A late measurement rewinds to the checkpoint
// just before its stamp, is applied, and every newer measurement is replayed: the estimate
// equals the one from the same measurements delivered in stamp order (ties in stamp are
// ordered by kind: command, MARG, altitude, scan match; equal stamp and kind by arrival).
// Measurements older than the window are rejected, counted (num_rejected_too_old()) and
// logged for the first few. Output (EstimateAt, AdvanceTo) predicts a copy to the asked time
// and never alters the filter.
#ifndef HETSLAM_FRONTENDS_EKF_STATE_UPDATER_H_
#define HETSLAM_FRONTENDS_EKF_STATE_UPDATER_H_

#include <cstdint>
#include <deque>
#include <string>
#include <variant>
#include <vector>

#include "Eigen/Core"
#include "core/se2.h"
#include "core/status.h"
#include "frontends/marg_filter.h"

namespace hetslam {

// State indices of X (see the symbol table above).
enum EkfStateIndex : int {
  kX = 0, kY = 1, kZ = 2,
  kVx = 3, kVy = 4, kVz = 5,
  kRoll = 6, kPitch = 7, kYaw = 8,
  kRollRate = 9, kPitchRate = 10, kYawRate = 11,
  kEkfStateSize = 12,
};

using EkfVector = Eigen::Matrix<double, kEkfStateSize, 1>;
using EkfMatrix = Eigen::Matrix<double, kEkfStateSize, kEkfStateSize>;

// Velocity from the recent scan-match poses (see ScanVelocityEstimator).
struct ScanVelocityOptions {
  double window_seconds = 1.0;       // fit over poses with stamp in [t - window, t]
  int min_poses = 3;                 // fewer poses in the window: no observation
  double min_span_seconds = 0.5;     // poses spanning less time: no observation
  double smoothing_stddev_mps = 0.05;  // added for the lag of the window average

  bool IsValid(std::string* error) const;
};

struct VelocityObservation {
  double stamp_seconds = 0.0;
  Eigen::Vector2d velocity_mps = Eigen::Vector2d::Zero();  // (ẋ, ẏ), world frame
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
};

// Keeps recent scan-match positions (sorted by stamp, late ones inserted in place) and fits
// x(t) = x̄ + ẋ (t - t̄), y(t) likewise, by least squares over a window ending at the query
// time. With weights w_i = (t_i - t̄) / Σ_j (t_j - t̄)²: ẋ = Σ w_i x_i and
// Cov(ẋ, ẏ) = Σ w_i² Σ_i + smoothing_stddev² I, Σ_i the 2×2 position covariance of pose i.
class ScanVelocityEstimator {
 public:
  explicit ScanVelocityEstimator(const ScanVelocityOptions& options);

  void AddPose(double stamp_seconds, const Eigen::Vector2d& position_meters,
               const Eigen::Matrix2d& position_covariance);
  // Fit over the poses with stamp in [stamp - window, stamp] (poses added later but stamped
  // after `stamp` are ignored). False when too few poses or too short a span.
  bool VelocityAt(double stamp_seconds, VelocityObservation* observation) const;
  // Forgets poses stamped before `stamp_seconds`.
  void DropBefore(double stamp_seconds);
  int size() const { return static_cast<int>(poses_.size()); }

 private:
  struct StampedPosition {
    double stamp_seconds;
    Eigen::Vector2d position_meters;
    Eigen::Matrix2d covariance;
  };
  ScanVelocityOptions options_;
  std::deque<StampedPosition> poses_;
};

struct EkfStateUpdaterOptions {
  // How far behind the newest measurement a late one is still accepted (and the history kept).
  double history_window_seconds = 1.0;
  // Period of the constant-rate output of AdvanceTo().
  double output_period_seconds = 0.01;

  // Constant-velocity model: white acceleration spectral densities.
  double horizontal_acceleration_noise_mps2_per_sqrt_hz = 0.5;  // x, y
  double vertical_acceleration_noise_mps2_per_sqrt_hz = 0.1;    // z
  double tilt_acceleration_noise_radps2_per_sqrt_hz = 1.0;      // roll, pitch
  double yaw_acceleration_noise_radps2_per_sqrt_hz = 0.5;       // heading

  // Command model (paper eq. 3): random-walk densities.
  double command_position_noise_meters_per_sqrt_second = 0.05;  // w_x, w_y
  double command_yaw_noise_radians_per_sqrt_second = 0.02;      // w_φ
  double command_velocity_noise_mps_per_sqrt_second = 0.2;      // w_ẋ, w_ẏ
  double command_yaw_rate_noise_radps_per_sqrt_second = 0.2;    // w_φ̇
  // A command drives the prediction for this long after its stamp; then constant velocity.
  double command_timeout_seconds = 0.5;
  // Time constant of the platform's velocity response to a command (a multirotor's velocity
  // controller), 0 = the velocity is the command (paper eq. 3). With τ > 0 the world velocity
  // (ẋ, ẏ) follows the commanded one, R(φ) (v_x, v_y), with a first-order lag:
  //   ẋ += (1 - e^(-δt/τ)) (v - ẋ),  x += δt v + τ (1 - e^(-δt/τ)) (ẋ - v)   (exact for a
  // constant command and heading over δt), so a turn or a stop is not predicted before the
  // platform makes it. A property of the platform: robot logs may state it (PARAM
  // command_response_seconds; the simulator's UAV: 0.25 s). While such a command is live the
  // scan velocity (below) is not applied: its line fit lags the velocity by half a window.
  double command_response_seconds = 0.0;

  bool use_scan_velocity = true;
  ScanVelocityOptions scan_velocity;

  // How many too-old rejections are written with LOG(WARNING) (all are counted).
  int max_logged_rejections = 5;

  bool IsValid(std::string* error) const;
};

// A filter state at a time: the mean X, its covariance P and convenience views.
struct StateEstimate {
  double stamp_seconds = 0.0;
  EkfVector state = EkfVector::Zero();
  EkfMatrix covariance = EkfMatrix::Identity();

  // world_T_robot as (x, y, φ).
  Pose2 pose() const { return Pose2(state[kX], state[kY], state[kYaw]); }
  // Covariance of (x, y, φ).
  Eigen::Matrix3d pose_covariance() const;
};

// MARG attitude and Euler rates in the world frame of the map (a magnetometer heading must
// be offset into it by the caller, or left out with has_heading = false).
struct MargMeasurement {
  double stamp_seconds = 0.0;
  double roll_radians = 0.0;
  double pitch_radians = 0.0;
  double heading_radians = 0.0;
  Eigen::Vector3d euler_rates_radps = Eigen::Vector3d::Zero();  // (ψ̇, θ̇, φ̇)
  bool has_heading = true;  // false: the heading row (and its covariance) is ignored
  // Covariance of (ψ, θ, φ, ψ̇, θ̇, φ̇).
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e-4;
};

// MargMeasurement from a MargFilter output, with its reported standard deviations;
// heading_offset_radians is added to the MARG heading to express it in the map frame.
MargMeasurement MargMeasurementFromAttitude(const MargAttitude& attitude, bool use_heading,
                                            double heading_offset_radians);

struct ScanMatchPose {
  double stamp_seconds = 0.0;
  Pose2 world_T_robot;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // of (x, y, φ)
};

struct AltitudeMeasurement {
  double stamp_seconds = 0.0;
  double z_meters = 0.0;
  double variance_meters2 = 1e-4;
};

// Humanoid head kinematics (paper §III-F: "z is estimated based on the current laser tilt and
// laser position within the robot body"). The head pitches about a neck joint at
// neck_height_meters above the floor (standing robot); the laser sits at
// (forward, up) = (neck_to_laser_forward_meters, neck_to_laser_up_meters) in the head frame.
// With head pitch β (positive nose down, about y) and body pitch θ from the MARG, the laser
// tilt is θ + β and its height is
//   z_laser = neck_height + up cos(θ + β) - forward sin(θ + β).
// The body pitch is taken as a rotation about the neck joint (the trunk sway of a standing
// humanoid is small next to the head motion).
struct HumanoidHeadOptions {
  double neck_height_meters = 0.45;
  double neck_to_laser_forward_meters = 0.05;
  double neck_to_laser_up_meters = 0.08;

  bool IsValid(std::string* error) const;
};
double LaserHeightFromHeadPitch(const HumanoidHeadOptions& options, double head_pitch_radians,
                                double body_pitch_radians);

class EkfStateUpdater {
 public:
  // CHECK-fails on invalid options (validate user input with IsValid first).
  explicit EkfStateUpdater(const EkfStateUpdaterOptions& options);

  // Starts (or restarts) the filter from `initial`; clears history and counters.
  void Initialize(const StateEstimate& initial);
  bool initialized() const { return initialized_; }

  // Each Add* returns OK once applied (in or out of sequence). Errors, with the filter
  // unchanged: not initialised, non-finite values, a covariance that is not symmetric positive
  // (semi-)definite, or a stamp older than the history window (also counted).
  Status AddCommand(const VelocityCommand& command);
  Status AddMarg(const MargMeasurement& measurement);
  Status AddScanMatchPose(const ScanMatchPose& measurement);
  Status AddAltitude(const AltitudeMeasurement& measurement);

  // The filter's estimate at its newest measurement.
  const StateEstimate& latest() const { return latest_; }

  // The estimate at `stamp_seconds`: the newest checkpoint not after it, predicted to it
  // (a filtered, not smoothed, estimate). Error if the stamp is before the kept history.
  Status EstimateAt(double stamp_seconds, StateEstimate* estimate) const;

  // Constant-rate output: the estimates at every multiple of output_period_seconds in
  // (previous call's time, stamp_seconds]; the first call starts after the initial stamp.
  std::vector<StateEstimate> AdvanceTo(double stamp_seconds);

  int64_t num_rejected_too_old() const { return num_rejected_too_old_; }
  int64_t num_out_of_sequence() const { return num_out_of_sequence_; }
  int64_t num_replayed() const { return num_replayed_; }
  int history_size() const { return static_cast<int>(events_.size()); }

 private:
  // The command state travels with the filter state so that a replay reproduces it.
  struct FilterState {
    StateEstimate estimate;
    bool has_command = false;
    VelocityCommand command;
  };
  using Measurement =
      std::variant<VelocityCommand, MargMeasurement, AltitudeMeasurement, ScanMatchPose>;
  struct Event {
    double stamp_seconds;
    int kind;  // Measurement::index(): the tie-break order at equal stamps
    Measurement measurement;
    FilterState after;  // checkpoint after applying this event
  };

  Status Insert(double stamp_seconds, Measurement measurement);
  void Apply(const Measurement& measurement, double stamp_seconds, FilterState* filter) const;
  void Predict(double stamp_seconds, FilterState* filter) const;
  void PredictConstantVelocity(double dt, StateEstimate* estimate) const;
  void PredictWithCommand(double dt, const VelocityCommand& command,
                          StateEstimate* estimate) const;
  void Prune();

  EkfStateUpdaterOptions options_;
  bool initialized_ = false;
  FilterState base_;          // state before the oldest kept event
  double base_stamp_seconds_ = 0.0;
  int base_kind_ = -1;        // kind of the event folded into base_ (-1: initial state)
  std::deque<Event> events_;  // sorted by (stamp, kind, arrival)
  StateEstimate latest_;
  ScanVelocityEstimator scan_velocity_;
  double last_output_stamp_seconds_ = 0.0;
  int64_t num_rejected_too_old_ = 0;
  int64_t num_out_of_sequence_ = 0;
  int64_t num_replayed_ = 0;
};

}  // namespace hetslam

#endif  // HETSLAM_FRONTENDS_EKF_STATE_UPDATER_H_
