#include "datasets/sim/team_simulator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <system_error>

#include "core/euler.h"
#include "core/map_layers.h"
#include "core/robot_log_writer.h"
#include "core/team_manifest.h"
#include "datasets/sim/sim_random.h"
#include "datasets/sim/sim_text.h"
#include "datasets/sim/simulator.h"
#include "datasets/sim/tag_camera.h"
#include "glog/logging.h"
#include "opencv2/core.hpp"
#include "opencv2/imgcodecs.hpp"
#include "opencv2/imgproc.hpp"

namespace hetslam {
namespace sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kMaxTiltRadians = 15.0 * kDegToRad;  // UAV roll and pitch limit
constexpr double kUavVelocityLagSeconds = 0.25;
constexpr double kUavAttitudeLagSeconds = 0.15;
constexpr double kUavClimbGainPerSecond = 1.0;
constexpr double kUavMaxClimbRateMps = 0.4;
constexpr double kHeadingGainPerSecond = 1.5;
constexpr double kSwayFrequencyHz = 1.0;  // one left-right cycle per two steps
constexpr double kSwayRollRadians = 2.0 * kDegToRad;
constexpr double kSwayLateralMeters = 0.015;
constexpr double kSwayFullSpeedMps = 0.1;  // sway amplitude grows linearly up to this speed

// Acceleration limits and arrival tolerances per kind.
struct KindDynamics {
  double acceleration_mps2;
  double yaw_acceleration_radps2;
  double waypoint_radius_meters;  // pass-through waypoints
  double goal_radius_meters;      // waypoints where the robot stops
  double stopped_speed_mps;
};

KindDynamics DynamicsFor(RobotKind kind) {
  switch (kind) {
    case RobotKind::kWheeled: return {0.5, 2.0, 0.35, 0.1, 0.01};
    case RobotKind::kHumanoid: return {0.2, 1.0, 0.2, 0.08, 0.005};
    case RobotKind::kUav: return {1.0, 2.0, 0.3, 0.1, 0.02};
  }
  return {0.5, 2.0, 0.35, 0.1, 0.01};
}

double MoveTowards(double current, double target, double max_step) {
  return current + std::clamp(target - current, -max_step, max_step);
}

Eigen::Vector2d MoveTowards(const Eigen::Vector2d& current, const Eigen::Vector2d& target,
                            double max_step) {
  const Eigen::Vector2d delta = target - current;
  const double norm = delta.norm();
  return norm <= max_step ? target : Eigen::Vector2d(current + delta * (max_step / norm));
}

Eigen::Matrix2d Rotation2(double yaw) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

// Exact displacement for a constant body velocity (vx, vy) and yaw rate w over dt, starting
// at heading yaw: the integral of R(yaw + w s) (vx, vy) for s in [0, dt].
Eigen::Vector2d PlanarDisplacement(double yaw, double vx, double vy, double w, double dt) {
  if (std::abs(w) < 1e-9) return Rotation2(yaw) * Eigen::Vector2d(vx, vy) * dt;
  const double yaw_end = yaw + w * dt;
  const double s = (std::sin(yaw_end) - std::sin(yaw)) / w;
  const double c = -(std::cos(yaw_end) - std::cos(yaw)) / w;
  return Eigen::Vector2d(s * vx - c * vy, c * vx + s * vy);
}

// The motion state of one robot between control updates.
struct MotionState {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  // nominal (humanoid: without sway)
  double z = 0.0;
  double yaw = 0.0, roll = 0.0, pitch = 0.0;
  Eigen::Vector3d velocity_world = Eigen::Vector3d::Zero();  // UAV
  double cmd_vx = 0.0, cmd_vy = 0.0, cmd_w = 0.0;            // body-frame command in force
  Eigen::Vector2d uav_velocity_command = Eigen::Vector2d::Zero();  // world frame
  double altitude_target = 0.0;
  double sway_phase = 0.0, sway_amplitude = 0.0;  // humanoid
};

TruthSample TruthFromState(const RobotSpec& spec, const MotionState& state, double t) {
  TruthSample sample;
  sample.stamp_seconds = t;
  double roll = state.roll;
  Eigen::Vector2d xy = state.xy;
  if (spec.kind == RobotKind::kHumanoid) {
    const double sway = state.sway_amplitude * std::sin(state.sway_phase);
    roll = kSwayRollRadians * sway;
    xy += Rotation2(state.yaw) * Eigen::Vector2d(0.0, kSwayLateralMeters * sway);
  }
  sample.position = Eigen::Vector3d(xy.x(), xy.y(), spec.kind == RobotKind::kUav ? state.z : 0.0);
  sample.rotation = Eigen::Quaterniond(RotationFromRollPitchYaw(roll, state.pitch, state.yaw));
  sample.rotation.normalize();
  return sample;
}

Eigen::Vector3d LogMap(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd aa(rotation);
  return aa.angle() * aa.axis();
}

// Fills acceleration_world and rate_body by finite differences (see the header).
void DifferentiateTruth(double dt, std::vector<TruthSample>* truth) {
  const int n = static_cast<int>(truth->size());
  for (int k = 0; k < n; ++k) {
    TruthSample& s = (*truth)[k];
    // Before the start the robot was at rest where it starts; after the end it keeps its last
    // velocity (extrapolated), so that a run cut by the duration limit ends without a spike.
    const TruthSample& prev = (*truth)[std::max(0, k - 1)];
    const Eigen::Matrix3d r = s.rotation.toRotationMatrix();
    const Eigen::Matrix3d r_prev = prev.rotation.toRotationMatrix();
    Eigen::Vector3d next_position;
    Eigen::Vector3d step_after;  // log(R(k)^T R(k+1))
    if (k + 1 < n) {
      next_position = (*truth)[k + 1].position;
      step_after = LogMap(r.transpose() * (*truth)[k + 1].rotation.toRotationMatrix());
    } else {
      next_position = 2.0 * s.position - prev.position;
      step_after = LogMap(r_prev.transpose() * r);
    }
    s.acceleration_world = (next_position - 2.0 * s.position + prev.position) / (dt * dt);
    s.rate_body = (LogMap(r_prev.transpose() * r) + step_after) / (2.0 * dt);
  }
}

// Truth at time t (interpolated between control steps; exact on them).
struct TruthAt {
  Eigen::Isometry3d world_T_body = Eigen::Isometry3d::Identity();
  Eigen::Vector3d acceleration_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d rate_body = Eigen::Vector3d::Zero();
};

TruthAt SampleTruth(const std::vector<TruthSample>& truth, double dt, double t) {
  CHECK(!truth.empty());
  const int n = static_cast<int>(truth.size());
  const double x = t / dt;
  int k = static_cast<int>(std::floor(x + 1e-9));
  k = std::clamp(k, 0, n - 1);
  double u = std::clamp(x - k, 0.0, 1.0);
  if (u < 1e-9 || k == n - 1) u = 0.0;
  const TruthSample& a = truth[k];
  const TruthSample& b = truth[std::min(n - 1, k + 1)];
  TruthAt out;
  out.world_T_body.linear() =
      (u == 0.0 ? a.rotation : a.rotation.slerp(u, b.rotation)).toRotationMatrix();
  out.world_T_body.translation() = (1.0 - u) * a.position + u * b.position;
  out.acceleration_world = (1.0 - u) * a.acceleration_world + u * b.acceleration_world;
  out.rate_body = (1.0 - u) * a.rate_body + u * b.rate_body;
  return out;
}

// Sensor stamps j / rate up to and including t_end.
std::vector<double> SensorStamps(double rate_hz, double t_end) {
  std::vector<double> stamps;
  for (long long j = 0;; ++j) {
    const double t = j / rate_hz;
    if (t > t_end + 1e-9) break;
    stamps.push_back(t);
  }
  return stamps;
}

Eigen::Vector3d Gaussian3(double stddev, std::mt19937_64* rng) {
  const double x = StandardGaussian(rng);
  const double y = StandardGaussian(rng);
  const double z = StandardGaussian(rng);
  return stddev * Eigen::Vector3d(x, y, z);
}

StampedPose3 Stamped(double t, const Eigen::Isometry3d& pose) {
  StampedPose3 s;
  s.stamp_seconds = t;
  s.pose = pose;
  return s;
}

// Runs the controller and integrates the truth of one robot (no sensors, no randomness).
void SimulateMotion(const RobotSpec& spec, double dt, double t_limit, RobotSimulation* out) {
  const KindDynamics dyn = DynamicsFor(spec.kind);
  const RobotOptions& limits = spec.motion;
  MotionState state;
  const Pose2 start = spec.InitialPose();
  state.xy = start.translation();
  state.yaw = start.theta();
  state.altitude_target = spec.altitude_meters;
  state.z = spec.kind == RobotKind::kUav ? spec.altitude_meters : 0.0;

  const int num_steps = static_cast<int>(spec.route.size());
  int step = 0;
  double step_start = 0.0;
  // Skip a first waypoint the robot already stands on (the implied start).
  auto is_stop_waypoint = [&](int i) {
    return i + 1 >= num_steps || spec.route[i + 1].type != RouteStep::Type::kWaypoint;
  };
  auto speed_now = [&]() {
    return spec.kind == RobotKind::kUav ? state.velocity_world.head<2>().norm()
                                        : std::hypot(state.cmd_vx, state.cmd_vy);
  };
  for (long long k = 0;; ++k) {
    const double t = k * dt;
    out->truth.push_back(TruthFromState(spec, state, t));
    if (t > t_limit - 1e-9) break;
    // Advance through finished steps.
    while (step < num_steps) {
      const RouteStep& s = spec.route[step];
      bool done = false;
      if (s.type == RouteStep::Type::kWaypoint) {
        const double distance = (s.target - state.xy).norm();
        done = is_stop_waypoint(step)
                   ? distance < dyn.goal_radius_meters && speed_now() < dyn.stopped_speed_mps
                   : distance < dyn.waypoint_radius_meters;
        if (!done && step == 0 && !spec.has_start_pose) done = distance < 1e-9;
      } else {
        done = t - step_start >= s.duration_seconds - 1e-9;
      }
      if (!done) break;
      ++step;
      step_start = t;
      if (step < num_steps && spec.route[step].type == RouteStep::Type::kWaypoint &&
          std::isfinite(spec.route[step].altitude_meters)) {
        state.altitude_target = spec.route[step].altitude_meters;
      }
    }
    if (step == num_steps && speed_now() < dyn.stopped_speed_mps &&
        std::abs(state.cmd_w) < 1e-3 &&
        (spec.kind != RobotKind::kUav || std::abs(state.velocity_world.z()) < 0.02)) {
      out->completed = true;
      break;
    }
    // Desired command.
    double vx_d = 0.0, vy_d = 0.0, w_d = 0.0;
    Eigen::Vector2d uav_velocity_d = Eigen::Vector2d::Zero();
    if (step < num_steps) {
      const RouteStep& s = spec.route[step];
      if (s.type == RouteStep::Type::kCommand) {
        vx_d = s.vx_mps;
        vy_d = s.vy_mps;
        w_d = s.yaw_rate_radps;
        uav_velocity_d = Rotation2(state.yaw) * Eigen::Vector2d(vx_d, vy_d);
      } else if (s.type == RouteStep::Type::kWaypoint) {
        const Eigen::Vector2d to_goal = s.target - state.xy;
        const double distance = to_goal.norm();
        const double heading_error =
            WrapAngle(std::atan2(to_goal.y(), to_goal.x()) - state.yaw);
        if (spec.kind == RobotKind::kUav) {
          double speed = limits.max_speed_mps;
          if (is_stop_waypoint(step)) {
            speed = std::min(speed, std::sqrt(2.0 * 0.5 * dyn.acceleration_mps2 * distance));
          }
          if (distance > 1e-9) uav_velocity_d = to_goal * (speed / distance);
          if (distance > 0.3) {
            w_d = std::clamp(kHeadingGainPerSecond * heading_error, -limits.max_turn_rate_radps,
                             limits.max_turn_rate_radps);
          }
        } else {
          w_d = std::clamp(kHeadingGainPerSecond * heading_error, -limits.max_turn_rate_radps,
                           limits.max_turn_rate_radps);
          const double alignment = std::max(0.0, std::cos(heading_error));
          vx_d = limits.max_speed_mps * alignment * alignment;
          if (is_stop_waypoint(step)) {
            vx_d = std::min(vx_d, std::sqrt(2.0 * dyn.acceleration_mps2 * distance));
          }
        }
      }
    }
    // Limited command, logged.
    state.cmd_w = MoveTowards(state.cmd_w, w_d, dyn.yaw_acceleration_radps2 * dt);
    if (spec.kind == RobotKind::kUav) {
      state.uav_velocity_command = MoveTowards(state.uav_velocity_command, uav_velocity_d,
                                               dyn.acceleration_mps2 * dt);
      const Eigen::Vector2d body = Rotation2(state.yaw).transpose() * state.uav_velocity_command;
      state.cmd_vx = body.x();
      state.cmd_vy = body.y();
    } else {
      state.cmd_vx = MoveTowards(state.cmd_vx, vx_d, dyn.acceleration_mps2 * dt);
      state.cmd_vy = MoveTowards(state.cmd_vy, vy_d, dyn.acceleration_mps2 * dt);
    }
    VelocityCommand command;
    command.stamp_seconds = t;
    command.forward_mps = state.cmd_vx;
    command.left_mps = state.cmd_vy;
    command.yaw_rate_radps = state.cmd_w;
    out->log.commands.push_back(command);
    // Integrate to t + dt.
    if (spec.kind == RobotKind::kUav) {
      const Eigen::Vector3d velocity_command(state.uav_velocity_command.x(),
                                             state.uav_velocity_command.y(),
                                             std::clamp(kUavClimbGainPerSecond *
                                                            (state.altitude_target - state.z),
                                                        -kUavMaxClimbRateMps,
                                                        kUavMaxClimbRateMps));
      const Eigen::Vector3d acceleration =
          (velocity_command - state.velocity_world) / kUavVelocityLagSeconds;
      const Eigen::Vector3d velocity_before = state.velocity_world;
      state.velocity_world += acceleration * dt;
      const Eigen::Vector3d step_xyz = 0.5 * (velocity_before + state.velocity_world) * dt;
      state.xy += step_xyz.head<2>();
      state.z += step_xyz.z();
      out->path_length_meters += step_xyz.head<2>().norm();
      // Tilt towards the horizontal acceleration (heading frame), lagged and clamped.
      const Eigen::Vector2d a_heading = Rotation2(state.yaw).transpose() * acceleration.head<2>();
      const double g = spec.marg.gravity_mps2;
      const double pitch_target = std::atan(a_heading.x() / g);
      const double roll_target = -std::atan(a_heading.y() / g);
      const double blend = dt / (kUavAttitudeLagSeconds + dt);
      state.pitch = std::clamp(state.pitch + blend * (pitch_target - state.pitch),
                               -kMaxTiltRadians, kMaxTiltRadians);
      state.roll = std::clamp(state.roll + blend * (roll_target - state.roll), -kMaxTiltRadians,
                              kMaxTiltRadians);
      state.yaw = WrapAngle(state.yaw + state.cmd_w * dt);
    } else {
      const Eigen::Vector2d step_xy =
          PlanarDisplacement(state.yaw, state.cmd_vx, state.cmd_vy, state.cmd_w, dt);
      state.xy += step_xy;
      state.yaw = WrapAngle(state.yaw + state.cmd_w * dt);
      out->path_length_meters += std::hypot(state.cmd_vx, state.cmd_vy) * dt;
      if (spec.kind == RobotKind::kHumanoid) {
        const double speed = std::hypot(state.cmd_vx, state.cmd_vy);
        state.sway_amplitude = std::min(1.0, speed / kSwayFullSpeedMps);
        if (speed > 0.0) state.sway_phase += 2.0 * M_PI * kSwayFrequencyHz * dt;
      }
    }
  }
  out->duration_seconds = out->truth.back().stamp_seconds;
}

std::string FormatPoseParam(const Eigen::Isometry3d& pose) {
  const Eigen::Vector3d rpy = RollPitchYawFromRotation(pose.linear());
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), "%.17g %.17g %.17g %.17g %.17g %.17g",
                pose.translation().x(), pose.translation().y(), pose.translation().z(), rpy.x(),
                rpy.y(), rpy.z());
  return buffer;
}

