// libFuzzer target: the team manifest reader (and the writer on what it accepts).
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/team_manifest.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hetslam;
  const std::string path = fuzz::WriteScratchFile("team.txt", fuzz::AsText(data, size));
  TeamManifest manifest;
  if (ReadTeamManifest(path, &manifest).ok()) {
    for (const TeamRobot& robot : manifest.robots) (void)manifest.RobotLogPath(robot);
    (void)WriteTeamManifest(fuzz::ScratchDir() + "/team_out.txt", manifest, {"fuzz"});
  }
  return 0;
}
