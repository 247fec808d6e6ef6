// libFuzzer target: the g2o reader; small graphs it accepts are also solved (a few
// iterations), since the factors CHECK what the reader promised to validate.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "core/g2o_io.h"
#include "factors/pose_graph_2d.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hetslam;
  std::istringstream input{std::string(fuzz::AsText(data, size))};
  PoseGraph2d graph;
  if (!ParseG2oPoseGraph2d(input, "fuzz.g2o", &graph).ok()) return 0;
  std::ostringstream written;
  WriteG2oPoseGraph2d(graph, &written);
  if (graph.vertices.empty() || graph.vertices.size() > 20 || graph.edges.size() > 60) return 0;
  PoseGraph2dOptions options;
  options.max_num_iterations = 5;
  PoseGraph2dSummary summary;
  (void)OptimizePoseGraph2d(options, &graph, &summary);
  return 0;
}