TagCameraOptions TagCameraOptionsFor(const CameraOptions& camera) {
  TagCameraOptions options;
  options.intrinsics = CameraIntrinsics{camera.fx, camera.fy, camera.cx, camera.cy,
                                        camera.width, camera.height};
  return options;
}

SimulatedTag ToSimulatedTag(const TagSpec& tag) {
  SimulatedTag simulated;
  simulated.id = tag.id;
  simulated.size_meters = tag.size_meters;
  simulated.world_T_tag = tag.WorldTTag();
  return simulated;
}

// Samples every sensor of one robot from its truth.
void SimulateSensors(const Scenario& scenario, const World& world, const RobotSpec& spec,
                     const TruthLayerOptions& truth_layers, double dt, std::mt19937_64* rng,
                     RobotSimulation* out) {
  std::mt19937_64 laser_rng((*rng)());
  std::mt19937_64 marg_rng((*rng)());
  std::mt19937_64 odometry_rng((*rng)());
  std::mt19937_64 altimeter_rng((*rng)());
  const double t_end = out->truth.back().stamp_seconds;
  RobotLog& log = out->log;
  std::vector<double> truth_stamps;

  // Laser (and MOUNT).
  for (double t : SensorStamps(spec.laser.rate_hz, t_end)) {
    const TruthAt truth = SampleTruth(out->truth, dt, t);
    const Eigen::Isometry3d body_T_laser = spec.BodyTLaser(spec.HeadPitchRadians(t));
    std::vector<Surface> surfaces;
    std::vector<RayHit> returned;
    int no_return = 0;
    LaserReading reading;
    const Eigen::Isometry3d world_T_laser = truth.world_T_body * body_T_laser;
    reading.scan = SimulateScan3D(world, spec.laser, world_T_laser, t, &laser_rng, &surfaces,
                                  &no_return, &returned);
    for (size_t i = 0; i < returned.size(); ++i) {
      const RayHit& hit = returned[i];
      if (!hit.hit || (hit.surface != Surface::kWall && hit.prism_index < 0)) continue;
      const double angle = reading.scan.angles_radians[i];
      const Eigen::Vector3d end = world_T_laser * (hit.range_meters * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0));
      const TruthLayer layer = hit.prism_index >= 0 ? ClassifyPrism(world.prisms()[hit.prism_index], truth_layers)
                                                    : TruthLayer::kWalls;
      AddSeenPoint(end.head<2>(), layer, truth_layers, &out->seen);
    }
    reading.scan.robot_T_sensor = body_T_laser;
    if (spec.kind == RobotKind::kHumanoid || log.mounts.empty()) {
      log.mounts.push_back(Stamped(t, body_T_laser));
    }
    out->num_no_return_beams += no_return;
    for (Surface surface : surfaces) {
      if (surface != Surface::kNone) ++out->beams_by_surface[surface];
    }
    log.lasers.push_back(reading);
    truth_stamps.push_back(t);
  }

  // MARG and attitude.
  const MargOptions& marg = spec.marg;
  Eigen::Vector3d gyro_bias = Gaussian3(marg.gyro_bias_radps, &marg_rng);
  const Eigen::Vector3d accel_bias = Gaussian3(marg.accel_bias_mps2, &marg_rng);
  const Eigen::Vector3d attitude_offset = Gaussian3(marg.attitude_offset_radians, &marg_rng);
  const Eigen::Vector3d field_world(marg.mag_horizontal_microtesla, 0.0,
                                    -marg.mag_vertical_microtesla);
  const double bias_step = marg.gyro_bias_walk_radps_per_sqrt_s * std::sqrt(1.0 / marg.rate_hz);
  for (double t : SensorStamps(marg.rate_hz, t_end)) {
    const TruthAt truth = SampleTruth(out->truth, dt, t);
    const Eigen::Matrix3d body_R_world = truth.world_T_body.linear().transpose();
    MargSample reading;
    reading.stamp_seconds = t;
    reading.gyro_radps = truth.rate_body + gyro_bias + Gaussian3(marg.gyro_noise_radps, &marg_rng);
    gyro_bias += Gaussian3(bias_step, &marg_rng);
    reading.accel_mps2 =
        body_R_world * (truth.acceleration_world + Eigen::Vector3d(0.0, 0.0, marg.gravity_mps2)) +
        accel_bias + Gaussian3(marg.accel_noise_mps2, &marg_rng);
    reading.magnetometer =
        body_R_world * field_world + Gaussian3(marg.mag_noise_microtesla, &marg_rng);
    log.marg.push_back(reading);
    const Eigen::Vector3d rpy = RollPitchYawFromRotation(truth.world_T_body.linear()) +
                                attitude_offset +
                                Gaussian3(marg.attitude_noise_radians, &marg_rng);
    AttitudeReading attitude;
    attitude.stamp_seconds = t;
    attitude.roll_radians = rpy.x();
    attitude.pitch_radians = rpy.y();
    attitude.yaw_radians = WrapAngle(rpy.z());
    log.attitudes.push_back(attitude);
  }

  // Wheel odometry: the odometry frame is the robot's start pose.
  if (spec.kind == RobotKind::kWheeled) {
    Pose2 odom = Pose2::Identity();
    Pose2 previous;
    bool first = true;
    for (double t : SensorStamps(spec.odometry.rate_hz, t_end)) {
      const Eigen::Isometry3d pose = SampleTruth(out->truth, dt, t).world_T_body;
      const Pose2 truth(pose.translation().x(), pose.translation().y(),
                        RollPitchYawFromRotation(pose.linear()).z());
      if (!first) odom = StepOdometry(spec.odometry, previous, truth, odom, &odometry_rng);
      first = false;
      previous = truth;
      OdometryReading reading;
      reading.stamp_seconds = t;
      reading.pose = odom;
      log.odometry.push_back(reading);
    }
  }

  // UAV altimeter: straight down from the body origin.
  if (spec.kind == RobotKind::kUav) {
    for (double t : SensorStamps(spec.altimeter.rate_hz, t_end)) {
      const Eigen::Vector3d position = SampleTruth(out->truth, dt, t).world_T_body.translation();
      const double noise = spec.altimeter.noise_std_meters * StandardGaussian(&altimeter_rng);
      const RayHit hit = world.CastRay3D(position, -Eigen::Vector3d::UnitZ(), 100.0);
      if (!hit.hit) continue;
      AltitudeReading reading;
      reading.stamp_seconds = t;
      reading.height_meters = std::max(0.0, hit.range_meters + noise);
      log.altitudes.push_back(reading);
    }
  }

  // Camera: pose and visible tags per frame (rendered by the writer).
  if (spec.camera.enabled) {
    const TagCamera camera(TagCameraOptionsFor(spec.camera));
    std::vector<SimulatedTag> tags;
    for (const TagSpec& tag : scenario.tags) tags.push_back(ToSimulatedTag(tag));
    int index = 0;
    for (double t : SensorStamps(spec.camera.rate_hz, t_end)) {
      CameraFrame frame;
      frame.stamp_seconds = t;
      frame.world_T_camera = SampleTruth(out->truth, dt, t).world_T_body *
                             spec.BodyTLaser(spec.HeadPitchRadians(t)) *
                             spec.camera.laser_T_camera;
      const Eigen::Vector3d eye = frame.world_T_camera.translation();
      for (size_t i = 0; i < tags.size(); ++i) {
        if (!camera.IsInView(tags[i], frame.world_T_camera)) continue;
        // The centre and the four corners, 1 cm in front of the wall, must all be in sight.
        const double h = 0.5 * tags[i].size_meters;
        bool visible = true;
        for (const Eigen::Vector3d& p_tag :
             {Eigen::Vector3d(0.0, 0.0, 0.01), Eigen::Vector3d(-h, -h, 0.01),
              Eigen::Vector3d(h, -h, 0.01), Eigen::Vector3d(h, h, 0.01),
              Eigen::Vector3d(-h, h, 0.01)}) {
          if (!world.LineOfSight(eye, tags[i].world_T_tag * p_tag, 0.005)) {
            visible = false;
            break;
          }
        }
        if (visible) frame.visible_tags.push_back(static_cast<int>(i));
      }
      char name[32];
      std::snprintf(name, sizeof(name), "images/%06d.png", index++);
      frame.relative_path = name;
      CameraImage image;
      image.stamp_seconds = t;
      image.path = frame.relative_path;
      log.images.push_back(image);
      out->frames.push_back(frame);
      truth_stamps.push_back(t);
    }
  }

  // TRUTH at every LASER and IMAGE stamp (once per distinct stamp).
  std::sort(truth_stamps.begin(), truth_stamps.end());
  for (size_t i = 0; i < truth_stamps.size(); ++i) {
    if (i > 0 && truth_stamps[i] - truth_stamps[i - 1] < 1e-9) continue;
    log.truth.push_back(
        Stamped(truth_stamps[i], SampleTruth(out->truth, dt, truth_stamps[i]).world_T_body));
  }

  // PARAMs.
  log.params["robot_name"] = spec.name;
  log.params["robot_kind"] = RobotKindName(spec.kind);
  // The platform's velocity response to a command, for the EKF's command model
  // (EkfStateUpdaterOptions::command_response_seconds); the others follow their commands.
  if (spec.kind == RobotKind::kUav) log.params["command_response_seconds"] = Fixed(kUavVelocityLagSeconds, 3);
  if (spec.camera.enabled) {
    log.params["camera_fx"] = Fixed(spec.camera.fx, 6);
    log.params["camera_fy"] = Fixed(spec.camera.fy, 6);
    log.params["camera_cx"] = Fixed(spec.camera.cx, 6);
    log.params["camera_cy"] = Fixed(spec.camera.cy, 6);
    log.params["camera_width"] = std::to_string(spec.camera.width);
    log.params["camera_height"] = std::to_string(spec.camera.height);
    log.params["laser_T_camera"] = FormatPoseParam(spec.camera.laser_T_camera);
  }
}

}  // namespace

