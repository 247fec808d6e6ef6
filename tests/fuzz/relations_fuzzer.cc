// libFuzzer target: a trajectory and a relations file (the input split at a "%%\n" line),
// both read, then scored against each other as hetslam_eval does.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/relations.h"
#include "core/trajectory_io.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hetslam;
  const auto [trajectory_text, relations_text] = fuzz::SplitAt(fuzz::AsText(data, size), "%%\n");
  const std::string trajectory_path = fuzz::WriteScratchFile("trajectory.txt", trajectory_text);
  const std::string relations_path = fuzz::WriteScratchFile("relations.txt", relations_text);
  std::vector<StampedPose2> trajectory;
  TrajectoryStampReport report;
  const bool have_trajectory = ReadTrajectoryChecked(trajectory_path, &trajectory, &report).ok();
  std::vector<Relation> relations;
  const bool have_relations = ReadRelations(relations_path, &relations).ok();
  if (have_trajectory && have_relations && !trajectory.empty() && !relations.empty()) {
    RelationsMetricOptions options;
    (void)EvaluateRelations(trajectory, relations, options);
  }
  return 0;
}
