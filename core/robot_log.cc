#include "core/robot_log.h"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>

#include "core/euler.h"
#include "core/file_io.h"
#include "core/text_fields.h"
#include "glog/logging.h"

namespace hetslam {

namespace {

using text_fields::ParseDouble;
using text_fields::ParseFiniteDouble;
using text_fields::ParseInteger;

constexpr int kVersion = 1;
constexpr long long kMaxBeams = 100000;
// A scan is written with a first angle and an increment; angles that differ from that fan by
// more than this are not "evenly spaced" (rounding of first + i * increment stays far below).
constexpr double kAngleTolerance = 1e-9;
// A MOUNT in force and a scan's robot_T_sensor must agree this well for the writer.
constexpr double kMountTolerance = 1e-9;

// Shortest decimal text that reads back as the same double (std::to_chars, locale
// independent). Non-finite values print as "nan", "inf", "-inf".
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

// "x y z roll pitch yaw" of a pose.
std::string FormatPose(const Eigen::Isometry3d& pose) {
  // + 0.0 turns the -0 that atan2 gives for some exact poses into 0 (same rotation).
  const Eigen::Vector3d rpy = RollPitchYawFromRotation(pose.linear()).array() + 0.0;
  const Eigen::Vector3d& t = pose.translation();
  return FormatDouble(t.x()) + " " + FormatDouble(t.y()) + " " + FormatDouble(t.z()) + " " +
         FormatDouble(rpy.x()) + " " + FormatDouble(rpy.y()) + " " + FormatDouble(rpy.z());
}

// A pose the writer can store: finite, with a rotation matrix (orthonormal, det +1).
bool IsWritablePose(const Eigen::Isometry3d& pose) {
  if (!pose.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = pose.linear();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
         R.determinant() > 0.0;
}

// The fields of one message after its type: the stamp, then fixed named numbers. Errors name
// the message and the field; the caller prefixes "file:line: ".
class MessageFields {
 public:
  explicit MessageFields(const std::vector<std::string>& fields)
      : fields_(fields), type_(fields[0]) {}

  // Exactly `names.size()` numbers after the stamp.
  Status ExpectNumbersAfterStamp(const std::vector<const char*>& names) const {
    if (fields_.size() < 2) return Status::Error(type_ + " has no stamp");
    const size_t found = fields_.size() - 2;
    if (found != names.size()) {
      std::string list;
      for (const char* name : names) list += std::string(list.empty() ? "" : " ") + name;
      return Status::Error(type_ + " needs " + std::to_string(names.size()) +
                           " numbers after the stamp (" + list + "), found " +
                           std::to_string(found));
    }
    return Status::Ok();
  }

  Status Stamp(double* stamp_seconds) const {
    if (fields_.size() < 2) return Status::Error(type_ + " has no stamp");
    return FiniteAt(1, "stamp", stamp_seconds);
  }

  Status FiniteAt(size_t index, const char* name, double* value) const {
    CHECK_LT(index, fields_.size()) << type_ << ": field " << name << " not checked";
    if (!ParseFiniteDouble(fields_[index], value)) {
      return Status::Error(type_ + " " + name + " ('" + fields_[index] +
                           "') is not a finite number");
    }
    return Status::Ok();
  }

  // The numbers after the stamp, named for the errors.
  Status Numbers(const std::vector<const char*>& names, double* values) const {
    HETSLAM_RETURN_IF_ERROR(ExpectNumbersAfterStamp(names));
    for (size_t i = 0; i < names.size(); ++i) {
      HETSLAM_RETURN_IF_ERROR(FiniteAt(i + 2, names[i], &values[i]));
    }
    return Status::Ok();
  }

 private:
  const std::vector<std::string>& fields_;
  const std::string type_;
};

const std::vector<const char*> kPoseNames = {"x", "y", "z", "roll", "pitch", "yaw"};

Status ParseStampedPose(const std::vector<std::string>& fields, StampedPose3* pose) {
  MessageFields m(fields);
  double v[6];
  HETSLAM_RETURN_IF_ERROR(m.Numbers(kPoseNames, v));
  HETSLAM_RETURN_IF_ERROR(m.Stamp(&pose->stamp_seconds));
  pose->pose = PoseFromValues(v);
  return Status::Ok();
}

// LASER t n angle_min angle_increment range_min range_max r_1 .. r_n
Status ParseLaser(const std::vector<std::string>& fields, LaserScan* scan,
                  int* num_non_finite) {
  MessageFields m(fields);
  if (fields.size() < 7) {
    return Status::Error("LASER is truncated: needs t n angle_min angle_increment range_min "
                         "range_max and the ranges, found " + std::to_string(fields.size() - 1) +
                         " fields");
  }
  HETSLAM_RETURN_IF_ERROR(m.Stamp(&scan->stamp_seconds));
  long long n = 0;
  if (!ParseInteger(fields[2], std::numeric_limits<long long>::min(),
                    std::numeric_limits<long long>::max(), &n)) {
    return Status::Error("LASER beam count ('" + fields[2] + "') is not an integer");
  }
  if (n < 0 || n > kMaxBeams) {
    return Status::Error("LASER beam count " + fields[2] + " is out of range [0, " +
                         std::to_string(kMaxBeams) + "]");
  }
  const size_t present = fields.size() - 7;
  if (static_cast<size_t>(n) != present) {
    return Status::Error("LASER declares " + std::to_string(n) + " ranges but " +
                         std::to_string(present) + " follow range_max");
  }
  double angle_min = 0.0, increment = 0.0;
  HETSLAM_RETURN_IF_ERROR(m.FiniteAt(3, "angle_min", &angle_min));
  HETSLAM_RETURN_IF_ERROR(m.FiniteAt(4, "angle_increment", &increment));
  HETSLAM_RETURN_IF_ERROR(m.FiniteAt(5, "range_min", &scan->range_min_meters));
  HETSLAM_RETURN_IF_ERROR(m.FiniteAt(6, "range_max", &scan->range_max_meters));
  if (!(scan->range_min_meters >= 0.0 && scan->range_max_meters > scan->range_min_meters)) {
    return Status::Error("LASER needs 0 <= range_min < range_max (got " + fields[5] + ", " +
                         fields[6] + ")");
  }
  scan->ranges_meters.resize(n);
  int non_finite = 0;
  for (long long i = 0; i < n; ++i) {
    const std::string& f = fields[7 + i];
    double r = 0.0;
    if (!ParseDouble(f, &r)) {
      return Status::Error("LASER range " + std::to_string(i) + " ('" + f +
                           "') is not a number");
    }
    if (!std::isfinite(r)) {
      ++non_finite;
      r = std::numeric_limits<double>::quiet_NaN();
    }
    scan->ranges_meters[i] = r;
  }
  scan->angles_radians = EvenlySpacedAngles(static_cast<int>(n), angle_min, increment);
  *num_non_finite = non_finite;
  return Status::Ok();
}

Status ParseMarg(const std::vector<std::string>& fields, MargSample* reading) {
  MessageFields m(fields);
  double v[9];
  HETSLAM_RETURN_IF_ERROR(
      m.Numbers({"gx", "gy", "gz", "ax", "ay", "az", "mx", "my", "mz"}, v));
  HETSLAM_RETURN_IF_ERROR(m.Stamp(&reading->stamp_seconds));
  reading->gyro_radps = Eigen::Vector3d(v[0], v[1], v[2]);
  reading->accel_mps2 = Eigen::Vector3d(v[3], v[4], v[5]);
  reading->magnetometer = Eigen::Vector3d(v[6], v[7], v[8]);
  return Status::Ok();
}

Status ParseAttitude(const std::vector<std::string>& fields, AttitudeReading* reading) {
  MessageFields m(fields);
  double v[3];
  HETSLAM_RETURN_IF_ERROR(m.Numbers({"roll", "pitch", "yaw"}, v));
  HETSLAM_RETURN_IF_ERROR(m.Stamp(&reading->stamp_seconds));
  reading->roll_radians = v[0];
  reading->pitch_radians = v[1];
  reading->yaw_radians = v[2];
  return Status::Ok();
}

Status ParseAltitude(const std::vector<std::string>& fields, AltitudeReading* reading) {
  MessageFields m(fields);
  HETSLAM_RETURN_IF_ERROR(m.Numbers({"z"}, &reading->height_meters));
  return m.Stamp(&reading->stamp_seconds);
}

Status ParseOdom(const std::vector<std::string>& fields, OdometryReading* reading) {
  MessageFields m(fields);
  double v[3];
  HETSLAM_RETURN_IF_ERROR(m.Numbers({"x", "y", "theta"}, v));
  HETSLAM_RETURN_IF_ERROR(m.Stamp(&reading->stamp_seconds));
  reading->pose = Pose2(v[0], v[1], v[2]);
  return Status::Ok();
}

Status ParseCommand(const std::vector<std::string>& fields, VelocityCommand* reading) {
  MessageFields m(fields);
  double v[3];
  HETSLAM_RETURN_IF_ERROR(m.Numbers({"vx", "vy", "yaw_rate"}, v));
  HETSLAM_RETURN_IF_ERROR(m.Stamp(&reading->stamp_seconds));
  reading->forward_mps = v[0];
  reading->left_mps = v[1];
  reading->yaw_rate_radps = v[2];
  return Status::Ok();
}

Status ParseImage(const std::vector<std::string>& fields, CameraImage* image) {
  MessageFields m(fields);
  if (fields.size() != 3) {
    return Status::Error("IMAGE needs a stamp and one path, found " +
                         std::to_string(fields.size() - 1) + " fields");
  }
  HETSLAM_RETURN_IF_ERROR(m.Stamp(&image->stamp_seconds));
  image->path = fields[2];
  return Status::Ok();
}

// PARAM name value...: the value is the rest of the line, fields joined by one space.
Status ParseParam(const std::vector<std::string>& fields, std::string* name, std::string* value) {
  if (fields.size() < 3) return Status::Error("PARAM needs a name and a value");
  *name = fields[1];
  value->clear();
  for (size_t i = 2; i < fields.size(); ++i) {
    if (i > 2) *value += ' ';
    *value += fields[i];
  }
  return Status::Ok();
}

// The header line "<magic> 1" (first non-comment line). Errors even in lenient mode.
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

bool IsPlainWord(const std::string& s) {
  if (s.empty() || s[0] == '#') return false;
  for (char c : s) {
    if (std::isspace(static_cast<unsigned char>(c))) return false;
  }
  return true;
}

// A PARAM value reads back identically when it is its own fields joined by single spaces.
bool IsCanonicalValue(const std::string& value) {
  std::vector<std::string> fields;
  text_fields::Split(value, &fields);
  if (fields.empty()) return false;
  std::string joined;
  for (size_t i = 0; i < fields.size(); ++i) joined += (i > 0 ? " " : "") + fields[i];
  return joined == value;
}

void WriteComments(FILE* file, const std::vector<std::string>& comment_lines) {
  for (const std::string& comment : comment_lines) {
    std::istringstream lines(comment);
    std::string one;
    bool any = false;
    while (std::getline(lines, one)) {
      std::fprintf(file, "# %s\n", one.c_str());
      any = true;
    }
    if (!any) std::fprintf(file, "#\n");
  }
}

bool AllFinite(std::initializer_list<double> values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

}  // namespace

Status RobotLog::CameraModel(CameraIntrinsics* intrinsics,
                             Eigen::Isometry3d* laser_T_camera) const {
  CHECK(intrinsics != nullptr) << "CameraModel: intrinsics is null";
  CHECK(laser_T_camera != nullptr) << "CameraModel: laser_T_camera is null";
  auto find = [&](const char* name, std::string* value) -> Status {
    const auto it = params.find(name);
    if (it == params.end()) {
      return Status::Error(path + ": PARAM " + name + " is missing (no camera model)");
    }
    *value = it->second;
    return Status::Ok();
  };
  auto positive = [&](const char* name, double* out) -> Status {
    std::string value;
    HETSLAM_RETURN_IF_ERROR(find(name, &value));
    if (!ParseFiniteDouble(value, out) || !(*out > 0.0)) {
      return Status::Error(path + ": PARAM " + name + " ('" + value +
                           "') is not a positive number");
    }
    return Status::Ok();
  };
  auto size = [&](const char* name, int* out) -> Status {
    std::string value;
    HETSLAM_RETURN_IF_ERROR(find(name, &value));
    long long v = 0;
    if (!ParseInteger(value, 1, 1000000, &v)) {
      return Status::Error(path + ": PARAM " + name + " ('" + value +
                           "') is not an integer in [1, 1000000]");
    }
    *out = static_cast<int>(v);
    return Status::Ok();
  };
  CameraIntrinsics k;
  HETSLAM_RETURN_IF_ERROR(positive("camera_fx", &k.fx));
  HETSLAM_RETURN_IF_ERROR(positive("camera_fy", &k.fy));
  HETSLAM_RETURN_IF_ERROR(positive("camera_cx", &k.cx));
  HETSLAM_RETURN_IF_ERROR(positive("camera_cy", &k.cy));
  HETSLAM_RETURN_IF_ERROR(size("camera_width", &k.width));
  HETSLAM_RETURN_IF_ERROR(size("camera_height", &k.height));
  std::string mount;
  HETSLAM_RETURN_IF_ERROR(find("laser_T_camera", &mount));
  std::vector<std::string> fields;
  text_fields::Split(mount, &fields);
  double v[6];
  bool ok = fields.size() == 6;
  for (size_t i = 0; ok && i < 6; ++i) ok = ParseFiniteDouble(fields[i], &v[i]);
  if (!ok) {
    return Status::Error(path + ": PARAM laser_T_camera ('" + mount +
                         "') is not 6 finite numbers 'x y z roll pitch yaw'");
  }
  *intrinsics = k;
  *laser_T_camera = PoseFromValues(v);
  return Status::Ok();
}

std::string RobotLog::ImagePath(const CameraImage& image) const {
  return JoinPath(directory, image.path);
}

std::string TeamManifest::RobotLogPath(const TeamRobot& robot) const {
  return JoinPath(JoinPath(directory, robot.directory), "log.txt");
}

Status ReadRobotLog(const std::string& path, const RobotLogReadOptions& options, RobotLog* log) {
  CHECK(log != nullptr) << "ReadRobotLog: log is null";
  *log = RobotLog();
  log->path = path;
  log->directory = DirectoryOf(path);
  if (options.max_warnings_kept < 0) {
    return Status::Error("invalid RobotLogReadOptions: max_warnings_kept " +
                         std::to_string(options.max_warnings_kept) + " is negative");
  }
  std::ifstream in;
  HETSLAM_RETURN_IF_ERROR(OpenForReading(path, &in));

  RobotLogStats& stats = log->stats;
  auto where = [&](int line_number) { return path + ":" + std::to_string(line_number) + ": "; };
  auto warn = [&](int line_number, const std::string& message) {
    if (static_cast<int>(log->warnings.size()) < options.max_warnings_kept) {
      log->warnings.push_back(where(line_number) + message);
    }
  };
  // Stamps going backwards within one message type: counted, never reordered.
  std::map<std::string, double> last_stamp;
  auto check_stamp = [&](int line_number, const std::string& type, double stamp) {
    const auto it = last_stamp.find(type);
    if (it != last_stamp.end() && stamp < it->second) {
      ++stats.timestamps_backwards[type];
      warn(line_number, type + " stamp " + FormatDouble(stamp) +
                            " is earlier than the previous " + type + " stamp " +
                            FormatDouble(it->second) + " (kept in file order)");
    }
    last_stamp[type] = stamp;
  };

  bool have_header = false;
  // robot_T_sensor of the scans: the last MOUNT line above them.
  Eigen::Isometry3d body_T_laser = Eigen::Isometry3d::Identity();
  std::string line;
  std::vector<std::string> fields;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    ++stats.lines;
    text_fields::Split(line, &fields);
    if (fields.empty() || fields[0][0] == '#') {
      ++stats.comment_lines;
      continue;
    }
    const std::string& type = fields[0];
    if (!have_header) {
      const Status status = CheckHeader(fields, "HSLOG", &log->version);
      if (!status.ok()) return Status::Error(where(line_number) + status.message());
      have_header = true;
      continue;
    }
    Status status;
    double stamp = 0.0;
    if (type == "LASER") {
      LaserReading reading;
      reading.line_number = line_number;
      int non_finite = 0;
      status = ParseLaser(fields, &reading.scan, &non_finite);
      if (status.ok()) {
        stats.non_finite_ranges += non_finite;
        reading.scan.robot_T_sensor = body_T_laser;
        stamp = reading.scan.stamp_seconds;
        log->lasers.push_back(std::move(reading));
      }
    } else if (type == "MOUNT" || type == "TRUTH") {
      StampedPose3 pose;
      pose.line_number = line_number;
      status = ParseStampedPose(fields, &pose);
      if (status.ok()) {
        stamp = pose.stamp_seconds;
        if (type == "MOUNT") {
          body_T_laser = pose.pose;
          log->mounts.push_back(pose);
        } else {
          log->truth.push_back(pose);
        }
      }
    } else if (type == "MARG") {
      MargSample reading;
      reading.line_number = line_number;
      status = ParseMarg(fields, &reading);
      if (status.ok()) {
        stamp = reading.stamp_seconds;
        log->marg.push_back(reading);
      }
    } else if (type == "ATTITUDE") {
      AttitudeReading reading;
      reading.line_number = line_number;
      status = ParseAttitude(fields, &reading);
      if (status.ok()) {
        stamp = reading.stamp_seconds;
        log->attitudes.push_back(reading);
      }
    } else if (type == "ALTITUDE") {
      AltitudeReading reading;
      reading.line_number = line_number;
      status = ParseAltitude(fields, &reading);
      if (status.ok()) {
        stamp = reading.stamp_seconds;
        log->altitudes.push_back(reading);
      }
    } else if (type == "ODOM") {
      OdometryReading reading;
      reading.line_number = line_number;
      status = ParseOdom(fields, &reading);
      if (status.ok()) {
        stamp = reading.stamp_seconds;
        log->odometry.push_back(reading);
      }
    } else if (type == "COMMAND") {
      VelocityCommand reading;
      reading.line_number = line_number;
      status = ParseCommand(fields, &reading);
      if (status.ok()) {
        stamp = reading.stamp_seconds;
        log->commands.push_back(reading);
      }
    } else if (type == "IMAGE") {
      CameraImage image;
      image.line_number = line_number;
      status = ParseImage(fields, &image);
      if (status.ok()) {
        stamp = image.stamp_seconds;
        log->images.push_back(image);
      }
    } else if (type == "PARAM") {
      std::string name, value;
      status = ParseParam(fields, &name, &value);
      if (status.ok()) {
        const auto it = log->params.find(name);
        if (it != log->params.end() && it->second != value) {
          warn(line_number, "PARAM " + name + " redefined from '" + it->second + "' to '" +
                                value + "' (the last value holds)");
        }
        log->params[name] = value;
      }
    } else if (type == "HSLOG") {
      status = Status::Error("HSLOG header repeated");
    } else {
      status = Status::Error("unknown message '" + type + "'");
    }
    if (!status.ok()) {
      if (!options.lenient) return Status::Error(where(line_number) + status.message());
      ++stats.malformed_lines_skipped;
      warn(line_number, status.message() + " (line skipped)");
      continue;
    }
    ++stats.message_counts[type];
    if (type != "PARAM") check_stamp(line_number, type, stamp);
  }
  if (in.bad()) {
    return Status::Error("error reading '" + path + "' after line " +
                         std::to_string(line_number) + ": " + std::strerror(errno));
  }
  if (!have_header) {
    return Status::Error(where(std::max(1, line_number)) +
                         "missing 'HSLOG 1' header: the file has no messages");
  }
  return Status::Ok();
}

namespace {

// The first angle and increment that give back `angles` through EvenlySpacedAngles: exactly
// when possible (scans built by EvenlySpacedAngles), else within kAngleTolerance.
Status LaserFan(const LaserScan& scan, const std::string& which, double* angle_min,
                double* increment) {
  const std::vector<double>& a = scan.angles_radians;
  const size_t n = a.size();
  *angle_min = n > 0 ? a[0] : 0.0;
  *increment = 0.0;
  if (n < 2) return Status::Ok();
  auto max_error = [&](double inc) {
    double worst = 0.0;
    for (size_t i = 0; i < n; ++i) {
      worst = std::max(worst, std::abs(a[0] + static_cast<double>(i) * inc - a[i]));
    }
    return worst;
  };
  // Candidates: the first difference and the mean spacing, each with its neighbours a few
  // ulps away (the increment that produced the angles is usually among them).
  double best = a[1] - a[0];
  double best_error = max_error(best);
  for (double base : {a[1] - a[0], (a[n - 1] - a[0]) / static_cast<double>(n - 1)}) {
    double down = base, up = base;
    for (int step = 0; step <= 4 && best_error > 0.0; ++step) {
      for (double candidate : {down, up}) {
        const double error = max_error(candidate);
        if (error < best_error) {
          best = candidate;
          best_error = error;
        }
      }
      down = std::nextafter(down, -std::numeric_limits<double>::infinity());
      up = std::nextafter(up, std::numeric_limits<double>::infinity());
    }
  }
  if (!(best_error <= kAngleTolerance)) {
    return Status::Error(which + " does not have evenly spaced beam angles (off by " +
                         FormatDouble(best_error) + " rad from the best fan); LASER stores "
                         "angle_min and angle_increment only");
  }
  *increment = best;
  return Status::Ok();
}

bool SamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff() <= kMountTolerance;
}

}  // namespace

Status WriteRobotLog(const std::string& path, const RobotLog& log,
                     const std::vector<std::string>& comment_lines) {
  // Validate everything before opening the file, so that an error leaves nothing behind.
  for (const auto& [name, value] : log.params) {
    if (!IsPlainWord(name) || !IsCanonicalValue(value)) {
      return Status::Error("PARAM '" + name + "' = '" + value +
                           "' cannot be written: the name must be one word not starting with "
                           "'#', the value non-empty words separated by single spaces");
    }
  }
  auto bad = [](const char* what, size_t k, double stamp, const char* problem) {
    return Status::Error(std::string(what) + " " + std::to_string(k) + " (t=" +
                         FormatDouble(stamp) + ") " + problem);
  };
  for (size_t k = 0; k < log.mounts.size(); ++k) {
    const StampedPose3& m = log.mounts[k];
    if (!std::isfinite(m.stamp_seconds) || !IsWritablePose(m.pose)) {
      return bad("MOUNT", k, m.stamp_seconds, "has a non-finite stamp or is not a rigid pose");
    }
  }
  for (size_t k = 0; k < log.truth.size(); ++k) {
    const StampedPose3& m = log.truth[k];
    if (!std::isfinite(m.stamp_seconds) || !IsWritablePose(m.pose)) {
      return bad("TRUTH", k, m.stamp_seconds, "has a non-finite stamp or is not a rigid pose");
    }
  }
  for (size_t k = 0; k < log.marg.size(); ++k) {
    const MargSample& m = log.marg[k];
    if (!std::isfinite(m.stamp_seconds) || !m.gyro_radps.allFinite() ||
        !m.accel_mps2.allFinite() || !m.magnetometer.allFinite()) {
      return bad("MARG", k, m.stamp_seconds, "has a non-finite value");
    }
  }
  for (size_t k = 0; k < log.attitudes.size(); ++k) {
    const AttitudeReading& a = log.attitudes[k];
    if (!AllFinite({a.stamp_seconds, a.roll_radians, a.pitch_radians, a.yaw_radians})) {
      return bad("ATTITUDE", k, a.stamp_seconds, "has a non-finite value");
    }
  }
  for (size_t k = 0; k < log.altitudes.size(); ++k) {
    const AltitudeReading& a = log.altitudes[k];
    if (!AllFinite({a.stamp_seconds, a.height_meters})) {
      return bad("ALTITUDE", k, a.stamp_seconds, "has a non-finite value");
    }
  }
  for (size_t k = 0; k < log.odometry.size(); ++k) {
    const OdometryReading& o = log.odometry[k];
    if (!std::isfinite(o.stamp_seconds) || !o.pose.ToVector().allFinite()) {
      return bad("ODOM", k, o.stamp_seconds, "has a non-finite value");
    }
  }
  for (size_t k = 0; k < log.commands.size(); ++k) {
    const VelocityCommand& c = log.commands[k];
    if (!AllFinite({c.stamp_seconds, c.forward_mps, c.left_mps, c.yaw_rate_radps})) {
      return bad("COMMAND", k, c.stamp_seconds, "has a non-finite value");
    }
  }
  for (size_t k = 0; k < log.images.size(); ++k) {
    const CameraImage& image = log.images[k];
    if (!std::isfinite(image.stamp_seconds) || !IsPlainWord(image.path)) {
      return bad("IMAGE", k, image.stamp_seconds,
                 "has a non-finite stamp or a path that is empty, starts with '#' or contains "
                 "white space");
    }
  }
  std::vector<std::pair<double, double>> fans(log.lasers.size());
  for (size_t k = 0; k < log.lasers.size(); ++k) {
    const LaserScan& scan = log.lasers[k].scan;
    const std::string which = "LASER " + std::to_string(k) + " (t=" +
                              FormatDouble(scan.stamp_seconds) + ")";
    if (scan.angles_radians.size() != scan.ranges_meters.size()) {
      return Status::Error(which + " has " + std::to_string(scan.angles_radians.size()) +
                           " angles but " + std::to_string(scan.ranges_meters.size()) +
                           " ranges");
    }
    if (scan.ranges_meters.size() > static_cast<size_t>(kMaxBeams)) {
      return Status::Error(which + " has more than " + std::to_string(kMaxBeams) + " beams");
    }
    if (!AllFinite({scan.stamp_seconds, scan.range_min_meters, scan.range_max_meters}) ||
        !(scan.range_min_meters >= 0.0 && scan.range_max_meters > scan.range_min_meters)) {
      return Status::Error(which + " needs a finite stamp and 0 <= range_min < range_max");
    }
    HETSLAM_RETURN_IF_ERROR(LaserFan(scan, which, &fans[k].first, &fans[k].second));
  }

  // The merge: at each step the smallest stamp among the heads of the per-type queues, ties in
  // the order of `kinds` (MOUNT first, so that a scan gets the mount of its own stamp).
  struct Kind {
    size_t size;
    std::function<double(size_t)> stamp;
    std::function<std::string(size_t)> format;
  };
  auto stamp_text = [](double stamp) { return FormatDouble(stamp); };
  const std::vector<Kind> kinds = {
      {log.mounts.size(), [&](size_t k) { return log.mounts[k].stamp_seconds; },
       [&](size_t k) {
         return "MOUNT " + stamp_text(log.mounts[k].stamp_seconds) + " " +
                FormatPose(log.mounts[k].pose);
       }},
      {log.odometry.size(), [&](size_t k) { return log.odometry[k].stamp_seconds; },
       [&](size_t k) {
         const OdometryReading& o = log.odometry[k];
         return "ODOM " + stamp_text(o.stamp_seconds) + " " + FormatDouble(o.pose.x()) + " " +
                FormatDouble(o.pose.y()) + " " + FormatDouble(o.pose.theta());
       }},
      {log.marg.size(), [&](size_t k) { return log.marg[k].stamp_seconds; },
       [&](size_t k) {
         const MargSample& m = log.marg[k];
         std::string line = "MARG " + stamp_text(m.stamp_seconds);
         for (const Eigen::Vector3d* v :
              {&m.gyro_radps, &m.accel_mps2, &m.magnetometer}) {
           for (int i = 0; i < 3; ++i) line += " " + FormatDouble((*v)[i]);
         }
         return line;
       }},
      {log.attitudes.size(), [&](size_t k) { return log.attitudes[k].stamp_seconds; },
       [&](size_t k) {
         const AttitudeReading& a = log.attitudes[k];
         return "ATTITUDE " + stamp_text(a.stamp_seconds) + " " + FormatDouble(a.roll_radians) +
                " " + FormatDouble(a.pitch_radians) + " " + FormatDouble(a.yaw_radians);
       }},
      {log.altitudes.size(), [&](size_t k) { return log.altitudes[k].stamp_seconds; },
       [&](size_t k) {
         const AltitudeReading& a = log.altitudes[k];
         return "ALTITUDE " + stamp_text(a.stamp_seconds) + " " + FormatDouble(a.height_meters);
       }},
      {log.commands.size(), [&](size_t k) { return log.commands[k].stamp_seconds; },
       [&](size_t k) {
         const VelocityCommand& c = log.commands[k];
         return "COMMAND " + stamp_text(c.stamp_seconds) + " " + FormatDouble(c.forward_mps) + " " +
                FormatDouble(c.left_mps) + " " + FormatDouble(c.yaw_rate_radps);
       }},
      {log.truth.size(), [&](size_t k) { return log.truth[k].stamp_seconds; },
       [&](size_t k) {
         return "TRUTH " + stamp_text(log.truth[k].stamp_seconds) + " " +
                FormatPose(log.truth[k].pose);
       }},
      {log.lasers.size(), [&](size_t k) { return log.lasers[k].scan.stamp_seconds; },
       [&](size_t k) {
         const LaserScan& scan = log.lasers[k].scan;
         std::string line = "LASER " + stamp_text(scan.stamp_seconds) + " " +
                            std::to_string(scan.ranges_meters.size()) + " " +
                            FormatDouble(fans[k].first) + " " + FormatDouble(fans[k].second) +
                            " " + FormatDouble(scan.range_min_meters) + " " +
                            FormatDouble(scan.range_max_meters);
         for (double r : scan.ranges_meters) {
           line += " ";
           line += std::isnan(r) ? std::string("nan") : FormatDouble(r);
         }
         return line;
       }},
      {log.images.size(), [&](size_t k) { return log.images[k].stamp_seconds; },
       [&](size_t k) {
         return "IMAGE " + stamp_text(log.images[k].stamp_seconds) + " " + log.images[k].path;
       }},
  };
  constexpr size_t kMountKind = 0;
  constexpr size_t kLaserKind = 7;

  // Every scan's robot_T_sensor must be what the reader will rebuild from the MOUNTs.
  {
    std::vector<size_t> next(kinds.size(), 0);
    Eigen::Isometry3d in_force = Eigen::Isometry3d::Identity();
    while (true) {
      size_t pick = kinds.size();
      for (size_t t : {kMountKind, kLaserKind}) {
        if (next[t] < kinds[t].size &&
            (pick == kinds.size() || kinds[t].stamp(next[t]) < kinds[pick].stamp(next[pick]))) {
          pick = t;
        }
      }
      if (pick == kinds.size()) break;
      const size_t k = next[pick]++;
      if (pick == kMountKind) {
        in_force = log.mounts[k].pose;
      } else if (!SamePose(in_force, log.lasers[k].scan.robot_T_sensor)) {
        return Status::Error(
            "LASER " + std::to_string(k) + " (t=" +
            FormatDouble(log.lasers[k].scan.stamp_seconds) +
            ") has a robot_T_sensor that differs from the MOUNT in force at its stamp (or "
            "identity when there is none): add a MOUNT, the log stores mounts only there");
      }
    }
  }

  FILE* file = std::fopen(path.c_str(), "w");
  if (file == nullptr) {
    return Status::Error("cannot open '" + path + "' for writing: " + std::strerror(errno));
  }
  std::fprintf(file, "HSLOG %d\n", kVersion);
  WriteComments(file, comment_lines);
  for (const auto& [name, value] : log.params) {
    std::fprintf(file, "PARAM %s %s\n", name.c_str(), value.c_str());
  }
  std::vector<size_t> next(kinds.size(), 0);
  while (true) {
    size_t pick = kinds.size();
    for (size_t t = 0; t < kinds.size(); ++t) {
      if (next[t] < kinds[t].size &&
          (pick == kinds.size() || kinds[t].stamp(next[t]) < kinds[pick].stamp(next[pick]))) {
        pick = t;
      }
    }
    if (pick == kinds.size()) break;
    const std::string line = kinds[pick].format(next[pick]++);
    std::fprintf(file, "%s\n", line.c_str());
  }
  return CloseWrittenFile(file, path);
}

Status ReadTeamManifest(const std::string& path, TeamManifest* manifest) {
  CHECK(manifest != nullptr) << "ReadTeamManifest: manifest is null";
  *manifest = TeamManifest();
  manifest->path = path;
  manifest->directory = DirectoryOf(path);
  std::ifstream in;
  HETSLAM_RETURN_IF_ERROR(OpenForReading(path, &in));
  auto where = [&](int line_number) { return path + ":" + std::to_string(line_number) + ": "; };

  bool have_header = false;
  std::map<std::string, int> robot_lines;                  // name -> line
  std::map<std::pair<std::string, int>, int> tag_lines;    // (family, id) -> line
  std::string line;
  std::vector<std::string> fields;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    text_fields::Split(line, &fields);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string& type = fields[0];
    if (!have_header) {
      int version = 0;
      const Status status = CheckHeader(fields, "HSTEAM", &version);
      if (!status.ok()) return Status::Error(where(line_number) + status.message());
      have_header = true;
      continue;
    }
    if (type == "robot") {
      if (fields.size() != 4) {
        return Status::Error(where(line_number) + "robot needs 3 fields (name kind directory), "
                             "found " + std::to_string(fields.size() - 1));
      }
      TeamRobot robot;
      robot.name = fields[1];
      robot.kind = fields[2];
      robot.directory = fields[3];
      robot.line_number = line_number;
      if (robot.kind != "wheeled" && robot.kind != "uav" && robot.kind != "humanoid") {
        return Status::Error(where(line_number) + "robot " + robot.name + " has unknown kind '" +
                             robot.kind + "' (wheeled, uav or humanoid)");
      }
      const auto [it, inserted] = robot_lines.emplace(robot.name, line_number);
      if (!inserted) {
        return Status::Error(where(line_number) + "robot name '" + robot.name +
                             "' is already used on line " + std::to_string(it->second));
      }
      manifest->robots.push_back(robot);
    } else if (type == "tag") {
      if (fields.size() != 10) {
        return Status::Error(where(line_number) + "tag needs 9 fields (id family size x y z roll "
                             "pitch yaw), found " + std::to_string(fields.size() - 1));
      }
      TagTruth tag;
      tag.line_number = line_number;
      long long id = 0;
      if (!ParseInteger(fields[1], 0, std::numeric_limits<int>::max(), &id)) {
        return Status::Error(where(line_number) + "tag id ('" + fields[1] +
                             "') is not a non-negative integer");
      }
      tag.id = static_cast<int>(id);
      tag.family = fields[2];
      if (!ParseFiniteDouble(fields[3], &tag.size_meters) || !(tag.size_meters > 0.0)) {
        return Status::Error(where(line_number) + "tag size ('" + fields[3] +
                             "') is not a positive number of metres");
      }
      double v[6];
      for (int i = 0; i < 6; ++i) {
        if (!ParseFiniteDouble(fields[4 + i], &v[i])) {
          return Status::Error(where(line_number) + "tag " + kPoseNames[i] + " ('" +
                               fields[4 + i] + "') is not a finite number");
        }
      }
      tag.world_T_tag = PoseFromValues(v);
      const auto [it, inserted] =
          tag_lines.emplace(std::make_pair(tag.family, tag.id), line_number);
      if (!inserted) {
        return Status::Error(where(line_number) + "tag " + tag.family + " " + fields[1] +
                             " is already placed on line " + std::to_string(it->second));
      }
      manifest->tags.push_back(tag);
    } else if (type == "HSTEAM") {
      return Status::Error(where(line_number) + "HSTEAM header repeated");
    } else {
      return Status::Error(where(line_number) + "unknown message '" + type +
                           "' (robot or tag)");
    }
  }
  if (in.bad()) {
    return Status::Error("error reading '" + path + "' after line " +
                         std::to_string(line_number) + ": " + std::strerror(errno));
  }
  if (!have_header) {
    return Status::Error(where(std::max(1, line_number)) +
                         "missing 'HSTEAM 1' header: the file has no messages");
  }
  return Status::Ok();
}