bool TeamSimulatorOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(control_rate_hz > 0.0 && control_rate_hz <= 1000.0)) {
    why << "control rate must be in (0, 1000] Hz, got " << control_rate_hz;
  } else if (!(std::isfinite(max_duration_seconds) && max_duration_seconds >= 0.0)) {
    why << "max duration must be finite and >= 0, got " << max_duration_seconds;
  } else if (!(world_image_pixels_per_meter > 0.0 && world_image_pixels_per_meter <= 1000.0)) {
    why << "world image pixels per metre must be in (0, 1000], got "
        << world_image_pixels_per_meter;
  } else {
    std::string truth_error;
    if (!truth_layers.IsValid(&truth_error)) why << "truth layers: " << truth_error;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

namespace {

// Whether segments [a, b] and [c, d] share a point (touching counts).
bool SegmentsIntersect(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                       const Eigen::Vector2d& d) {
  const auto cross = [](const Eigen::Vector2d& u, const Eigen::Vector2d& v) { return u.x() * v.y() - u.y() * v.x(); };
  const double d1 = cross(b - a, c - a), d2 = cross(b - a, d - a);
  const double d3 = cross(d - c, a - c), d4 = cross(d - c, b - c);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  const auto on = [&](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r, double side) {
    return side == 0.0 && r.x() >= std::min(p.x(), q.x()) && r.x() <= std::max(p.x(), q.x()) &&
           r.y() >= std::min(p.y(), q.y()) && r.y() <= std::max(p.y(), q.y());
  };
  return on(a, b, c, d1) || on(a, b, d, d2) || on(c, d, a, d3) || on(c, d, b, d4);
}

// Whether segment [a, b] meets the convex polygon `footprint` (an edge crossed or inside).
bool SegmentMeetsPolygon(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                         const std::vector<Eigen::Vector2d>& footprint) {
  const size_t n = footprint.size();
  bool inside = n >= 3;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = footprint[i];
    const Eigen::Vector2d& q = footprint[(i + 1) % n];
    if (SegmentsIntersect(a, b, p, q)) return true;
    const Eigen::Vector2d e = q - p, r = a - p;
    if (e.x() * r.y() - e.y() * r.x() < 0) inside = false;  // counter-clockwise: inside is on the left
  }
  return inside;
}

std::string PointText(const Eigen::Vector2d& p) {
  std::ostringstream out;
  out << "(" << p.x() << ", " << p.y() << ")";
  return out.str();
}

}  // namespace

