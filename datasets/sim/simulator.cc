#include "datasets/sim/simulator.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "core/file_io.h"
#include "datasets/sim/sim_random.h"
#include "datasets/sim/sim_text.h"
#include "glog/logging.h"
#include "opencv2/core.hpp"
#include "opencv2/imgcodecs.hpp"
#include "opencv2/imgproc.hpp"

namespace hetslam {
namespace sim {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// Moves `pose` for `dt` seconds at body-frame speed v and yaw rate w (exact unicycle arc).
Pose2 IntegrateUnicycle(const Pose2& pose, double v, double w, double dt) {
  const double theta = pose.theta();
  if (std::abs(w) < 1e-9) {
    return Pose2(pose.x() + v * dt * std::cos(theta), pose.y() + v * dt * std::sin(theta),
                 theta + w * dt);
  }
  const double theta_end = theta + w * dt;
  const double radius = v / w;
  return Pose2(pose.x() + radius * (std::sin(theta_end) - std::sin(theta)),
               pose.y() - radius * (std::cos(theta_end) - std::cos(theta)), theta_end);
}

double MoveTowards(double current, double target, double max_step) {
  return current + std::clamp(target - current, -max_step, max_step);
}

}  // namespace

Pose2 StepOdometry(const OdometryOptions& options, const Pose2& previous_truth,
                   const Pose2& truth, const Pose2& odom, std::mt19937_64* rng) {
  // The increment in the body frame at the previous sample, computed from differences so
  // that no motion gives exactly zero (Between() would leave ~1e-16 rounding, and the
  // square-root noise model would turn that into ~1e-10 m of spurious noise).
  const Eigen::Vector2d step_body =
      previous_truth.rotation().transpose() * (truth.translation() - previous_truth.translation());
  const double step_theta = WrapAngle(truth.theta() - previous_truth.theta());
  const double distance = step_body.norm();
  const double trans_std = options.trans_noise_meters_per_sqrt_meter * std::sqrt(distance);
  const double rot_std = std::sqrt(
      options.rot_noise_radians_per_sqrt_meter * options.rot_noise_radians_per_sqrt_meter *
          distance +
      options.rot_noise_radians_per_sqrt_radian * options.rot_noise_radians_per_sqrt_radian *
          std::abs(step_theta));
  const double n_t = trans_std * StandardGaussian(rng);
  const double n_r = rot_std * StandardGaussian(rng);
  return odom * Pose2(step_body.x() + n_t, step_body.y(), step_theta + n_r);
}

bool SimulatorOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  // At most 1e10 s (year 2286 as a Unix time): beyond, t0 + k / rate rounds to t0 and the
  // simulated clock would stand still.
  if (!(std::isfinite(start_stamp_seconds) && start_stamp_seconds >= 0.0 && start_stamp_seconds <= 1e10)) {
    why << "start stamp must be in [0, 1e10] s, got " << start_stamp_seconds;
  } else if (!(positive(control_rate_hz) && control_rate_hz <= 1000.0)) {
    why << "control rate must be in (0, 1000] Hz, got " << control_rate_hz;
  } else if (!positive(heading_gain_per_second)) {
    why << "heading gain must be positive, got " << heading_gain_per_second;
  } else if (!positive(max_acceleration_mps2)) {
    why << "max acceleration must be positive, got " << max_acceleration_mps2;
  } else if (!positive(max_yaw_acceleration_radps2)) {
    why << "max yaw acceleration must be positive, got " << max_yaw_acceleration_radps2;
  } else if (!positive(waypoint_reached_radius_meters)) {
    why << "waypoint radius must be positive, got " << waypoint_reached_radius_meters;
  } else if (!(positive(goal_reached_radius_meters) &&
               goal_reached_radius_meters <= waypoint_reached_radius_meters)) {
    why << "goal radius must be positive and <= the waypoint radius, got "
        << goal_reached_radius_meters;
  } else if (!positive(stopped_speed_mps)) {
    why << "stopped speed must be positive, got " << stopped_speed_mps;
  }
  if (why.str().empty()) return true;
  if (error != nullptr) *error = why.str();
  return false;
}

