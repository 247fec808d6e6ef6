// libFuzzer target: the simulator's scenario parser, which also builds the world (walls,
// boxes, prisms: the shapes whose CHECKs the parser must keep data away from).
#include <cstddef>
#include <cstdint>
#include <string>

#include "datasets/sim/scenario.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hetslam;
  sim::Scenario scenario;
  if (sim::ParseScenario(std::string(fuzz::AsText(data, size)), "fuzz.scenario", &scenario).ok()) {
    (void)scenario.world.Bounds();
    if (!scenario.IsTeam()) (void)scenario.InitialPose();
  }
  return 0;
}