Status CheckRoutesClear(const Scenario& scenario, const World& world) {
  for (const RobotSpec& robot : scenario.robots) {
    const bool uav = robot.kind == RobotKind::kUav;
    double altitude = robot.altitude_meters;
    Eigen::Vector2d from = robot.InitialPose().translation();
    for (const RouteStep& step : robot.route) {
      if (step.type != RouteStep::Type::kWaypoint) continue;
      const double leg_altitude = uav && std::isfinite(step.altitude_meters) ? std::min(altitude, step.altitude_meters)
                                                                              : altitude;
      const auto blocked = [&](const std::string& what) {
        return Status::Error(scenario.source_name + ":" + std::to_string(step.source_line) + ": robot '" + robot.name +
                             "' would go from " + PointText(from) + " to " + PointText(step.target) + " through " +
                             what + " (the simulator has no collisions: add a waypoint around it)");
      };
      for (const WallSegment& wall : world.walls()) {
        if (uav && leg_altitude > world.wall_height_meters()) continue;
        if (SegmentsIntersect(from, step.target, wall.a, wall.b)) {
          return blocked("the wall of line " + std::to_string(wall.source_line));
        }
      }
      for (const Prism& prism : world.prisms()) {
        const bool in_the_way = uav ? prism.z_max_meters > leg_altitude - 0.2 : prism.z_min_meters < 0.3;
        if (in_the_way && SegmentMeetsPolygon(from, step.target, prism.footprint)) {
          return blocked("the furniture or obstacle of line " + std::to_string(prism.source_line));
        }
      }
      if (uav && std::isfinite(step.altitude_meters)) altitude = step.altitude_meters;
      from = step.target;
    }
  }
  return Status::Ok();
}