LaserScan SimulateScan(const World& world, const LaserOptions& laser, const Pose2& world_T_sensor,
                       double stamp_seconds, std::mt19937_64* rng, int* num_no_return) {
  CHECK(rng != nullptr);
  std::string why;
  CHECK(laser.IsValid(&why)) << why;
  LaserScan scan;
  scan.stamp_seconds = stamp_seconds;
  scan.angles_radians = laser.BeamAnglesRadians();
  scan.range_min_meters = 0.0;
  scan.range_max_meters = laser.max_range_meters;
  scan.ranges_meters.resize(scan.angles_radians.size());
  std::vector<double> world_angles(scan.angles_radians.size());
  for (size_t i = 0; i < world_angles.size(); ++i) {
    world_angles[i] = world_T_sensor.theta() + scan.angles_radians[i];
  }
  std::vector<double> exact_ranges;
  world.CastRays(world_T_sensor.translation(), world_angles, laser.max_range_meters,
                 &exact_ranges);
  int no_return = 0;
  for (size_t i = 0; i < scan.angles_radians.size(); ++i) {
    // Both numbers are drawn for every beam, hit or not, so the random stream does not depend
    // on the geometry.
    const double dropout_draw = Uniform01(rng);
    const double noise = laser.range_noise_std_meters * StandardGaussian(rng);
    const double range = exact_ranges[i];
    const bool hit = std::isfinite(range);
    double measured = laser.max_range_meters;
    if (hit && dropout_draw >= laser.dropout_probability) {
      const double noisy = range + noise;
      if (scan.IsValidRange(noisy)) measured = noisy;
    }
    if (measured == laser.max_range_meters) ++no_return;
    scan.ranges_meters[i] = measured;
  }
  if (num_no_return != nullptr) *num_no_return = no_return;
  return scan;
}

Status Simulate(const Scenario& scenario, const SimulatorOptions& options, std::mt19937_64* rng,
                SimulationResult* result) {
  CHECK(rng != nullptr);
  CHECK(result != nullptr);
  *result = SimulationResult();
  std::string why;
  if (!scenario.IsValid(&why)) {
    return Status::Error("invalid scenario '" + scenario.source_name + "': " + why);
  }
  if (!options.IsValid(&why)) return Status::Error("invalid simulator options: " + why);

  const std::vector<Eigen::Vector2d>& waypoints = scenario.waypoints;
  const int num_waypoints = static_cast<int>(waypoints.size());
  const RobotOptions& robot = scenario.robot;
  const double t0 = options.start_stamp_seconds;
  const double t_end = t0 + scenario.duration_limit_seconds;
  const double control_dt = 1.0 / options.control_rate_hz;

  Pose2 truth = scenario.InitialPose();
  Pose2 odom = truth;            // the odometry frame is the world frame at the start
  Pose2 truth_at_last_odom = truth;
  double v = 0.0, w = 0.0;       // command in force (body frame)
  int target = scenario.FirstWaypointToReach();
  result->waypoints_reached = target;

  long long k_scan = 0, k_odom = 0, k_control = 0;  // event counters: t_k = t0 + k / rate
  double t = t0;
  while (true) {
    const double t_scan = t0 + k_scan / scenario.laser.rate_hz;
    const double t_odom = t0 + k_odom / scenario.odometry.rate_hz;
    const double t_control = t0 + k_control / options.control_rate_hz;
    const double t_next = std::min({t_scan, t_odom, t_control});
    if (t_next > t_end + 1e-9) break;  // duration limit

    const double dt = t_next - t;
    truth = IntegrateUnicycle(truth, v, w, dt);
    result->path_length_meters += std::abs(v) * dt;
    t = t_next;

    // Events at the same time in a fixed order: odometry, scan, control (a new command takes
    // effect after the sensors have sampled).
    if (t_odom == t_next) {
      odom = StepOdometry(scenario.odometry, truth_at_last_odom, truth, odom, rng);
      truth_at_last_odom = truth;
      OdometryReading reading;
      reading.stamp_seconds = t;
      reading.pose = odom;
      result->log.odometry.push_back(reading);
      ++k_odom;
    }
    if (t_scan == t_next) {
      odom = StepOdometry(scenario.odometry, truth_at_last_odom, truth, odom, rng);
      truth_at_last_odom = truth;
      LaserReading reading;
      int no_return = 0;
      reading.scan = SimulateScan(scenario.world, scenario.laser, truth, t, rng, &no_return);
      reading.odometry_pose = odom;
      reading.has_odometry_pose = true;
      result->log.lasers.push_back(std::move(reading));
      result->truth.push_back({t, truth});
      result->num_no_return_beams += no_return;
      ++k_scan;
    }
    if (t_control == t_next) {
      ++k_control;
      result->truth_dense.push_back({t, truth});
      // Advance past every waypoint already within reach.
      while (target < num_waypoints) {
        const double radius = target == num_waypoints - 1 ? options.goal_reached_radius_meters
                                                          : options.waypoint_reached_radius_meters;
        if ((waypoints[target] - truth.translation()).norm() >= radius) break;
        ++target;
        ++result->waypoints_reached;
      }
      if (target == num_waypoints && std::abs(v) < options.stopped_speed_mps) {
        result->completed = true;
        break;
      }
      double v_desired = 0.0, w_desired = 0.0;
      if (target < num_waypoints) {
        const Eigen::Vector2d to_goal = waypoints[target] - truth.translation();
        const double heading_error =
            WrapAngle(std::atan2(to_goal.y(), to_goal.x()) - truth.theta());
        w_desired = std::clamp(options.heading_gain_per_second * heading_error,
                               -robot.max_turn_rate_radps, robot.max_turn_rate_radps);
        const double alignment = std::max(0.0, std::cos(heading_error));
        v_desired = robot.max_speed_mps * alignment * alignment;
        if (target == num_waypoints - 1) {
          // Brake so as to stop at the goal.
          v_desired = std::min(
              v_desired, std::sqrt(2.0 * options.max_acceleration_mps2 * to_goal.norm()));
        }
      }
      v = MoveTowards(v, v_desired, options.max_acceleration_mps2 * control_dt);
      w = MoveTowards(w, w_desired, options.max_yaw_acceleration_radps2 * control_dt);
      if (target == num_waypoints && std::abs(v) < options.stopped_speed_mps) {
        v = 0.0;
        w = 0.0;
      }
      result->commands.push_back({t, v, w});
    }
  }
  result->num_scans = static_cast<int>(result->truth.size());
  if (!result->truth.empty()) {
    result->duration_seconds = result->truth.back().stamp_seconds - result->truth.front().stamp_seconds;
  }
  return Status::Ok();
}

