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
  FILE* file = nullptr;
  HETSLAM_RETURN_IF_ERROR(OpenForWriting(path, "w", &file));
  std::fprintf(file, "# timestamp x y theta\n");
  for (const StampedPose2& p : trajectory) {
    std::fprintf(file, "%.6f %.9f %.9f %.9f\n", p.stamp_seconds, p.pose.x(), p.pose.y(),
                 p.pose.theta());
  }
  return CommitWrittenFile(file, path);
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

Status ReadTrajectoryChecked(const std::string& path, std::vector<StampedPose2>* trajectory,
                             TrajectoryStampReport* report) {
  CHECK(trajectory != nullptr) << "ReadTrajectoryChecked: trajectory is null";
  CHECK(report != nullptr) << "ReadTrajectoryChecked: report is null";
  constexpr size_t kMaxWarnings = 5;
  trajectory->clear();
  *report = TrajectoryStampReport();
  std::vector<NumericRow> rows;
  HETSLAM_RETURN_IF_ERROR(ReadNumericTable(path, {"timestamp", "x", "y", "theta"}, &rows));
  trajectory->reserve(rows.size());
  const NumericRow* previous = nullptr;
  auto warn = [&](const NumericRow& row, const std::string& message) {
    if (report->warnings.size() < kMaxWarnings) {
      report->warnings.push_back(path + ":" + std::to_string(row.line_number) + ": " + message);
    }
  };
  for (const NumericRow& row : rows) {
    const std::vector<double>& v = row.values;
    if (previous != nullptr) {
      const double previous_stamp = previous->values[0];
      if (v == previous->values) {
        ++report->duplicate_rows_dropped;
        warn(row, "repeats line " + std::to_string(previous->line_number) + " exactly (dropped)");
        continue;
      }
      if (v[0] == previous_stamp) {
        ++report->repeated_stamps;
        warn(row, "has the stamp of line " + std::to_string(previous->line_number) + " with another pose");
      } else if (v[0] < previous_stamp) {
        ++report->stamps_backwards;
        warn(row, "stamp is earlier than line " + std::to_string(previous->line_number) + "'s");
      }
    }
    trajectory->push_back({v[0], Pose2(v[1], v[2], v[3])});
    previous = &row;
  }
  return Status::Ok();
}

}  // namespace hetslam