Status PlaceRandomObstacles(const Scenario& scenario, std::mt19937_64* rng, World* world) {
  CHECK(rng != nullptr);
  CHECK(world != nullptr);
  // The robots' planned legs (start, then every waypoint), kept clear.
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> legs;
  for (const RobotSpec& robot : scenario.robots) {
    Eigen::Vector2d from = robot.InitialPose().translation();
    legs.emplace_back(from, from);
    for (const RouteStep& step : robot.route) {
      if (step.type != RouteStep::Type::kWaypoint) continue;
      legs.emplace_back(from, step.target);
      from = step.target;
    }
  }
  auto distance_to_legs = [&](const Eigen::Vector2d& p) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& [a, b] : legs) {
      const Eigen::Vector2d ab = b - a;
      const double len2 = ab.squaredNorm();
      const double u = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
      best = std::min(best, (a + u * ab - p).norm());
    }
    return best;
  };
  for (const RandomObstacleSpec& spec : scenario.random_obstacles) {
    int placed = 0;
    for (int attempt = 0; attempt < 500 * spec.count && placed < spec.count; ++attempt) {
      const double cx = UniformIn(spec.region.min().x(), spec.region.max().x(), rng);
      const double cy = UniformIn(spec.region.min().y(), spec.region.max().y(), rng);
      const double w = UniformIn(0.15, 0.4, rng);
      const double h = UniformIn(0.15, 0.4, rng);
      const double yaw = UniformIn(0.0, M_PI, rng);
      const double height = UniformIn(0.05, spec.max_height_meters, rng);
      const Eigen::Vector2d center(cx, cy);
      const double radius = 0.5 * std::hypot(w, h);
      if (world->DistanceToNearestStructure(center) < radius + 0.1) continue;
      if (distance_to_legs(center) < radius + 0.45) continue;
      world->AddBoxPrism(center, Eigen::Vector2d(w, h), yaw, 0.0, height, Surface::kObstacle,
                         spec.source_line);
      ++placed;
    }
    if (placed < spec.count) {
      return Status::Error(scenario.source_name + ":" + std::to_string(spec.source_line) +
                           ": could place only " + std::to_string(placed) + " of " +
                           std::to_string(spec.count) +
                           " random obstacles clear of walls, furniture and robot routes");
    }
  }
  return Status::Ok();
}