Status WriteWorldImage(const std::string& path, const Scenario& scenario,
                       const std::vector<StampedPose2>& truth,
                       const std::vector<StampedPose2>& odometry, double pixels_per_meter) {
  if (!(pixels_per_meter > 0.0 && pixels_per_meter <= 1000.0)) {
    return Status::Error(path + ": pixels per metre must be in (0, 1000], got " +
                         std::to_string(pixels_per_meter));
  }
  Eigen::AlignedBox2d bounds = scenario.world.Bounds();
  for (const StampedPose2& p : truth) bounds.extend(p.pose.translation());
  for (const StampedPose2& p : odometry) bounds.extend(p.pose.translation());
  for (const Eigen::Vector2d& w : scenario.waypoints) bounds.extend(w);
  if (bounds.isEmpty()) return Status::Error(path + ": nothing to draw");
  constexpr double kMarginMeters = 1.0;
  const Eigen::Vector2d min_corner = bounds.min().array() - kMarginMeters;
  const Eigen::Vector2d extent = bounds.sizes().array() + 2.0 * kMarginMeters;
  // Sizes in doubles before any int cast (a long wall used to overflow the cast and slip past
  // the limit into a cv::Exception); each side at most 32767 pixels, so that the drawing's
  // 4-bit sub-pixel coordinates stay in int.
  const double cols_wanted = std::ceil(extent.x() * pixels_per_meter);
  const double rows_wanted = std::ceil(extent.y() * pixels_per_meter);
  if (!(cols_wanted * rows_wanted <= 1e8 && cols_wanted <= 32767 && rows_wanted <= 32767)) {
    std::ostringstream message;
    message << path << ": image of " << cols_wanted << " x " << rows_wanted
            << " pixels is too large (at most 32767 a side, 1e8 in all): the world spans " << extent.x() << " x "
            << extent.y() << " m";
    return Status::Error(message.str());
  }
  const int cols = static_cast<int>(cols_wanted);
  const int rows = static_cast<int>(rows_wanted);
  cv::Mat image(rows, cols, CV_8UC3, cv::Scalar(255, 255, 255));
  // North up: row grows as y falls. Points carry 4 fractional bits (shift) for smooth lines.
  constexpr int kShift = 4;
  constexpr double kSub = 1 << kShift;
  auto to_pixel = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(std::lround((p.x() - min_corner.x()) * pixels_per_meter * kSub)),
                     static_cast<int>(std::lround((min_corner.y() + extent.y() - p.y()) *
                                                  pixels_per_meter * kSub)));
  };
  // 1 m grid.
  const cv::Scalar grid_color(235, 235, 235);
  for (double x = std::ceil(min_corner.x()); x <= min_corner.x() + extent.x(); x += 1.0) {
    cv::line(image, to_pixel({x, min_corner.y()}), to_pixel({x, min_corner.y() + extent.y()}),
             grid_color, 1, cv::LINE_8, kShift);
  }
  for (double y = std::ceil(min_corner.y()); y <= min_corner.y() + extent.y(); y += 1.0) {
    cv::line(image, to_pixel({min_corner.x(), y}), to_pixel({min_corner.x() + extent.x(), y}),
             grid_color, 1, cv::LINE_8, kShift);
  }
  for (const WallSegment& wall : scenario.world.walls()) {
    cv::line(image, to_pixel(wall.a), to_pixel(wall.b), cv::Scalar(0, 0, 0), 2, cv::LINE_AA,
             kShift);
  }
  auto draw_path = [&](const std::vector<StampedPose2>& path, const cv::Scalar& color) {
    for (size_t i = 1; i < path.size(); ++i) {
      cv::line(image, to_pixel(path[i - 1].pose.translation()),
               to_pixel(path[i].pose.translation()), color, 2, cv::LINE_AA, kShift);
    }
  };
  draw_path(odometry, cv::Scalar(0, 140, 255));  // BGR: orange
  draw_path(truth, cv::Scalar(200, 80, 0));      // blue
  const int dot_radius = static_cast<int>(std::max(2.0, 0.12 * pixels_per_meter) * kSub);
  for (const Eigen::Vector2d& w : scenario.waypoints) {
    cv::circle(image, to_pixel(w), dot_radius, cv::Scalar(0, 0, 220), cv::FILLED, cv::LINE_AA,
               kShift);
  }
  if (!truth.empty()) {
    cv::circle(image, to_pixel(truth.front().pose.translation()), 2 * dot_radius,
               cv::Scalar(0, 170, 0), 2, cv::LINE_AA, kShift);
  }
  return WriteImageFile(path, image);
}

