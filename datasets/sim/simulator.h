// A wheeled robot driving a scenario's waypoint route in a 2D world, with a simulated 2D laser,
// wheel odometry and ground truth.
//
// Time and frames: the world frame of the scenario; the robot body frame has x forward, y left;
// the laser sits on the body origin looking along x (robot_T_sensor = identity). Time starts
// at `SimulatorOptions::start_stamp_seconds`; laser scans are taken at start + k / laser rate,
// odometry samples at start + k / odometry rate, controller updates at start + k / control
// rate (k = 0, 1, ...). Between events the robot moves on an exact unicycle arc with the last
// command held. A scan is instantaneous (no motion distortion within a sweep).
//
// Controller (smooth unicycle, per control update): with e the heading error towards the
// current waypoint (wrapped to [-pi, pi)),
//   yaw_rate_cmd = clamp(heading_gain * e, +-max_turn_rate)
//   speed_cmd    = max_speed * max(0, cos e)^2   (slow in turns, turn on the spot when e > 90°)
//                  and, for the last waypoint, <= sqrt(2 * max_acceleration * distance)
// both changed by at most the acceleration limits per update. A waypoint counts as reached
// within `waypoint_reached_radius_meters` (the last one within `goal_reached_radius_meters`);
// the run ends when the robot has reached the last waypoint and stopped, or at the scenario's
// duration limit (then `completed` is false).
//
// Laser: per beam, the exact ray cast against the walls (World::CastRays) plus N(0, sigma^2)
// range noise; no wall within max range, a dropout (probability p, independent per beam) or a
// noisy range outside (range_min, range_max) is written as range = max range ("no return",
// invalid for every reader of the log).
//
// Odometry: see OdometryOptions in robot_spec.h (noisy increments, chained). It is integrated at
// every odometry sample and every scan, so each FLASER line carries the odometry pose at its
// own time; ODOM lines are written at the odometry rate.
//
// Randomness: every random number is drawn from the caller's std::mt19937_64, in a fixed order
// (its raw output is mapped to uniform/Gaussian numbers here, not by <random> distributions,
// so the stream is the same with every standard library): the same seed gives the same log,
// byte for byte.
#ifndef HETSLAM_DATASETS_SIM_SIMULATOR_H_
#define HETSLAM_DATASETS_SIM_SIMULATOR_H_

#include <random>
#include <string>
#include <vector>

#include "core/carmen_log.h"
#include "core/se2.h"
#include "core/status.h"
#include "core/trajectory_io.h"
#include "datasets/sim/scenario.h"
#include "opencv2/core.hpp"

namespace hetslam {
namespace sim {

struct SimulatorOptions {
  double start_stamp_seconds = 0.0;           // time stamp of the first scan
  double control_rate_hz = 50.0;              // controller updates (and commands recorded)
  double heading_gain_per_second = 1.5;       // yaw_rate_cmd = gain * heading error
  double max_acceleration_mps2 = 0.5;         // limit on the change of the speed command
  double max_yaw_acceleration_radps2 = 2.0;   // limit on the change of the yaw-rate command
  double waypoint_reached_radius_meters = 0.35;
  double goal_reached_radius_meters = 0.1;    // for the last waypoint
  double stopped_speed_mps = 0.01;            // the run ends at the goal below this speed

  // Checks all values finite and positive (start stamp: finite, >= 0), rates <= 1000 Hz and
  // goal radius <= waypoint radius.
  bool IsValid(std::string* error) const;
};

// A body-frame velocity command, as recorded by the controller at the control rate.
struct StampedCommand {
  double stamp_seconds = 0.0;
  double forward_velocity_mps = 0.0;  // vx, body frame
  double yaw_rate_radps = 0.0;        // about z, counter-clockwise positive
};

struct SimulationResult {
  // FLASER readings (ranges, odometry pose at the scan; scan.range_max_meters = laser max
  // range; no-return beams hold that max range) and ODOM readings (odometry rate).
  CarmenLog log;
  // world_T_robot at every scan, same time stamps and order as log.lasers.
  std::vector<StampedPose2> truth;
  // world_T_robot at every controller update (dense, for plots and path length).
  std::vector<StampedPose2> truth_dense;
  std::vector<StampedCommand> commands;
  int waypoints_reached = 0;        // of scenario.waypoints.size() (an implied start counts)
  bool completed = false;           // reached the last waypoint before the duration limit
  double duration_seconds = 0.0;    // last scan time - first scan time
  double path_length_meters = 0.0;  // true distance travelled
  int num_scans = 0;
  int num_no_return_beams = 0;      // beams written as max range (no wall in range or dropout)
};

// Runs the scenario. Errors (invalid scenario or options) are returned; an unfinished route
// is not an error (see `completed`). `rng` must be seeded by the caller.
Status Simulate(const Scenario& scenario, const SimulatorOptions& options, std::mt19937_64* rng,
                SimulationResult* result);

// One scan of `world` from world_T_sensor with the given laser, with noise and dropouts drawn
// from `rng` (noise-free when range_noise_std_meters and dropout_probability are 0). Beam
// angles follow LaserOptions::BeamAnglesRadians(); range_max_meters = laser max range.
LaserScan SimulateScan(const World& world, const LaserOptions& laser, const Pose2& world_T_sensor,
                       double stamp_seconds, std::mt19937_64* rng, int* num_no_return = nullptr);

// One noisy odometry increment (see OdometryOptions in robot_spec.h): the true planar motion from
// `previous_truth` to `truth` (both world_T_robot), corrupted with two Gaussian draws from
// `rng`, chained onto `odom`. Returns the new odometry pose.
Pose2 StepOdometry(const OdometryOptions& options, const Pose2& previous_truth,
                   const Pose2& truth, const Pose2& odom, std::mt19937_64* rng);

// Draws a picture of the world: walls (black), waypoints (red dots), the true trajectory
// (blue) and, if not empty, the odometry trajectory (orange), north up, at
// `pixels_per_meter`, with a 1 m grid. Writes it with cv::imwrite (format from the extension).
Status WriteWorldImage(const std::string& path, const Scenario& scenario,
                       const std::vector<StampedPose2>& truth,
                       const std::vector<StampedPose2>& odometry, double pixels_per_meter = 25.0);

// cv::imwrite with errors (a false return or an OpenCV exception) as a Status naming the file.
Status WriteImageFile(const std::string& path, const cv::Mat& image, const std::vector<int>& params = {});

// The files WriteSimulationOutputs writes into a directory.
struct SimulationFiles {
  std::string log_path;       // <dir>/log.clf      CARMEN log (FLASER + ODOM)
  std::string truth_path;     // <dir>/truth.txt    timestamp x y theta at every scan
  std::string commands_path;  // <dir>/commands.txt timestamp vx_mps yaw_rate_radps
  std::string image_path;     // <dir>/world.png    world, truth (and odometry) trajectories
};

// Writes the four files above into `directory` (which must exist); `comment_lines` go at the
// top of the log (e.g. scenario and seed), after a description of the simulated sensors.
Status WriteSimulationOutputs(const std::string& directory, const Scenario& scenario,
                              const SimulationResult& result,
                              const std::vector<std::string>& comment_lines,
                              SimulationFiles* files);

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_SIMULATOR_H_
