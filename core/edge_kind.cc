#include "core/edge_kind.h"

namespace hetslam {

const char* EdgeKindName(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kSequential:
      return "sequential";
    case EdgeKind::kLoopClosure:
      return "loop closure";
    case EdgeKind::kInterRobot:
      return "inter-robot";
  }
  return "unknown";
}

}  // namespace hetslam
