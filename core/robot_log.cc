#include "core/robot_log.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <utility>

#include "core/robot_log_text.h"
#include "core/text_fields.h"
#include "glog/logging.h"

namespace hetslam {

namespace {

using robot_log_text::CheckEndOfFile;
using robot_log_text::CheckHeader;
using robot_log_text::DirectoryOf;
using robot_log_text::FormatDouble;
using robot_log_text::JoinPath;
using robot_log_text::kMaxBeams;
using robot_log_text::kMaxPositionMeters;
using robot_log_text::kMaxRangeMeters;
using robot_log_text::kMaxRate;
using robot_log_text::kMaxStampSeconds;
using robot_log_text::kPoseNames;
using robot_log_text::OpenForReading;
using robot_log_text::PoseFromValues;
using text_fields::ParseDouble;
using text_fields::ParseFiniteDouble;
using text_fields::ParseInteger;

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
    HETSLAM_RETURN_IF_ERROR(FiniteAt(1, "stamp", stamp_seconds));
    return Bounded("stamp", *stamp_seconds, kMaxStampSeconds, "s");
  }

  // |value| <= limit (the magnitude limits of robot_log_text.h).
  Status Bounded(const char* name, double value, double limit, const char* unit) const {
    if (std::abs(value) <= limit) return Status::Ok();
    return Status::Error(type_ + " " + name + " " + FormatDouble(value) + " is beyond +-" + FormatDouble(limit) +
                         " " + unit);
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

Status ParseStampedPose(const std::vector<std::string>& fields, StampedPose3* pose) {
  MessageFields m(fields);
  double v[6];
  HETSLAM_RETURN_IF_ERROR(m.Numbers(kPoseNames, v));
  for (int i = 0; i < 3; ++i) HETSLAM_RETURN_IF_ERROR(m.Bounded(kPoseNames[i], v[i], kMaxPositionMeters, "m"));
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
  {
    const Status angles = CheckBeamAngles(static_cast<int>(n), angle_min, increment);
    if (!angles.ok()) return Status::Error("LASER " + angles.message());
  }
  HETSLAM_RETURN_IF_ERROR(m.FiniteAt(5, "range_min", &scan->range_min_meters));
  HETSLAM_RETURN_IF_ERROR(m.FiniteAt(6, "range_max", &scan->range_max_meters));
  if (!(scan->range_min_meters >= 0.0 && scan->range_max_meters > scan->range_min_meters)) {
    return Status::Error("LASER needs 0 <= range_min < range_max (got " + fields[5] + ", " +
                         fields[6] + ")");
  }
  HETSLAM_RETURN_IF_ERROR(m.Bounded("range_max", scan->range_max_meters, kMaxRangeMeters, "m"));
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
  for (int i = 0; i < 3; ++i) HETSLAM_RETURN_IF_ERROR(m.Bounded("gyro rate", v[i], kMaxRate, "rad/s"));
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
  HETSLAM_RETURN_IF_ERROR(m.Bounded("z", reading->height_meters, kMaxPositionMeters, "m"));
  return m.Stamp(&reading->stamp_seconds);
}

Status ParseOdom(const std::vector<std::string>& fields, OdometryReading* reading) {
  MessageFields m(fields);
  double v[3];
  HETSLAM_RETURN_IF_ERROR(m.Numbers({"x", "y", "theta"}, v));
  HETSLAM_RETURN_IF_ERROR(m.Bounded("x", v[0], kMaxPositionMeters, "m"));
  HETSLAM_RETURN_IF_ERROR(m.Bounded("y", v[1], kMaxPositionMeters, "m"));
  HETSLAM_RETURN_IF_ERROR(m.Stamp(&reading->stamp_seconds));
  reading->pose = Pose2(v[0], v[1], v[2]);
  return Status::Ok();
}

Status ParseCommand(const std::vector<std::string>& fields, VelocityCommand* reading) {
  MessageFields m(fields);
  double v[3];
  HETSLAM_RETURN_IF_ERROR(m.Numbers({"vx", "vy", "yaw_rate"}, v));
  HETSLAM_RETURN_IF_ERROR(m.Bounded("vx", v[0], kMaxRate, "m/s"));
  HETSLAM_RETURN_IF_ERROR(m.Bounded("vy", v[1], kMaxRate, "m/s"));
  HETSLAM_RETURN_IF_ERROR(m.Bounded("yaw_rate", v[2], kMaxRate, "rad/s"));
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
  if (!robot_log_text::StaysInside(fields[2])) {
    return Status::Error("IMAGE path '" + fields[2] +
                         "' leaves the log's folder (an absolute path or a '..' component)");
  }
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
  return CheckEndOfFile(in, path, line_number, have_header, "HSLOG");
}

}  // namespace hetslam