Status WriteTeamManifest(const std::string& path, const TeamManifest& manifest,
                         const std::vector<std::string>& comment_lines) {
  std::set<std::string> names;
  for (const TeamRobot& robot : manifest.robots) {
    if (!IsPlainWord(robot.name) || !IsPlainWord(robot.directory)) {
      return Status::Error("robot '" + robot.name + "' in '" + robot.directory +
                           "': name and directory must be one word not starting with '#'");
    }
    if (robot.kind != "wheeled" && robot.kind != "uav" && robot.kind != "humanoid") {
      return Status::Error("robot " + robot.name + " has unknown kind '" + robot.kind + "'");
    }
    if (!names.insert(robot.name).second) {
      return Status::Error("robot name '" + robot.name + "' is used twice");
    }
  }
  std::set<std::pair<std::string, int>> tags;
  for (const TagTruth& tag : manifest.tags) {
    const std::string which = "tag " + tag.family + " " + std::to_string(tag.id);
    if (tag.id < 0 || !IsPlainWord(tag.family)) {
      return Status::Error(which + ": needs an id >= 0 and a one-word family");
    }
    if (!std::isfinite(tag.size_meters) || !(tag.size_meters > 0.0)) {
      return Status::Error(which + " has size " + FormatDouble(tag.size_meters) +
                           "; needs a positive size");
    }
    if (!IsWritablePose(tag.world_T_tag)) {
      return Status::Error(which + ": world_T_tag is not a finite rigid pose");
    }
    if (!tags.insert({tag.family, tag.id}).second) {
      return Status::Error(which + " is placed twice");
    }
  }
  FILE* file = std::fopen(path.c_str(), "w");
  if (file == nullptr) {
    return Status::Error("cannot open '" + path + "' for writing: " + std::strerror(errno));
  }
  std::fprintf(file, "HSTEAM %d\n", kVersion);
  WriteComments(file, comment_lines);
  for (const TeamRobot& robot : manifest.robots) {
    std::fprintf(file, "robot %s %s %s\n", robot.name.c_str(), robot.kind.c_str(),
                 robot.directory.c_str());
  }
  for (const TagTruth& tag : manifest.tags) {
    std::fprintf(file, "tag %d %s %s %s\n", tag.id, tag.family.c_str(),
                 FormatDouble(tag.size_meters).c_str(), FormatPose(tag.world_T_tag).c_str());
  }
  return CloseWrittenFile(file, path);
}


}  // namespace hetslam
