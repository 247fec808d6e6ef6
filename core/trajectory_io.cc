#include "core/trajectory_io.h"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "core/file_io.h"
#include "core/numeric_table.h"
#include "glog/logging.h"

namespace hetslam {

Status WriteTrajectory(const std::string& path, const std::vector<StampedPose2>& trajectory) {
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const StampedPose2& p = trajectory[i];
    if (!std::isfinite(p.stamp_seconds) || !p.pose.ToVector().allFinite()) {
      return Status::Error("cannot write '" + path + "': pose " + std::to_string(i) +
                           " has a non-finite timestamp or value");
    }
  }
  FILE* file = std::fopen(path.c_str(), "w");
  if (file == nullptr) {
    return Status::Error("cannot open '" + path + "' for writing: " + std::strerror(errno));
  }
  std::fprintf(file, "# timestamp x y theta\n");
  for (const StampedPose2& p : trajectory) {
    std::fprintf(file, "%.6f %.9f %.9f %.9f\n", p.stamp_seconds, p.pose.x(), p.pose.y(),
                 p.pose.theta());
  }
  return CloseWrittenFile(file, path);
}

Status ReadTrajectory(const std::string& path, std::vector<StampedPose2>* trajectory) {
  CHECK(trajectory != nullptr) << "ReadTrajectory: trajectory is null";
  trajectory->clear();
  std::vector<NumericRow> rows;
  HETSLAM_RETURN_IF_ERROR(ReadNumericTable(path, {"timestamp", "x", "y", "theta"}, &rows));
  trajectory->reserve(rows.size());
  for (const NumericRow& row : rows) {
    const std::vector<double>& v = row.values;
    trajectory->push_back({v[0], Pose2(v[1], v[2], v[3])});
  }
  return Status::Ok();
}

}  // namespace hetslam