LaserScan SimulateScan3D(const World& world, const LaserOptions& laser,
                         const Eigen::Isometry3d& world_T_laser, double stamp_seconds,
                         std::mt19937_64* rng, std::vector<Surface>* surfaces,
                         int* num_no_return, std::vector<RayHit>* returned) {
  CHECK(rng != nullptr);
  std::string why;
  CHECK(laser.IsValid(&why)) << why;
  LaserScan scan;
  scan.stamp_seconds = stamp_seconds;
  scan.angles_radians = laser.BeamAnglesRadians();
  scan.range_min_meters = 0.0;
  scan.range_max_meters = laser.max_range_meters;
  const size_t n = scan.angles_radians.size();
  std::vector<Eigen::Vector3d> directions(n);
  for (size_t i = 0; i < n; ++i) {
    directions[i] = world_T_laser.linear() * Eigen::Vector3d(std::cos(scan.angles_radians[i]),
                                                             std::sin(scan.angles_radians[i]), 0.0);
  }
  std::vector<RayHit> hits;
  world.CastRays3D(world_T_laser.translation(), directions, laser.max_range_meters, &hits);
  scan.ranges_meters.resize(n);
  if (surfaces != nullptr) surfaces->assign(n, Surface::kNone);
  if (returned != nullptr) returned->assign(n, RayHit());
  int no_return = 0;
  for (size_t i = 0; i < n; ++i) {
    // Both numbers are drawn for every beam, so the stream does not depend on the geometry.
    const double dropout_draw = Uniform01(rng);
    const double noise = laser.range_noise_std_meters * StandardGaussian(rng);
    double measured = laser.max_range_meters;
    if (hits[i].hit && dropout_draw >= laser.dropout_probability) {
      const double noisy = hits[i].range_meters + noise;
      if (scan.IsValidRange(noisy)) measured = noisy;
    }
    if (measured == laser.max_range_meters) {
      ++no_return;
    } else if (returned != nullptr) {
      (*returned)[i] = hits[i];
    }
    scan.ranges_meters[i] = measured;
    if (surfaces != nullptr) (*surfaces)[i] = hits[i].surface;
  }
  if (num_no_return != nullptr) *num_no_return = no_return;
  return scan;
}

Status SimulateTeam(const Scenario& scenario, const TeamSimulatorOptions& options,
                    std::mt19937_64* rng, TeamSimulationResult* result) {
  CHECK(rng != nullptr);
  CHECK(result != nullptr);
  *result = TeamSimulationResult();
  std::string why;
  if (!scenario.IsTeam()) {
    return Status::Error("scenario '" + scenario.source_name +
                         "' has no robot blocks (use Simulate for single-robot scenarios)");
  }
  if (!scenario.IsValid(&why)) {
    return Status::Error("invalid scenario '" + scenario.source_name + "': " + why);
  }
  if (!options.IsValid(&why)) return Status::Error("invalid team simulator options: " + why);
  result->world = scenario.world;
  HETSLAM_RETURN_IF_ERROR(CheckRoutesClear(scenario, result->world));
  HETSLAM_RETURN_IF_ERROR(PlaceRandomObstacles(scenario, rng, &result->world));
  double t_limit = scenario.duration_limit_seconds;
  if (options.max_duration_seconds > 0.0) t_limit = std::min(t_limit, options.max_duration_seconds);
  const double dt = 1.0 / options.control_rate_hz;
  for (const RobotSpec& spec : scenario.robots) {
    std::mt19937_64 sensor_rng((*rng)());
    RobotSimulation robot;
    robot.name = spec.name;
    robot.kind = spec.kind;
    robot.image_noise_seed = (*rng)();
    SimulateMotion(spec, dt, t_limit, &robot);
    DifferentiateTruth(dt, &robot.truth);
    SimulateSensors(scenario, result->world, spec, options.truth_layers, dt, &sensor_rng, &robot);
    robot.log.params["control_rate_hz"] = Fixed(options.control_rate_hz, 3);
    result->robots.push_back(std::move(robot));
  }
  return Status::Ok();
}

