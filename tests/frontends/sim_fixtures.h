// Simulated inputs shared by the front-end tests: a ring of rooms for the 2D simulator, and the
// shipped 2.5D scenarios (datasets/scenarios) run by the team simulator without images.
#ifndef HETSLAM_TESTS_FRONTENDS_SIM_FIXTURES_H_
#define HETSLAM_TESTS_FRONTENDS_SIM_FIXTURES_H_

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/robot_log.h"
#include "core/trajectory_io.h"
#include "datasets/sim/scenario.h"
#include "datasets/sim/simulator.h"
#include "datasets/sim/team_simulator.h"
#include "datasets/sim/world.h"
#include "glog/logging.h"

namespace hetslam {
namespace testing_sim {

// A 6 m x 4 m room ([-3, 3] x [-2, 2]) with a 0.6 m square pillar centred at (1.2, 0.7):
// no symmetry a matcher could confuse. Scans are ray-cast by the simulator's world.
inline sim::World RoomWithPillar() {
  sim::World world;
  world.AddBox(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(6.0, 4.0), 0.0);
  world.AddBox(Eigen::Vector2d(1.2, 0.7), Eigen::Vector2d(0.6, 0.6), 0.0);
  return world;
}

// A 14 m × 10 m ring of rooms with a central block and a few boxes, driven around once and a
// half (a loop to close), 181-beam 12 m laser.
inline constexpr char kRingScenario[] = R"(
wall 0 0 14 0
wall 14 0 14 10
wall 14 10 0 10
wall 0 10 0 0
box 7 5 6 2
box 0.4 5 0.6 0.8
box 13.6 3 0.5 0.9 30
box 7 9.6 1.0 0.4
box 5 0.4 0.6 0.6
box 10.5 6.5 0.8 0.5
waypoint 1.5 1.5
waypoint 12.5 1.5
waypoint 12.5 8.5
waypoint 1.5 8.5
waypoint 1.5 1.5
waypoint 10 1.5
laser 180 181 12 0.01 0.002 4
robot 0.6 45
)";

inline sim::SimulationResult SimulateRing(uint64_t seed) {
  sim::Scenario scenario;
  const Status parsed = sim::ParseScenario(kRingScenario, "ring", &scenario);
  CHECK(parsed.ok()) << parsed.message();
  std::mt19937_64 rng(seed);
  sim::SimulationResult simulation;
  const Status simulated = sim::Simulate(scenario, sim::SimulatorOptions(), &rng, &simulation);
  CHECK(simulated.ok()) << simulated.message();
  return simulation;
}

// The shipped scenario datasets/scenarios/<name>.scenario, simulated with `seed` (without
// camera images) for at most `max_duration_seconds` (0: the whole route).
inline sim::TeamSimulationResult SimulateShippedScenario(const std::string& name, uint64_t seed,
                                                         double max_duration_seconds = 0.0) {
  sim::Scenario scenario;
  const Status read =
      sim::ReadScenarioFile(std::string(HETSLAM_SOURCE_DIR) + "/datasets/scenarios/" + name + ".scenario", &scenario);
  CHECK(read.ok()) << read.message();
  sim::TeamSimulatorOptions options;
  options.render_images = false;
  if (max_duration_seconds > 0) options.max_duration_seconds = max_duration_seconds;
  std::mt19937_64 rng(seed);
  sim::TeamSimulationResult result;
  const Status simulated = sim::SimulateTeam(scenario, options, &rng, &result);
  CHECK(simulated.ok()) << simulated.message();
  CHECK(!result.robots.empty());
  return result;
}

// A robot log's 6D TRUTH as planar poses (x, y, yaw).
inline std::vector<StampedPose2> PlanarTruth(const RobotLog& log) {
  std::vector<StampedPose2> truth;
  for (const StampedPose3& t : log.truth) {
    const Eigen::Matrix3d r = t.pose.linear();
    truth.push_back(
        {t.stamp_seconds, Pose2(t.pose.translation().x(), t.pose.translation().y(), std::atan2(r(1, 0), r(0, 0)))});
  }
  return truth;
}

}  // namespace testing_sim
}  // namespace hetslam

#endif  // HETSLAM_TESTS_FRONTENDS_SIM_FIXTURES_H_
