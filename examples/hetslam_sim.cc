// hetslam_sim: simulates robots in a scenario world and writes a dataset with ground truth.
//
//   hetslam_sim --out=/tmp/sim --seed=7
//   hetslam_sim --scenario=datasets/scenarios/team_two.scenario --out=/tmp/team --seed=1
//
// A scenario without robot blocks (the 2D path, e.g. the office loop) gives one wheeled robot
// with a 2D laser and wheel odometry: DIR/log.clf (CARMEN FLASER + ODOM), DIR/truth.txt
// (timestamp x y theta at every scan), DIR/commands.txt (body-frame velocity commands) and
// DIR/world.png. A scenario with robot_begin .. robot_end blocks gives a team dataset:
// DIR/team.txt (HSTEAM manifest with tag truth), DIR/<robot>/log.txt (HSLOG),
// DIR/<robot>/images/NNNNNN.png, DIR/truth_layers/ (the true walls, furniture and
// floor_obstacles maps, world frame) and DIR/world.png (datasets/README.md). Then a summary is
// printed. The same --scenario and --seed always give the same files, byte for byte.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <system_error>

#include "datasets/sim/scenario.h"
#include "datasets/sim/simulator.h"
#include "datasets/sim/team_simulator.h"
#include "examples/flag_help.h"
#include "gflags/gflags.h"
#include "glog/logging.h"

#ifndef HETSLAM_DEFAULT_SCENARIO
#define HETSLAM_DEFAULT_SCENARIO "datasets/scenarios/office_loop.scenario"
#endif

DEFINE_string(scenario, HETSLAM_DEFAULT_SCENARIO,
              "Scenario file (world, and either single-robot settings or robot blocks; format in "
              "datasets/README.md). Default: the shipped office loop.");
DEFINE_string(out, "", "Output folder, created if missing. Single robot: receives log.clf, "
              "truth.txt, commands.txt and world.png. Team: team.txt, <robot>/log.txt, "
              "<robot>/images/*.png, truth_layers/{walls,furniture,floor_obstacles}.{pgm,yaml} "
              "and world.png. Required.");
DEFINE_uint64(seed, 1, "Seed of the one std::mt19937_64 behind every random number (sensor "
              "noise, dropouts, odometry noise, random obstacles, image noise). Same seed, same "
              "bytes.");
DEFINE_double(start_stamp, 0.0, "Single robot only: time stamp of the first scan, seconds, in [0, 1e10].");
DEFINE_double(control_rate_hz, 0.0, "Controller update rate, Hz (commands are recorded at this "
              "rate; teams also integrate the truth at it), in (0, 1000]. 0 or unset: 50 Hz for a single "
              "robot, 100 Hz for a team; a negative value is an error.");
DEFINE_double(waypoint_radius, 0.35, "Single robot only: a waypoint counts as reached within "
              "this distance, metres.");
DEFINE_double(goal_radius, 0.1, "Single robot only: the last waypoint counts as reached within "
              "this distance, metres.");
DEFINE_double(max_duration, 0.0, "Teams only: stop after this many simulated seconds if earlier "
              "than the scenario's duration_limit_s (0: the scenario's limit).");
DEFINE_bool(images, true, "Teams only: render and write the camera images (--noimages keeps the "
            "IMAGE lines but writes no PNG files; faster).");
DEFINE_bool(mirror, false, "Simulate the scenario mirrored about the vertical line through the middle of its "
            "walls (x -> 2 axis - x): walls, furniture, tags (readable, normals mirrored), starts, waypoints and "
            "body-frame commands; the robots themselves are not mirrored. A method whose errors lean one way "
            "with the handedness of its scans gets them the other way round here (datasets/sim/scenario.h, "
            "MirroredScenario).");
DEFINE_bool(allow_incomplete, false, "Exit with status 0 even when a robot did not finish its "
            "route before the duration limit (the files are written either way).");

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
  options->control_rate_hz = FLAGS_control_rate_hz > 0.0 ? FLAGS_control_rate_hz : 50.0;
  options->waypoint_reached_radius_meters = FLAGS_waypoint_radius;
  options->goal_reached_radius_meters = FLAGS_goal_radius;
  std::string why;
  if (!options->IsValid(&why)) {
    *error = "bad flag value: " + why;
    return false;
  }
  return true;
}

bool TeamOptionsFromFlags(sim::TeamSimulatorOptions* options, std::string* error) {
  options->control_rate_hz = FLAGS_control_rate_hz > 0.0 ? FLAGS_control_rate_hz : 100.0;
  options->max_duration_seconds = FLAGS_max_duration;
  options->render_images = FLAGS_images;
  std::string why;
  if (!options->IsValid(&why)) {
    *error = "bad flag value: " + why;
    return false;
  }
  return true;
}

