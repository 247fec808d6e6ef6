#include "core/robot_log_text.h"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <sstream>

#include "core/euler.h"
#include "core/text_fields.h"
#include "glog/logging.h"

namespace hetslam {
namespace robot_log_text {

using text_fields::ParseInteger;

std::string FormatDouble(double v) {
  std::array<char, 64> buffer;
  const std::to_chars_result result =
      std::to_chars(buffer.data(), buffer.data() + buffer.size(), v);
  CHECK(result.ec == std::errc()) << "to_chars failed";
  return std::string(buffer.data(), result.ptr);
}

std::string DirectoryOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  // "a//b" names b in a: drop the repeated slashes too.
  size_t end = slash;
  while (end > 0 && path[end - 1] == '/') --end;
  if (end == 0) return "/";
  return path.substr(0, end);
}

bool StaysInside(const std::string& relative) {
  if (relative.empty() || relative[0] == '/' || relative[0] == '\\') return false;
  size_t start = 0;
  while (start <= relative.size()) {
    const size_t end = std::min(relative.find_first_of("/\\", start), relative.size());
    if (relative.compare(start, end - start, "..") == 0 && end - start == 2) return false;
    start = end + 1;
  }
  return true;
}

std::string JoinPath(const std::string& directory, const std::string& relative) {
  if (!relative.empty() && relative[0] == '/') return relative;
  if (directory.empty()) return relative;
  if (directory.back() == '/') return directory + relative;
  return directory + "/" + relative;
}

Eigen::Isometry3d PoseFromValues(const double* v) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  pose.linear() = RotationFromRollPitchYaw(v[3], v[4], v[5]);
  return pose;
}

std::string FormatPose(const Eigen::Isometry3d& pose) {
  // + 0.0 turns the -0 that atan2 gives for some exact poses into 0 (same rotation).
  const Eigen::Vector3d rpy = RollPitchYawFromRotation(pose.linear()).array() + 0.0;
  const Eigen::Vector3d& t = pose.translation();
  return FormatDouble(t.x()) + " " + FormatDouble(t.y()) + " " + FormatDouble(t.z()) + " " +
         FormatDouble(rpy.x()) + " " + FormatDouble(rpy.y()) + " " + FormatDouble(rpy.z());
}

bool IsWritablePose(const Eigen::Isometry3d& pose) {
  if (!pose.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = pose.linear();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
         R.determinant() > 0.0;
}

Status CheckHeader(const std::vector<std::string>& fields, const char* magic, int* version) {
  if (fields[0] != magic) {
    return Status::Error(std::string("expected the header '") + magic + " " +
                         std::to_string(kVersion) + "' as the first message, found '" +
                         fields[0] + "'");
  }
  long long v = 0;
  if (fields.size() != 2 || !ParseInteger(fields[1], 0, 1000000, &v)) {
    return Status::Error(std::string(magic) + " header needs one integer version");
  }
  if (v != kVersion) {
    return Status::Error(std::string("unsupported ") + magic + " version " + fields[1] +
                         " (this reader knows version " + std::to_string(kVersion) + ")");
  }
  *version = static_cast<int>(v);
  return Status::Ok();
}

Status OpenForReading(const std::string& path, std::ifstream* in) {
  struct stat info;
  if (stat(path.c_str(), &info) != 0) {
    return Status::Error("cannot open '" + path + "': " + std::strerror(errno));
  }
  if (S_ISDIR(info.st_mode)) return Status::Error("cannot open '" + path + "': Is a directory");
  in->open(path);
  if (!*in) return Status::Error("cannot open '" + path + "': " + std::strerror(errno));
  return Status::Ok();
}

Status CheckEndOfFile(const std::ifstream& in, const std::string& path, int line_number,
                      bool have_header, const char* magic) {
  if (in.bad()) {
    return Status::Error("error reading '" + path + "' after line " +
                         std::to_string(line_number) + ": " + std::strerror(errno));
  }
  if (!have_header) {
    return Status::Error(path + ":" + std::to_string(std::max(1, line_number)) + ": missing '" +
                         magic + " " + std::to_string(kVersion) +
                         "' header: the file has no messages");
  }
  return Status::Ok();
}

bool IsPlainWord(const std::string& s) {
  if (s.empty() || s[0] == '#') return false;
  for (char c : s) {
    if (std::isspace(static_cast<unsigned char>(c))) return false;
  }
  return true;
}


}  // namespace robot_log_text
}  // namespace hetslam
