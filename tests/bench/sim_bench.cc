// Simulator speed: one 361-beam scan in the office loop by brute-force CastRay per beam vs
// CastRays (angular culling), and the whole office loop (simulation only, no file output);
// the team scenarios (simulation only: no images rendered, no files).
#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "benchmark/benchmark.h"
#include "datasets/sim/scenario.h"
#include "datasets/sim/simulator.h"
#include "datasets/sim/team_simulator.h"
#include "glog/logging.h"

namespace hetslam {
namespace sim {
namespace {

const Scenario& OfficeLoop() {
  static const Scenario* const scenario = [] {
    auto* s = new Scenario;
    const Status status = ReadScenarioFile(
        std::string(HETSLAM_SOURCE_DIR) + "/datasets/scenarios/office_loop.scenario", s);
    CHECK(status.ok()) << status.message();
    return s;
  }();
  return *scenario;
}

// Seeded sensor poses inside the building, with the beam angles of a 180° / 361-beam fan.
struct Rays {
  Eigen::Vector2d origin;
  std::vector<double> angles;
};

std::vector<Rays> RandomRays(int count) {
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> x(0.5, 29.5), y(0.5, 19.5), heading(-M_PI, M_PI);
  std::vector<Rays> rays(count);
  for (Rays& r : rays) {
    r.origin = Eigen::Vector2d(x(rng), y(rng));
    const double h = heading(rng);
    for (int k = 0; k < 361; ++k) r.angles.push_back(h - M_PI / 2 + k * M_PI / 360);
  }
  return rays;
}

void BM_ScanBruteForceCastRay(benchmark::State& state) {
  const World& world = OfficeLoop().world;
  const std::vector<Rays> rays = RandomRays(64);
  size_t i = 0;
  for (auto _ : state) {
    const Rays& r = rays[i++ % rays.size()];
    for (double angle : r.angles) {
      double range = 0.0;
      benchmark::DoNotOptimize(world.CastRay(r.origin, angle, 30.0, &range));
      benchmark::DoNotOptimize(range);
    }
  }
  state.SetItemsProcessed(state.iterations() * 361);
}
BENCHMARK(BM_ScanBruteForceCastRay);

void BM_ScanCastRays(benchmark::State& state) {
  const World& world = OfficeLoop().world;
  const std::vector<Rays> rays = RandomRays(64);
  std::vector<double> ranges;
  size_t i = 0;
  for (auto _ : state) {
    const Rays& r = rays[i++ % rays.size()];
    world.CastRays(r.origin, r.angles, 30.0, &ranges);
    benchmark::DoNotOptimize(ranges.data());
  }
  state.SetItemsProcessed(state.iterations() * 361);
}
BENCHMARK(BM_ScanCastRays);

void BM_SimulateOfficeLoop(benchmark::State& state) {
  const Scenario& scenario = OfficeLoop();
  double simulated_seconds = 0.0;
  for (auto _ : state) {
    std::mt19937_64 rng(1);
    SimulationResult result;
    const Status status = Simulate(scenario, SimulatorOptions(), &rng, &result);
    CHECK(status.ok()) << status.message();
    simulated_seconds = result.duration_seconds;
    benchmark::DoNotOptimize(result.log.lasers.data());
  }
  state.counters["simulated_s"] = simulated_seconds;
}
BENCHMARK(BM_SimulateOfficeLoop)->Unit(benchmark::kMillisecond);

// One shipped team scenario, simulated (3D laser, MARG, camera visibility), no files written.
void BM_SimulateTeamScenario(benchmark::State& state, const std::string& name) {
  Scenario scenario;
  const Status read = ReadScenarioFile(
      std::string(HETSLAM_SOURCE_DIR) + "/datasets/scenarios/" + name + ".scenario", &scenario);
  CHECK(read.ok()) << read.message();
  double simulated_seconds = 0.0;
  for (auto _ : state) {
    std::mt19937_64 rng(1);
    TeamSimulationResult result;
    const Status status = SimulateTeam(scenario, TeamSimulatorOptions(), &rng, &result);
    CHECK(status.ok()) << status.message();
    simulated_seconds = 0.0;
    for (const RobotSimulation& robot : result.robots) {
      simulated_seconds = std::max(simulated_seconds, robot.duration_seconds);
    }
    benchmark::DoNotOptimize(result.robots.data());
  }
  state.counters["simulated_s"] = simulated_seconds;
}
BENCHMARK_CAPTURE(BM_SimulateTeamScenario, humanoid_static_tilt, "humanoid_static_tilt")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SimulateTeamScenario, uav_flight, "uav_flight")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SimulateTeamScenario, team_three, "team_three")->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace sim
}  // namespace hetslam

BENCHMARK_MAIN();