int RunTeam(const sim::Scenario& scenario) {
  sim::TeamSimulatorOptions options;
  std::string error;
  if (!TeamOptionsFromFlags(&options, &error)) {
    std::cerr << "hetslam_sim: " << error << " (see --help)\n";
    return 2;
  }
  std::mt19937_64 rng(FLAGS_seed);
  sim::TeamSimulationResult result;
  Status status = sim::SimulateTeam(scenario, options, &rng, &result);
  if (!status.ok()) {
    std::cerr << "hetslam_sim: " << status.message() << "\n";
    return 1;
  }
  sim::TeamDatasetFiles files;
  status = sim::WriteTeamDataset(FLAGS_out, scenario, result, options,
                                 {"seed " + std::to_string(FLAGS_seed)}, &files);
  if (!status.ok()) {
    std::cerr << "hetslam_sim: " << status.message() << "\n";
    return 1;
  }
  std::cout << "wrote " << files.manifest_path << " (" << result.robots.size() << " robots, "
            << scenario.tags.size() << " tags)\n";
  bool all_completed = true;
  for (size_t i = 0; i < result.robots.size(); ++i) {
    const sim::RobotSimulation& robot = result.robots[i];
    std::cout << "wrote " << files.robot_log_paths[i] << " (" << robot.log.lasers.size()
              << " LASER, " << robot.log.marg.size() << " MARG, " << robot.log.images.size()
              << " IMAGE)\n";
  }
  std::cout << "wrote " << files.images_written << " images\n"
            << "wrote " << files.truth_layers_directory << "/ ("
            << files.truth_layer_paths.size() / 2 << " true map layers)\n"
            << "wrote " << files.world_image_path << "\n"
            << "scenario " << scenario.source_name << ", seed " << FLAGS_seed << "\n";
  for (const sim::RobotSimulation& robot : result.robots) {
    int frames_with_tags = 0;
    for (const sim::CameraFrame& frame : robot.frames) {
      if (!frame.visible_tags.empty()) ++frames_with_tags;
    }
    long long beams = 0;
    for (const auto& [surface, count] : robot.beams_by_surface) beams += count;
    std::cout << robot.name << " (" << sim::RobotKindName(robot.kind) << "): "
              << robot.duration_seconds << " s, path " << robot.path_length_meters << " m, "
              << (robot.completed ? "route completed" : "route NOT completed") << ", "
              << frames_with_tags << " of " << robot.frames.size() << " frames see a tag; beams:";
    for (const auto& [surface, count] : robot.beams_by_surface) {
      std::cout << " " << sim::SurfaceName(surface) << " " << count;
    }
    std::cout << ", no return " << robot.num_no_return_beams << "\n";
    all_completed = all_completed && robot.completed;
  }
  if (!all_completed) {
    std::cerr << "hetslam_sim: a robot did not finish its route within the duration limit\n";
    if (!FLAGS_allow_incomplete) return 3;
  }
  return 0;
}

int Run() {
  if (FLAGS_control_rate_hz < 0.0 || !std::isfinite(FLAGS_control_rate_hz)) {
    std::cerr << "hetslam_sim: --control_rate_hz must be 0 (the default rate) or in (0, 1000] Hz, got "
              << FLAGS_control_rate_hz << " (see --help)\n";
    return 2;
  }
  if (FLAGS_out.empty()) {
    std::cerr << "hetslam_sim: --out is required (an output folder) (see --help)\n";
    return 2;
  }
  if (FLAGS_scenario.empty()) {
    std::cerr << "hetslam_sim: --scenario must name a scenario file (see --help)\n";
    return 2;
  }
  sim::Scenario scenario;
  Status status = sim::ReadScenarioFile(FLAGS_scenario, &scenario);
  if (!status.ok()) {
    std::cerr << "hetslam_sim: " << status.message() << "\n";
    return 1;
  }
  if (FLAGS_mirror) scenario = sim::MirroredScenario(scenario);
  if (scenario.IsTeam()) return RunTeam(scenario);
  sim::SimulatorOptions options;
  std::string error;
  if (!OptionsFromFlags(&options, &error)) {
    std::cerr << "hetslam_sim: " << error << " (see --help)\n";
    return 2;
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
      "simulate robots in a scenario world and write a dataset with ground truth\n"
      "  hetslam_sim --out=DIR [--scenario=FILE] [--seed=N]\n"
      "single-robot scenarios write DIR/log.clf, DIR/truth.txt, DIR/commands.txt, DIR/world.png;\n"
      "scenarios with robot blocks write DIR/team.txt, DIR/<robot>/log.txt,\n"
      "DIR/<robot>/images/NNNNNN.png, DIR/truth_layers/ (true map layers) and DIR/world.png\n"
      "(format: datasets/README.md)");
  hetslam::PrintProgramHelpIfAsked(argc, argv, __FILE__);
  gflags::ParseCommandLineFlags(&argc, &argv, true);
  google::InitGoogleLogging(argv[0]);
  return hetslam::Run();
}