Status WriteTeamWorldImage(const std::string& path, const Scenario& scenario,
                           const TeamSimulationResult& result, double pixels_per_meter) {
  if (!(pixels_per_meter > 0.0 && pixels_per_meter <= 1000.0)) {
    return Status::Error(path + ": pixels per metre must be in (0, 1000]");
  }
  Eigen::AlignedBox2d bounds = result.world.Bounds();
  for (const RobotSimulation& robot : result.robots) {
    for (const TruthSample& s : robot.truth) bounds.extend(Eigen::Vector2d(s.position.head<2>()));
  }
  if (bounds.isEmpty()) return Status::Error(path + ": nothing to draw");
  constexpr double kMarginMeters = 1.0;
  const Eigen::Vector2d min_corner = bounds.min().array() - kMarginMeters;
  const Eigen::Vector2d extent = bounds.sizes().array() + 2.0 * kMarginMeters;
  const int cols = static_cast<int>(std::ceil(extent.x() * pixels_per_meter));
  const int rows = static_cast<int>(std::ceil(extent.y() * pixels_per_meter));
  if (static_cast<double>(cols) * rows > 1e8) return Status::Error(path + ": image too large");
  cv::Mat image(rows, cols, CV_8UC3, cv::Scalar(255, 255, 255));
  constexpr int kShift = 4;
  constexpr double kSub = 1 << kShift;
  auto to_pixel = [&](const Eigen::Vector2d& p) {
    return cv::Point(
        static_cast<int>(std::lround((p.x() - min_corner.x()) * pixels_per_meter * kSub)),
        static_cast<int>(
            std::lround((min_corner.y() + extent.y() - p.y()) * pixels_per_meter * kSub)));
  };
  auto to_plain_pixel = [&](const Eigen::Vector2d& p) {
    const cv::Point q = to_pixel(p);
    return cv::Point(q.x >> kShift, q.y >> kShift);
  };
  const cv::Scalar grid_color(235, 235, 235);
  for (double x = std::ceil(min_corner.x()); x <= min_corner.x() + extent.x(); x += 1.0) {
    cv::line(image, to_pixel({x, min_corner.y()}), to_pixel({x, min_corner.y() + extent.y()}),
             grid_color, 1, cv::LINE_8, kShift);
  }
  for (double y = std::ceil(min_corner.y()); y <= min_corner.y() + extent.y(); y += 1.0) {
    cv::line(image, to_pixel({min_corner.x(), y}), to_pixel({min_corner.x() + extent.x(), y}),
             grid_color, 1, cv::LINE_8, kShift);
  }
  // Prisms, lowest first so that a table top is drawn over its legs.
  std::vector<const Prism*> prisms;
  for (const Prism& prism : result.world.prisms()) prisms.push_back(&prism);
  std::stable_sort(prisms.begin(), prisms.end(), [](const Prism* a, const Prism* b) {
    return a->z_max_meters < b->z_max_meters;
  });
  for (const Prism* prism : prisms) {
    std::vector<cv::Point> polygon;
    for (const Eigen::Vector2d& p : prism->footprint) polygon.push_back(to_pixel(p));
    const bool obstacle = prism->surface == Surface::kObstacle;
    const cv::Scalar fill = obstacle ? cv::Scalar(60, 90, 160) : cv::Scalar(170, 205, 225);
    const cv::Scalar edge = obstacle ? cv::Scalar(30, 50, 100) : cv::Scalar(90, 130, 160);
    cv::fillConvexPoly(image, polygon, fill, cv::LINE_AA, kShift);
    cv::polylines(image, polygon, true, edge, 1, cv::LINE_AA, kShift);
  }
  for (const WallSegment& wall : result.world.walls()) {
    cv::line(image, to_pixel(wall.a), to_pixel(wall.b), cv::Scalar(0, 0, 0), 2, cv::LINE_AA,
             kShift);
  }
  for (const TagSpec& tag : scenario.tags) {
    const Eigen::Isometry3d world_T_tag = tag.WorldTTag();
    const Eigen::Vector2d x_axis = world_T_tag.linear().col(0).head<2>();
    const Eigen::Vector2d normal = world_T_tag.linear().col(2).head<2>();
    const Eigen::Vector2d c = tag.center.head<2>() + 0.05 * normal;
    const double half = 0.5 * std::max(tag.size_meters, 0.3);
    cv::line(image, to_pixel(c - half * x_axis), to_pixel(c + half * x_axis),
             cv::Scalar(0, 0, 230), 4, cv::LINE_AA, kShift);
    cv::putText(image, "tag " + std::to_string(tag.id), to_plain_pixel(c + 0.35 * normal),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 200), 1, cv::LINE_AA);
  }
  const cv::Scalar palette[] = {cv::Scalar(200, 80, 0), cv::Scalar(0, 150, 0),
                                cv::Scalar(180, 0, 180), cv::Scalar(0, 130, 255),
                                cv::Scalar(160, 160, 0), cv::Scalar(80, 80, 80)};
  const int dot_radius = static_cast<int>(std::max(3.0, 0.15 * pixels_per_meter) * kSub);
  for (size_t r = 0; r < result.robots.size(); ++r) {
    const RobotSimulation& robot = result.robots[r];
    const cv::Scalar color = palette[r % (sizeof(palette) / sizeof(palette[0]))];
    for (size_t i = 1; i < robot.truth.size(); ++i) {
      cv::line(image, to_pixel(robot.truth[i - 1].position.head<2>()),
               to_pixel(robot.truth[i].position.head<2>()), color, 2, cv::LINE_AA, kShift);
    }
    if (robot.truth.empty()) continue;
    const Eigen::Vector2d start = robot.truth.front().position.head<2>();
    cv::circle(image, to_pixel(start), dot_radius, color, 2, cv::LINE_AA, kShift);
    cv::putText(image, robot.name + " (" + RobotKindName(robot.kind) + ")",
                to_plain_pixel(start + Eigen::Vector2d(0.25, 0.25)), cv::FONT_HERSHEY_SIMPLEX,
                0.45, color, 1, cv::LINE_AA);
  }
  return WriteImageFile(path, image);
}

