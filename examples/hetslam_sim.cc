// hetslam_sim: simulates a wheeled robot with a 2D laser and wheel odometry driving a
// scenario's waypoint route, and writes a dataset with ground truth.
//
//   hetslam_sim --out=/tmp/sim --seed=7
//   hetslam_sim --scenario=my_floor.scenario --out=/tmp/my_floor --seed=1
//
// Writes DIR/log.clf (CARMEN FLASER + ODOM), DIR/truth.txt (timestamp x y theta at every
// scan), DIR/commands.txt (body-frame velocity commands) and DIR/world.png, then prints a
// summary. The same --scenario and --seed always give the same files, byte for byte.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <system_error>

#include "datasets/sim/simulator.h"
#include "datasets/sim/world.h"
#include "gflags/gflags.h"
#include "glog/logging.h"

#ifndef HETSLAM_DEFAULT_SCENARIO
#define HETSLAM_DEFAULT_SCENARIO "datasets/scenarios/office_loop.scenario"
#endif

DEFINE_string(scenario, HETSLAM_DEFAULT_SCENARIO,
              "Scenario file (walls, boxes, waypoints, robot, laser and odometry settings; format "
              "in datasets/README.md). Default: the shipped office loop.");
DEFINE_string(out, "", "Output folder, created if missing. Receives log.clf, truth.txt, "
              "commands.txt and world.png. Required.");
DEFINE_uint64(seed, 1, "Seed of the one std::mt19937_64 behind every random number (laser noise, "
              "dropouts, odometry noise). Same seed, same bytes.");
DEFINE_double(start_stamp, 0.0, "Time stamp of the first scan, seconds (>= 0).");
DEFINE_double(control_rate_hz, 50.0, "Controller update rate, Hz (commands are recorded at this rate).");
DEFINE_double(waypoint_radius, 0.35, "A waypoint counts as reached within this distance, metres.");
DEFINE_double(goal_radius, 0.1, "The last waypoint counts as reached within this distance, metres.");
DEFINE_bool(allow_incomplete, false, "Exit with status 0 even when the robot did not reach its last "
            "waypoint before the scenario's duration limit (the files are written either way).");

namespace hetslam {
namespace {

bool OptionsFromFlags(sim::SimulatorOptions* options, std::string* error) {
  if (FLAGS_out.empty()) {
    *error = "--out is required (an output folder)";
    return false;
  }
  if (FLAGS_scenario.empty()) {
    *error = "--scenario must name a scenario file";
    return false;
  }
  options->start_stamp_seconds = FLAGS_start_stamp;
  options->control_rate_hz = FLAGS_control_rate_hz;
  options->waypoint_reached_radius_meters = FLAGS_waypoint_radius;
  options->goal_reached_radius_meters = FLAGS_goal_radius;
  std::string why;
  if (!options->IsValid(&why)) {
    *error = "bad flag value: " + why;
    return false;
  }
  return true;
}

int Run() {
  sim::SimulatorOptions options;
  std::string error;
  if (!OptionsFromFlags(&options, &error)) {
    std::cerr << "hetslam_sim: " << error << " (see --help)\n";
    return 2;
  }
  sim::Scenario scenario;
  Status status = sim::ReadScenarioFile(FLAGS_scenario, &scenario);
  if (!status.ok()) {
    std::cerr << "hetslam_sim: " << status.message() << "\n";
    return 1;
  }
  std::error_code ec;
  std::filesystem::create_directories(FLAGS_out, ec);
  if (ec) {
    std::cerr << "hetslam_sim: cannot create output folder '" << FLAGS_out
              << "': " << ec.message() << "\n";
    return 1;
  }

  std::mt19937_64 rng(FLAGS_seed);
  sim::SimulationResult result;
  status = sim::Simulate(scenario, options, &rng, &result);
  if (!status.ok()) {
    std::cerr << "hetslam_sim: " << status.message() << "\n";
    return 1;
  }
  sim::SimulationFiles files;
  status = sim::WriteSimulationOutputs(FLAGS_out, scenario, result,
                                       {"seed " + std::to_string(FLAGS_seed)}, &files);
  if (!status.ok()) {
    std::cerr << "hetslam_sim: " << status.message() << "\n";
    return 1;
  }

  std::cout << "wrote " << files.log_path << " (" << result.log.lasers.size() << " FLASER, "
            << result.log.odometry.size() << " ODOM)\n"
            << "wrote " << files.truth_path << " (" << result.truth.size() << " poses)\n"
            << "wrote " << files.commands_path << " (" << result.commands.size()
            << " commands)\n"
            << "wrote " << files.image_path << "\n";

  const Pose2 start = result.truth.front().pose;
  const Pose2 end = result.truth.back().pose;
  const Pose2 odom_end = result.log.lasers.back().odometry_pose;
  const long long beams =
      static_cast<long long>(result.num_scans) * scenario.laser.num_beams;
  std::cout << "scenario " << scenario.source_name << ", seed " << FLAGS_seed << "\n"
            << "duration " << result.duration_seconds << " s, " << result.num_scans
            << " scans, path length " << result.path_length_meters << " m\n"
            << "waypoints reached " << result.waypoints_reached << " of "
            << scenario.waypoints.size()
            << (result.completed ? " (route completed)" : " (route NOT completed)") << "\n"
            << "end-to-start distance " << (end.translation() - start.translation()).norm()
            << " m\n"
            << "odometry error at the end " << (odom_end.translation() - end.translation()).norm()
            << " m, " << std::abs(WrapAngle(odom_end.theta() - end.theta())) * 180.0 / M_PI
            << " deg\n"
            << "no-return beams " << result.num_no_return_beams << " of " << beams << "\n";
  if (!result.completed) {
    std::cerr << "hetslam_sim: the robot did not reach its last waypoint within the duration "
                 "limit of "
              << scenario.duration_limit_seconds << " s\n";
    if (!FLAGS_allow_incomplete) return 3;
  }
  return 0;
}

}  // namespace
}  // namespace hetslam

int main(int argc, char** argv) {
  gflags::SetUsageMessage(
      "simulate a wheeled robot with a 2D laser and odometry in a scenario world\n"
      "  hetslam_sim --out=DIR [--scenario=FILE] [--seed=N]\n"
      "writes DIR/log.clf, DIR/truth.txt, DIR/commands.txt, DIR/world.png");
  gflags::ParseCommandLineFlags(&argc, &argv, true);
  google::InitGoogleLogging(argv[0]);
  return hetslam::Run();
}
