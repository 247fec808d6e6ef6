// libFuzzer target: a ROS map (YAML + PGM). The input is the YAML text, optionally followed by
// a "%%PGM\n" line and the bytes of the PGM it names as `image: map.pgm`; without one, a small
// valid PGM is used.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/map_io.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hetslam;
  const auto [yaml, pgm] = fuzz::SplitAt(fuzz::AsText(data, size), "%%PGM\n");
  static const std::string kDefaultPgm = std::string("P5\n4 3\n255\n") + std::string(12, '\xfe');
  fuzz::WriteScratchFile("map.pgm", pgm.empty() ? std::string_view(kDefaultPgm) : pgm);
  const std::string yaml_path = fuzz::WriteScratchFile("map.yaml", yaml);
  GridLayer layer;
  (void)ReadMapPgmYaml(yaml_path, &layer);
  return 0;
}
