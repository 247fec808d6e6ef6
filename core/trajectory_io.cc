#include "core/trajectory_io.h"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "core/text_fields.h"
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
  const bool write_failed = std::ferror(file) != 0;
  const int write_errno = errno;
  if (std::fclose(file) != 0 || write_failed) {
    return Status::Error("error writing '" + path + "': " +
                         std::strerror(write_failed ? write_errno : errno));
  }
  return Status::Ok();
}

Status ReadTrajectory(const std::string& path, std::vector<StampedPose2>* trajectory) {
  CHECK(trajectory != nullptr) << "ReadTrajectory: trajectory is null";
  trajectory->clear();
  struct stat info;
  if (stat(path.c_str(), &info) != 0) {
    return Status::Error("cannot open '" + path + "': " + std::strerror(errno));
  }
  if (S_ISDIR(info.st_mode)) return Status::Error("cannot open '" + path + "': Is a directory");
  std::ifstream in(path);
  if (!in) return Status::Error("cannot open '" + path + "': " + std::strerror(errno));

  static const char* const kNames[4] = {"timestamp", "x", "y", "theta"};
  std::string line;
  std::vector<std::string> fields;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    text_fields::Split(line, &fields);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string where = path + ":" + std::to_string(line_number) + ": ";
    if (fields.size() != 4) {
      trajectory->clear();
      return Status::Error(where + "expected 4 fields 'timestamp x y theta', found " +
                           std::to_string(fields.size()));
    }
    double v[4];
    for (int k = 0; k < 4; ++k) {
      if (!text_fields::ParseFiniteDouble(fields[k], &v[k])) {
        trajectory->clear();
        return Status::Error(where + kNames[k] + " ('" + fields[k] +
                             "') is not a finite number");
      }
    }
    StampedPose2 p;
    p.stamp_seconds = v[0];
    p.pose = Pose2(v[1], v[2], v[3]);
    trajectory->push_back(p);
  }
  if (in.bad()) {
    trajectory->clear();
    return Status::Error("error reading '" + path + "': " + std::strerror(errno));
  }
  return Status::Ok();
}

}  // namespace hetslam