Status WriteImageFile(const std::string& path, const cv::Mat& image, const std::vector<int>& params) {
  // Encoded in memory, then written through a temporary file (core/file_io.h): a failed write
  // leaves no truncated image.
  std::vector<uchar> bytes;
  const size_t dot = path.rfind('.');
  const std::string extension = dot == std::string::npos ? ".png" : path.substr(dot);
  try {
    if (!cv::imencode(extension, image, bytes, params)) return Status::Error(path + ": cannot encode image");
  } catch (const cv::Exception& e) {
    return Status::Error(path + ": cannot encode image: " + e.what());
  }
  return WriteFileBytes(path, bytes.data(), bytes.size());
}

Status WriteSimulationOutputs(const std::string& directory, const Scenario& scenario,
                              const SimulationResult& result,
                              const std::vector<std::string>& comment_lines,
                              SimulationFiles* files) {
  CHECK(files != nullptr);
  const std::string prefix = directory.empty() || directory.back() == '/' ? directory
                                                                         : directory + "/";
  files->log_path = prefix + "log.clf";
  files->truth_path = prefix + "truth.txt";
  files->commands_path = prefix + "commands.txt";
  files->image_path = prefix + "world.png";

  const LaserOptions& laser = scenario.laser;
  const OdometryOptions& odometry = scenario.odometry;
  std::vector<std::string> comments = {
      "hetslam simulated log: scenario " + scenario.source_name,
      "laser: " + Fixed(laser.field_of_view_radians * kRadToDeg, 3) + " deg fov, " +
          std::to_string(laser.num_beams) + " beams, " + Fixed(laser.max_range_meters, 3) +
          " m max range, range noise std " + Fixed(laser.range_noise_std_meters, 4) +
          " m, dropout " + Fixed(laser.dropout_probability, 4) + ", " + Fixed(laser.rate_hz, 3) +
          " Hz; no return = max range",
      "odometry: " + Fixed(odometry.rate_hz, 3) + " Hz, noise " +
          Fixed(odometry.trans_noise_meters_per_sqrt_meter, 4) + " m/sqrt(m), " +
          Fixed(odometry.rot_noise_radians_per_sqrt_meter * kRadToDeg, 4) + " deg/sqrt(m), " +
          Fixed(odometry.rot_noise_radians_per_sqrt_radian * std::sqrt(kRadToDeg), 4) +
          " deg/sqrt(deg); starts at the true initial pose",
      "ground truth is in truth.txt (not in this file); FLASER poses are odometry"};
  comments.insert(comments.end(), comment_lines.begin(), comment_lines.end());
  HETSLAM_RETURN_IF_ERROR(WriteCarmenLog(files->log_path, result.log, comments));
  HETSLAM_RETURN_IF_ERROR(WriteTrajectory(files->truth_path, result.truth));

  FILE* file = std::fopen(files->commands_path.c_str(), "w");
  if (file == nullptr) {
    return Status::Error("cannot open '" + files->commands_path +
                         "' for writing: " + std::strerror(errno));
  }
  std::fprintf(file, "# timestamp vx_mps yaw_rate_radps (body-frame commands)\n");
  for (const StampedCommand& c : result.commands) {
    std::fprintf(file, "%.6f %.9f %.9f\n", c.stamp_seconds, c.forward_velocity_mps,
                 c.yaw_rate_radps);
  }
  HETSLAM_RETURN_IF_ERROR(CloseWrittenFile(file, files->commands_path));

  std::vector<StampedPose2> odometry_path;
  odometry_path.reserve(result.log.odometry.size());
  for (const OdometryReading& o : result.log.odometry) {
    odometry_path.push_back({o.stamp_seconds, o.pose});
  }
  return WriteWorldImage(files->image_path, scenario, result.truth_dense, odometry_path);
}

}  // namespace sim
}  // namespace hetslam