Status WriteTeamDataset(const std::string& directory, const Scenario& scenario,
                        const TeamSimulationResult& result, const TeamSimulatorOptions& options,
                        const std::vector<std::string>& comment_lines, TeamDatasetFiles* files) {
  CHECK(files != nullptr);
  *files = TeamDatasetFiles();
  namespace fs = std::filesystem;
  const fs::path root(directory);
  std::error_code ec;
  fs::create_directories(root, ec);
  if (ec) return Status::Error("cannot create '" + directory + "': " + ec.message());

  TeamManifest manifest;
  for (const RobotSimulation& robot : result.robots) {
    TeamRobot entry;
    entry.name = robot.name;
    entry.kind = RobotKindName(robot.kind);
    entry.directory = robot.name;
    manifest.robots.push_back(entry);
  }
  for (const TagSpec& tag : scenario.tags) {
    TagTruth truth;
    truth.id = tag.id;
    truth.family = "tag36h11";
    truth.size_meters = tag.size_meters;
    truth.world_T_tag = tag.WorldTTag();
    manifest.tags.push_back(truth);
  }
  std::vector<std::string> manifest_comments = {
      "hetslam simulated team: scenario " + scenario.source_name,
      "each robot's log starts in its own frame; TRUTH and tag lines are in the world frame"};
  manifest_comments.insert(manifest_comments.end(), comment_lines.begin(), comment_lines.end());
  files->manifest_path = (root / "team.txt").string();
  HETSLAM_RETURN_IF_ERROR(WriteTeamManifest(files->manifest_path, manifest, manifest_comments));

  for (size_t r = 0; r < result.robots.size(); ++r) {
    const RobotSimulation& robot = result.robots[r];
    const RobotSpec& spec = scenario.robots[r];
    const fs::path robot_dir = root / robot.name;
    fs::create_directories(robot_dir / "images", ec);
    if (ec) return Status::Error("cannot create '" + robot_dir.string() + "': " + ec.message());
    const LaserOptions& laser = spec.laser;
    std::vector<std::string> comments = {
        "hetslam simulated " + std::string(RobotKindName(robot.kind)) + " '" + robot.name +
            "': scenario " + scenario.source_name,
        "laser: " + Fixed(laser.field_of_view_radians * kRadToDeg, 3) + " deg fov, " +
            std::to_string(laser.num_beams) + " beams, " + Fixed(laser.max_range_meters, 3) +
            " m max range, range noise std " + Fixed(laser.range_noise_std_meters, 4) +
            " m, dropout " + Fixed(laser.dropout_probability, 4) + ", " +
            Fixed(laser.rate_hz, 3) + " Hz; no return = max range",
        "marg: " + Fixed(spec.marg.rate_hz, 3) + " Hz, gyro noise " +
            Fixed(spec.marg.gyro_noise_radps * kRadToDeg, 4) + " deg/s, gyro bias std " +
            Fixed(spec.marg.gyro_bias_radps * kRadToDeg, 4) + " deg/s, accel noise " +
            Fixed(spec.marg.accel_noise_mps2, 4) + " m/s^2, magnetometer noise " +
            Fixed(spec.marg.mag_noise_microtesla, 3) + " uT",
        std::string("TRUTH is world_T_body (evaluation only); ") +
            (robot.kind == RobotKind::kWheeled ? "ODOM starts at the robot's start pose"
                                               : "no wheel odometry")};
    comments.insert(comments.end(), comment_lines.begin(), comment_lines.end());
    const std::string log_path = (robot_dir / "log.txt").string();
    HETSLAM_RETURN_IF_ERROR(WriteRobotLog(log_path, robot.log, comments));
    files->robot_log_paths.push_back(log_path);

    if (!options.render_images || robot.frames.empty()) continue;
    const TagCamera camera(TagCameraOptionsFor(spec.camera));
    std::vector<SimulatedTag> all_tags;
    for (const TagSpec& tag : scenario.tags) all_tags.push_back(ToSimulatedTag(tag));
    std::mt19937_64 noise_rng(robot.image_noise_seed);
    const std::vector<int> png_params = {cv::IMWRITE_PNG_COMPRESSION, 1};
    for (const CameraFrame& frame : robot.frames) {
      std::vector<SimulatedTag> visible;
      for (int index : frame.visible_tags) visible.push_back(all_tags[index]);
      const cv::Mat image = camera.Render(visible, frame.world_T_camera, &noise_rng);
      const std::string image_path = (robot_dir / frame.relative_path).string();
      HETSLAM_RETURN_IF_ERROR(WriteImageFile(image_path, image, png_params));
      ++files->images_written;
    }
  }
  TruthLayerMaps truth_layers;
  HETSLAM_RETURN_IF_ERROR(RasterizeTruthLayers(result.world, options.truth_layers, &truth_layers));
  files->truth_layers_directory = (root / kTruthLayersFolder).string();
  HETSLAM_RETURN_IF_ERROR(WriteTruthLayers(files->truth_layers_directory, truth_layers,
                                           options.truth_layers, &files->truth_layer_paths));
  for (const RobotSimulation& robot : result.robots) {
    HETSLAM_RETURN_IF_ERROR(WriteTruthLayers((root / robot.name / kSeenLayersFolder).string(),
                                             SeenTruthLayers(truth_layers, robot.seen),
                                             options.truth_layers, nullptr, robot.name));
  }

  files->world_image_path = (root / "world.png").string();
  return WriteTeamWorldImage(files->world_image_path, scenario, result,
                             options.world_image_pixels_per_meter);
}

}  // namespace sim
}  // namespace hetslam
