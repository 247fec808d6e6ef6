#include "core/carmen_log.h"

#include <sys/stat.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/file_io.h"
#include "core/robot_log_text.h"
#include "core/text_fields.h"
#include "glog/logging.h"

namespace hetslam {
namespace {

using text_fields::ParseDouble;
using text_fields::ParseFiniteDouble;
using text_fields::ParseInteger;

constexpr long long kMaxBeams = 100000;
constexpr double kDegToRad = M_PI / 180.0;

// PARAM names that change the FLASER beam geometry (see the header). The fov is read as
// radians when it is at most 2*pi (+ slack) and as degrees above that: CARMEN ini files give
// degrees (180), some converted logs give radians (3.14159); a fov above 2*pi radians cannot
// exist, so the reading is unambiguous for real lasers. The resolution is in degrees, as in
// CARMEN. The max range (metres) is this project's own key, written by WriteCarmenLog so
// that a written log reads back with the same validity limit.
constexpr char kParamFov[] = "laser_front_laser_fov";
constexpr char kParamResolution[] = "laser_front_laser_resolution";
constexpr char kParamMaxRange[] = "laser_front_laser_max_range";
constexpr double kFovDegreesAbove = 2.0 * M_PI + 1e-3;

// FLASER geometry in force while reading (defaults from the options, PARAMs override).
struct FlaserGeometry {
  double fov_radians = M_PI;
  bool has_resolution = false;
  double resolution_radians = 0.0;
  double max_range_meters = 81.0;
};

// Beam angles of an n-beam FLASER message, as documented in carmen_log.h.
std::vector<double> FlaserAngles(int n, const FlaserGeometry& g) {
  if (n == 1) return {0.0};  // a single beam looks straight ahead
  double increment = 0.0;
  if (g.has_resolution) {
    increment = g.resolution_radians;
  } else {
    increment = (n % 2 == 1) ? g.fov_radians / (n - 1) : g.fov_radians / n;
  }
  return EvenlySpacedAngles(n, -0.5 * g.fov_radians, increment);
}

Eigen::Isometry3d PlanarIsometry(const Pose2& pose) {
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = Eigen::AngleAxisd(pose.theta(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  iso.translation() = Eigen::Vector3d(pose.x(), pose.y(), 0.0);
  return iso;
}

// Magnitude limits of CARMEN fields, as for robot logs (core/robot_log_text.h).
constexpr double kMaxPositionMeters = robot_log_text::kMaxPositionMeters;
constexpr double kMaxStampSeconds = robot_log_text::kMaxStampSeconds;

// Cursor over the fields of one message; every getter names the message and field in its
// error so that the caller only has to prefix "file:line: ".
class FieldReader {
 public:
  FieldReader(const std::vector<std::string>& fields, const std::string& type)
      : fields_(fields), type_(type) {}

  size_t position() const { return next_; }
  size_t remaining() const { return fields_.size() - next_; }

  Status Finite(const char* name, double* value) {
    if (next_ >= fields_.size()) return Missing(name);
    const std::string& f = fields_[next_++];
    if (!ParseFiniteDouble(f, value)) {
      return Status::Error(type_ + " field " + name + " ('" + f + "') is not a finite number");
    }
    return Status::Ok();
  }

  // A finite number with |value| <= limit (positions: 1e7 m, stamps: 1e12 s; beyond them a
  // value is corrupt and would overflow a grid or a time integration).
  Status Bounded(const char* name, double limit, double* value) {
    HETSLAM_RETURN_IF_ERROR(Finite(name, value));
    if (std::abs(*value) > limit) {
      return Status::Error(type_ + " field " + name + " (" + robot_log_text::FormatDouble(*value) +
                           ") is beyond +-" + robot_log_text::FormatDouble(limit));
    }
    return Status::Ok();
  }

  // A range reading: any number; "nan" and infinities become NaN (an invalid beam).
  Status Range(int index, double* value) {
    if (next_ >= fields_.size()) return Missing("range");
    const std::string& f = fields_[next_++];
    double v = 0.0;
    if (!ParseDouble(f, &v)) {
      return Status::Error(type_ + " range " + std::to_string(index) + " ('" + f +
                           "') is not a number");
    }
    *value = std::isfinite(v) ? v : std::numeric_limits<double>::quiet_NaN();
    return Status::Ok();
  }

  Status Remission(int index) {
    if (next_ >= fields_.size()) return Missing("remission");
    const std::string& f = fields_[next_++];
    double v = 0.0;
    if (!ParseDouble(f, &v)) {
      return Status::Error(type_ + " remission " + std::to_string(index) + " ('" + f +
                           "') is not a number");
    }
    return Status::Ok();
  }

  Status Word(const char* name, std::string* value) {
    if (next_ >= fields_.size()) return Missing(name);
    *value = fields_[next_++];
    return Status::Ok();
  }

  // A count of `what` ("ranges", "remissions") that must be in [0, kMaxBeams] and leave at
  // least `trailing_fields` fields after the counted ones.
  Status Count(const char* what, size_t trailing_fields, const char* trailing_description,
               int* count) {
    if (next_ >= fields_.size()) return Missing("count");
    const std::string& f = fields_[next_++];
    long long n = 0;
    if (!ParseInteger(f, std::numeric_limits<long long>::min(),
                      std::numeric_limits<long long>::max(), &n)) {
      return Status::Error(type_ + " count of " + what + " ('" + f + "') is not an integer");
    }
    if (n < 0 || n > kMaxBeams) {
      return Status::Error(type_ + " count of " + what + " " + f + " is out of range [0, " +
                           std::to_string(kMaxBeams) + "]");
    }
    const size_t follow = remaining();
    if (static_cast<size_t>(n) + trailing_fields > follow) {
      return Status::Error(type_ + " declares " + std::to_string(n) + " " + what +
                           " but only " + std::to_string(follow) + " fields follow (needs " +
                           std::to_string(n + trailing_fields) + ": the " + what + ", then " +
                           trailing_description + ")");
    }
    *count = static_cast<int>(n);
    return Status::Ok();
  }

  Status ExpectEnd() const {
    if (next_ != fields_.size()) {
      return Status::Error(type_ + " has " + std::to_string(fields_.size() - next_) +
                           " unexpected extra field(s) at the end (first: '" + fields_[next_] +
                           "')");
    }
    return Status::Ok();
  }

 private:
  Status Missing(const char* name) const {
    return Status::Error(type_ + " is truncated: field " + name + " missing (only " +
                         std::to_string(fields_.size()) + " fields on the line)");
  }

  const std::vector<std::string>& fields_;
  const std::string type_;
  size_t next_ = 1;  // fields_[0] is the message type
};

// ipc_timestamp ipc_hostname logger_timestamp; returns ipc_timestamp.
Status ReadTimestamps(FieldReader* r, double* ipc_timestamp) {
  std::string host;
  double logger_timestamp = 0.0;
  HETSLAM_RETURN_IF_ERROR(r->Bounded("ipc_timestamp", kMaxStampSeconds, ipc_timestamp));
  HETSLAM_RETURN_IF_ERROR(r->Word("ipc_hostname", &host));
  HETSLAM_RETURN_IF_ERROR(r->Bounded("logger_timestamp", kMaxStampSeconds, &logger_timestamp));
  return Status::Ok();
}

Status ParseFlaser(const std::vector<std::string>& fields, const FlaserGeometry& geometry,
                   const CarmenReadOptions& options, LaserReading* reading) {
  FieldReader r(fields, "FLASER");
  int n = 0;
  HETSLAM_RETURN_IF_ERROR(
      r.Count("ranges", 9,
              "x y theta odom_x odom_y odom_theta ipc_timestamp ipc_hostname logger_timestamp",
              &n));
  LaserScan& scan = reading->scan;
  scan.ranges_meters.resize(n);
  for (int i = 0; i < n; ++i) HETSLAM_RETURN_IF_ERROR(r.Range(i, &scan.ranges_meters[i]));
  double x, y, theta, odom_x, odom_y, odom_theta;
  HETSLAM_RETURN_IF_ERROR(r.Bounded("x", kMaxPositionMeters, &x));
  HETSLAM_RETURN_IF_ERROR(r.Bounded("y", kMaxPositionMeters, &y));
  HETSLAM_RETURN_IF_ERROR(r.Finite("theta", &theta));
  HETSLAM_RETURN_IF_ERROR(r.Bounded("odom_x", kMaxPositionMeters, &odom_x));
  HETSLAM_RETURN_IF_ERROR(r.Bounded("odom_y", kMaxPositionMeters, &odom_y));
  HETSLAM_RETURN_IF_ERROR(r.Finite("odom_theta", &odom_theta));
  HETSLAM_RETURN_IF_ERROR(ReadTimestamps(&r, &scan.stamp_seconds));
  HETSLAM_RETURN_IF_ERROR(r.ExpectEnd());
  scan.angles_radians = FlaserAngles(n, geometry);
  scan.range_min_meters = options.range_min_meters;
  scan.range_max_meters = geometry.max_range_meters;
  scan.robot_T_sensor = Eigen::Isometry3d::Identity();
  reading->odometry_pose = Pose2(odom_x, odom_y, odom_theta);
  reading->has_odometry_pose = true;
  return Status::Ok();
}

// The header shared by ROBOTLASER1 and RAWLASER1, the ranges and the remissions.
Status ParseLaserBody(FieldReader* r, size_t trailing_fields, const char* trailing_description,
                      const CarmenReadOptions& options, LaserScan* scan) {
  double laser_type, start_angle, fov, angular_res, max_range, accuracy, remission_mode;
  HETSLAM_RETURN_IF_ERROR(r->Finite("laser_type", &laser_type));
  HETSLAM_RETURN_IF_ERROR(r->Finite("start_angle", &start_angle));
  HETSLAM_RETURN_IF_ERROR(r->Finite("fov", &fov));
  HETSLAM_RETURN_IF_ERROR(r->Finite("angular_res", &angular_res));
  HETSLAM_RETURN_IF_ERROR(r->Finite("max_range", &max_range));
  HETSLAM_RETURN_IF_ERROR(r->Finite("accuracy", &accuracy));
  HETSLAM_RETURN_IF_ERROR(r->Finite("remission_mode", &remission_mode));
  int n = 0;
  // After the ranges: at least the remission count, then the trailing fields.
  const std::string after_ranges = std::string("the remission count, remissions, ") +
                                   trailing_description;
  HETSLAM_RETURN_IF_ERROR(r->Count("ranges", 1 + trailing_fields, after_ranges.c_str(), &n));
  scan->ranges_meters.resize(n);
  for (int i = 0; i < n; ++i) HETSLAM_RETURN_IF_ERROR(r->Range(i, &scan->ranges_meters[i]));
  int m = 0;
  HETSLAM_RETURN_IF_ERROR(r->Count("remissions", trailing_fields, trailing_description, &m));
  for (int i = 0; i < m; ++i) HETSLAM_RETURN_IF_ERROR(r->Remission(i));
  HETSLAM_RETURN_IF_ERROR(CheckBeamAngles(n, start_angle, angular_res, "start_angle", "angular_res"));
  scan->angles_radians = EvenlySpacedAngles(n, start_angle, angular_res);
  scan->range_min_meters = options.range_min_meters;
  scan->range_max_meters = max_range;
  return Status::Ok();
}

Status ParseRobotLaser(const std::vector<std::string>& fields, const CarmenReadOptions& options,
                       LaserReading* reading) {
  FieldReader r(fields, "ROBOTLASER1");
  LaserScan& scan = reading->scan;
  HETSLAM_RETURN_IF_ERROR(ParseLaserBody(
      &r, 14,
      "laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv forward_safety "
      "side_safety turn_axis ipc_timestamp ipc_hostname logger_timestamp",
      options, &scan));
  double laser_x, laser_y, laser_theta, robot_x, robot_y, robot_theta, unused;
  HETSLAM_RETURN_IF_ERROR(r.Bounded("laser_x", kMaxPositionMeters, &laser_x));
  HETSLAM_RETURN_IF_ERROR(r.Bounded("laser_y", kMaxPositionMeters, &laser_y));
  HETSLAM_RETURN_IF_ERROR(r.Finite("laser_theta", &laser_theta));
  HETSLAM_RETURN_IF_ERROR(r.Bounded("robot_x", kMaxPositionMeters, &robot_x));
  HETSLAM_RETURN_IF_ERROR(r.Bounded("robot_y", kMaxPositionMeters, &robot_y));
  HETSLAM_RETURN_IF_ERROR(r.Finite("robot_theta", &robot_theta));
  HETSLAM_RETURN_IF_ERROR(r.Finite("tv", &unused));
  HETSLAM_RETURN_IF_ERROR(r.Finite("rv", &unused));
  HETSLAM_RETURN_IF_ERROR(r.Finite("forward_safety", &unused));
  HETSLAM_RETURN_IF_ERROR(r.Finite("side_safety", &unused));
  HETSLAM_RETURN_IF_ERROR(r.Finite("turn_axis", &unused));
  HETSLAM_RETURN_IF_ERROR(ReadTimestamps(&r, &scan.stamp_seconds));
  HETSLAM_RETURN_IF_ERROR(r.ExpectEnd());
  // Both poses are in the odometry frame: robot_T_laser = odom_T_robot^-1 * odom_T_laser.
  const Pose2 odom_T_robot(robot_x, robot_y, robot_theta);
  const Pose2 odom_T_laser(laser_x, laser_y, laser_theta);
  scan.robot_T_sensor = PlanarIsometry(Between(odom_T_robot, odom_T_laser));
  reading->odometry_pose = odom_T_robot;
  reading->has_odometry_pose = true;
  return Status::Ok();
}

Status ParseRawLaser(const std::vector<std::string>& fields, const CarmenReadOptions& options,
                     LaserReading* reading) {
  FieldReader r(fields, "RAWLASER1");
  LaserScan& scan = reading->scan;
  HETSLAM_RETURN_IF_ERROR(
      ParseLaserBody(&r, 3, "ipc_timestamp ipc_hostname logger_timestamp", options, &scan));
  HETSLAM_RETURN_IF_ERROR(ReadTimestamps(&r, &scan.stamp_seconds));
  HETSLAM_RETURN_IF_ERROR(r.ExpectEnd());
  scan.robot_T_sensor = Eigen::Isometry3d::Identity();
  reading->has_odometry_pose = false;
  return Status::Ok();
}

Status ParseOdom(const std::vector<std::string>& fields, OdometryReading* reading) {
  FieldReader r(fields, "ODOM");
  double x, y, theta, unused;
  HETSLAM_RETURN_IF_ERROR(r.Bounded("x", kMaxPositionMeters, &x));
  HETSLAM_RETURN_IF_ERROR(r.Bounded("y", kMaxPositionMeters, &y));
  HETSLAM_RETURN_IF_ERROR(r.Finite("theta", &theta));
  HETSLAM_RETURN_IF_ERROR(r.Finite("tv", &unused));
  HETSLAM_RETURN_IF_ERROR(r.Finite("rv", &unused));
  HETSLAM_RETURN_IF_ERROR(r.Finite("accel", &unused));
  HETSLAM_RETURN_IF_ERROR(ReadTimestamps(&r, &reading->stamp_seconds));
  HETSLAM_RETURN_IF_ERROR(r.ExpectEnd());
  reading->pose = Pose2(x, y, theta);
  return Status::Ok();
}

// PARAM name value [ipc_timestamp ipc_hostname logger_timestamp]. Geometry PARAMs must be
// positive numbers; they update `geometry` for the FLASER lines that follow.
Status ParseParam(const std::vector<std::string>& fields, FlaserGeometry* geometry,
                  std::map<std::string, std::string>* params) {
  if (fields.size() < 3) {
    return Status::Error("PARAM is truncated: needs a name and a value");
  }
  const std::string& name = fields[1];
  const std::string& value = fields[2];
  const bool is_geometry = name == kParamFov || name == kParamResolution || name == kParamMaxRange;
  if (is_geometry) {
    double v = 0.0;
    if (!ParseFiniteDouble(value, &v) || !(v > 0.0)) {
      return Status::Error("PARAM " + name + " value '" + value + "' is not a positive number");
    }
    if (name == kParamFov) {
      geometry->fov_radians = v > kFovDegreesAbove ? v * kDegToRad : v;
      if (geometry->fov_radians > kFovDegreesAbove) {
        return Status::Error("PARAM " + name + " value '" + value + "' exceeds 360 degrees");
      }
    } else if (name == kParamResolution) {
      geometry->has_resolution = true;
      geometry->resolution_radians = v * kDegToRad;
    } else {
      geometry->max_range_meters = v;
    }
  }
  (*params)[name] = value;
  return Status::Ok();
}

std::string FormatDouble(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

}  // namespace

Status ReadCarmenLog(const std::string& path, const CarmenReadOptions& options, CarmenLog* log) {
  CHECK(log != nullptr) << "ReadCarmenLog: log is null";
  *log = CarmenLog();
  if (!(options.flaser_fov_radians > 0.0 && options.flaser_fov_radians <= 2.0 * M_PI + 1e-9)) {
    return Status::Error("invalid CarmenReadOptions: flaser_fov_radians must be in (0, 2*pi] (got " +
                         FormatDouble(options.flaser_fov_radians) + ")");
  }
  if (!(options.flaser_max_range_meters > options.range_min_meters) ||
      !std::isfinite(options.range_min_meters)) {
    return Status::Error(
        "invalid CarmenReadOptions: need finite range_min_meters < flaser_max_range_meters "
        "(got " + FormatDouble(options.range_min_meters) + ", " +
        FormatDouble(options.flaser_max_range_meters) + ")");
  }

  struct stat info;
  if (stat(path.c_str(), &info) != 0) {
    return Status::Error("cannot open '" + path + "': " + std::strerror(errno));
  }
  if (S_ISDIR(info.st_mode)) {
    return Status::Error("cannot open '" + path + "': Is a directory");
  }
  std::ifstream in(path);
  if (!in) return Status::Error("cannot open '" + path + "': " + std::strerror(errno));

  FlaserGeometry geometry;
  geometry.fov_radians = options.flaser_fov_radians;
  geometry.max_range_meters = options.flaser_max_range_meters;

  CarmenReadStats& stats = log->stats;
  auto warn = [&](int line_number, const std::string& message) {
    if (static_cast<int>(log->warnings.size()) < options.max_warnings_kept) {
      log->warnings.push_back(path + ":" + std::to_string(line_number) + ": " + message);
    }
  };

  std::string line;
  std::vector<std::string> fields;
  int line_number = 0;
  double last_laser_stamp = 0.0, last_odometry_stamp = 0.0;
  while (std::getline(in, line)) {
    ++line_number;
    ++stats.lines;
    text_fields::Split(line, &fields);
    if (fields.empty() || fields[0][0] == '#') {
      ++stats.comment_lines;
      continue;
    }
    const std::string& type = fields[0];
    Status status;
    if (type == "FLASER" || type == "ROBOTLASER1" || type == "RAWLASER1") {
      LaserReading reading;
      reading.line_number = line_number;
      if (type == "FLASER") {
        status = ParseFlaser(fields, geometry, options, &reading);
      } else if (type == "ROBOTLASER1") {
        status = ParseRobotLaser(fields, options, &reading);
      } else {
        status = ParseRawLaser(fields, options, &reading);
      }
      if (status.ok()) {
        if (stats.lasers_read > 0 && reading.scan.stamp_seconds < last_laser_stamp) {
          ++stats.laser_timestamps_backwards;
          warn(line_number, type + " timestamp " + FormatDouble(reading.scan.stamp_seconds) +
                                " is earlier than the previous laser timestamp " +
                                FormatDouble(last_laser_stamp) + " (kept in file order)");
        }
        ++stats.lasers_read;
        last_laser_stamp = reading.scan.stamp_seconds;
        if (options.keep_readings) log->lasers.push_back(std::move(reading));
      }
    } else if (type == "ODOM") {
      OdometryReading reading;
      reading.line_number = line_number;
      status = ParseOdom(fields, &reading);
      if (status.ok()) {
        if (stats.odometry_read > 0 && reading.stamp_seconds < last_odometry_stamp) {
          ++stats.odometry_timestamps_backwards;
          warn(line_number, "ODOM timestamp " + FormatDouble(reading.stamp_seconds) +
                                " is earlier than the previous ODOM timestamp " +
                                FormatDouble(last_odometry_stamp) + " (kept in file order)");
        }
        ++stats.odometry_read;
        last_odometry_stamp = reading.stamp_seconds;
        if (options.keep_readings) log->odometry.push_back(reading);
      }
    } else if (type == "PARAM") {
      status = ParseParam(fields, &geometry, &log->params);
    } else {
      ++stats.unknown_messages_skipped;
      ++stats.unknown_message_counts[type];
      continue;
    }
    if (!status.ok()) {
      if (!options.lenient) {
        return Status::Error(path + ":" + std::to_string(line_number) + ": " + status.message());
      }
      ++stats.malformed_lines_skipped;
      warn(line_number, status.message() + " (line skipped)");
    }
  }
  if (in.bad()) {
    return Status::Error("error reading '" + path + "' after line " +
                         std::to_string(line_number) + ": " + std::strerror(errno));
  }
  return Status::Ok();
}

struct CarmenMessageReader::State {
  std::string path;
  CarmenReadOptions options;
  Kind kind = Kind::kLaser;
  std::ifstream in;
  FlaserGeometry geometry;
  std::map<std::string, std::string> params;  // needed by ParseParam, not kept
  int line_number = 0;
  std::string line;
  std::vector<std::string> fields;
};

CarmenMessageReader::CarmenMessageReader(std::string path, const CarmenReadOptions& options, Kind kind)
    : state_(std::make_unique<State>()) {
  state_->path = std::move(path);
  state_->options = options;
  state_->kind = kind;
}

CarmenMessageReader::~CarmenMessageReader() = default;

Status CarmenMessageReader::Open() {
  State& s = *state_;
  s.in = std::ifstream(s.path);
  if (!s.in) return Status::Error("cannot open '" + s.path + "': " + std::strerror(errno));
  s.geometry = FlaserGeometry();
  s.geometry.fov_radians = s.options.flaser_fov_radians;
  s.geometry.max_range_meters = s.options.flaser_max_range_meters;
  s.line_number = 0;
  return Status::Ok();
}

Status CarmenMessageReader::Next(Measurement* measurement, bool* got) {
  State& s = *state_;
  *got = false;
  while (std::getline(s.in, s.line)) {
    ++s.line_number;
    text_fields::Split(s.line, &s.fields);
    if (s.fields.empty() || s.fields[0][0] == '#') continue;
    const std::string& type = s.fields[0];
    Status status;
    if (s.kind == Kind::kLaser && (type == "FLASER" || type == "ROBOTLASER1" || type == "RAWLASER1")) {
      LaserReading reading;
      reading.line_number = s.line_number;
      if (type == "FLASER") {
        status = ParseFlaser(s.fields, s.geometry, s.options, &reading);
      } else if (type == "ROBOTLASER1") {
        status = ParseRobotLaser(s.fields, s.options, &reading);
      } else {
        status = ParseRawLaser(s.fields, s.options, &reading);
      }
      if (status.ok()) {
        *measurement = std::move(reading);
        *got = true;
        return Status::Ok();
      }
    } else if (s.kind == Kind::kLaser && type == "PARAM") {
      status = ParseParam(s.fields, &s.geometry, &s.params);
    } else if (s.kind == Kind::kOdometry && type == "ODOM") {
      OdometryReading reading;
      reading.line_number = s.line_number;
      status = ParseOdom(s.fields, &reading);
      if (status.ok()) {
        *measurement = reading;
        *got = true;
        return Status::Ok();
      }
    } else {
      continue;
    }
    if (!status.ok() && !s.options.lenient) {
      return Status::Error(s.path + ":" + std::to_string(s.line_number) + ": " + status.message());
    }
  }
  if (s.in.bad()) {
    return Status::Error("error reading '" + s.path + "' after line " + std::to_string(s.line_number) + ": " +
                         std::strerror(errno));
  }
  return Status::Ok();
}

namespace {

// The FLASER geometry of all scans in `log`, as the PARAM values WriteCarmenLog writes.
struct WrittenGeometry {
  bool has_angles = false;  // some scan has >= 2 beams
  double fov_radians = 0.0;
  double resolution_degrees = 0.0;
  bool has_max_range = false;
  double max_range_meters = 0.0;
};

Status CheckGeometry(const CarmenLog& log, WrittenGeometry* g) {
  // Angles of the first scan with >= 2 beams define fov and resolution.
  for (const LaserReading& reading : log.lasers) {
    const LaserScan& scan = reading.scan;
    if (scan.angles_radians.size() >= 2) {
      g->has_angles = true;
      g->fov_radians = -2.0 * scan.angles_radians[0];
      // Mean spacing over the whole fan: less rounding than the first difference alone.
      const size_t n = scan.angles_radians.size();
      g->resolution_degrees =
          (scan.angles_radians[n - 1] - scan.angles_radians[0]) / (n - 1) / kDegToRad;
      break;
    }
  }
  if (g->has_angles && !(g->fov_radians > 0.0 && g->fov_radians <= kFovDegreesAbove &&
                         g->resolution_degrees > 0.0)) {
    return Status::Error(
        "scans cannot be written as FLASER: beams must start at -fov/2 < 0 with increasing "
        "angles (first angle " + FormatDouble(-0.5 * g->fov_radians) + " rad)");
  }
  FlaserGeometry reader_geometry;
  reader_geometry.fov_radians = g->fov_radians;
  reader_geometry.has_resolution = true;
  reader_geometry.resolution_radians = g->resolution_degrees * kDegToRad;
  for (size_t k = 0; k < log.lasers.size(); ++k) {
    const LaserScan& scan = log.lasers[k].scan;
    const std::string which = "laser reading " + std::to_string(k) + " (t=" +
                              FormatDouble(scan.stamp_seconds) + ")";
    if (scan.angles_radians.size() != scan.ranges_meters.size()) {
      return Status::Error(which + " has " + std::to_string(scan.angles_radians.size()) +
                           " angles but " + std::to_string(scan.ranges_meters.size()) +
                           " ranges");
    }
    if (!std::isfinite(scan.stamp_seconds) || !log.lasers[k].odometry_pose.ToVector().allFinite()) {
      return Status::Error(which + " has a non-finite timestamp or pose");
    }
    if (scan.ranges_meters.size() > static_cast<size_t>(kMaxBeams)) {
      return Status::Error(which + " has more than " + std::to_string(kMaxBeams) + " beams");
    }
    if (!g->has_max_range) {
      g->has_max_range = true;
      g->max_range_meters = scan.range_max_meters;
      if (!(std::isfinite(g->max_range_meters) && g->max_range_meters > 0.0)) {
        return Status::Error(which + " has a max range that is not a positive number");
      }
    } else if (scan.range_max_meters != g->max_range_meters) {
      return Status::Error(which + " has max range " + FormatDouble(scan.range_max_meters) +
                           " m but an earlier scan has " + FormatDouble(g->max_range_meters) +
                           " m; one FLASER log has one laser");
    }
    const int n = static_cast<int>(scan.angles_radians.size());
    const std::vector<double> expected = FlaserAngles(n, reader_geometry);
    for (int i = 0; i < n; ++i) {
      if (!(std::abs(expected[i] - scan.angles_radians[i]) < 1e-6)) {
        return Status::Error(which + " beam " + std::to_string(i) + " has angle " +
                             FormatDouble(scan.angles_radians[i]) + " rad; FLASER can only "
                             "store evenly spaced beams from -fov/2 shared by all scans "
                             "(expected " + FormatDouble(expected[i]) + ")");
      }
    }
  }
  return Status::Ok();
}

bool IsPlainWord(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (std::isspace(static_cast<unsigned char>(c))) return false;
  }
  return true;
}

}  // namespace

Status WriteCarmenLog(const std::string& path, const CarmenLog& log,
                      const std::vector<std::string>& comment_lines) {
  WrittenGeometry geometry;
  HETSLAM_RETURN_IF_ERROR(CheckGeometry(log, &geometry));
  for (const OdometryReading& odom : log.odometry) {
    if (!std::isfinite(odom.stamp_seconds) || !odom.pose.ToVector().allFinite()) {
      return Status::Error("odometry reading at t=" + FormatDouble(odom.stamp_seconds) +
                           " has a non-finite timestamp or pose");
    }
  }
  for (const auto& [name, value] : log.params) {
    if (!IsPlainWord(name) || !IsPlainWord(value)) {
      return Status::Error("PARAM '" + name + "' = '" + value +
                           "' cannot be written: names and values must be non-empty and "
                           "contain no white space");
    }
  }

  FILE* file = nullptr;
  HETSLAM_RETURN_IF_ERROR(OpenForWriting(path, "w", &file));
  WriteCommentLines(file, comment_lines);
  // PARAM lines carry CARMEN's ipc_timestamp ipc_hostname logger_timestamp tail.
  if (geometry.has_angles) {
    std::fprintf(file, "PARAM %s %.17g 0.000000 hetslam 0.000000\n", kParamFov,
                 geometry.fov_radians);
    std::fprintf(file, "PARAM %s %.17g 0.000000 hetslam 0.000000\n", kParamResolution,
                 geometry.resolution_degrees);
  }
  if (geometry.has_max_range) {
    std::fprintf(file, "PARAM %s %.17g 0.000000 hetslam 0.000000\n", kParamMaxRange,
                 geometry.max_range_meters);
  }
  for (const auto& [name, value] : log.params) {
    if (name == kParamFov || name == kParamResolution || name == kParamMaxRange) continue;
    std::fprintf(file, "PARAM %s %s 0.000000 hetslam 0.000000\n", name.c_str(), value.c_str());
  }

  // Merge the two streams by timestamp, each kept in its own order; at equal times the
  // odometry goes first (as in CARMEN logs, where the ODOM at a scan precedes its FLASER).
  size_t i = 0, j = 0;
  while (i < log.lasers.size() || j < log.odometry.size()) {
    const bool take_odom =
        j < log.odometry.size() &&
        (i >= log.lasers.size() || log.odometry[j].stamp_seconds <= log.lasers[i].scan.stamp_seconds);
    if (take_odom) {
      const OdometryReading& o = log.odometry[j++];
      std::fprintf(file, "ODOM %.9f %.9f %.9f 0 0 0 %.6f hetslam %.6f\n", o.pose.x(), o.pose.y(),
                   o.pose.theta(), o.stamp_seconds, o.stamp_seconds);
      continue;
    }
    const LaserReading& l = log.lasers[i++];
    const LaserScan& scan = l.scan;
    std::fprintf(file, "FLASER %zu", scan.ranges_meters.size());
    for (double r : scan.ranges_meters) {
      std::fprintf(file, " %.6f", scan.IsValidRange(r) ? r : scan.range_max_meters);
    }
    const Pose2 pose = l.has_odometry_pose ? l.odometry_pose : Pose2();
    std::fprintf(file, " %.9f %.9f %.9f %.9f %.9f %.9f %.6f hetslam %.6f\n", pose.x(), pose.y(),
                 pose.theta(), pose.x(), pose.y(), pose.theta(), scan.stamp_seconds,
                 scan.stamp_seconds);
  }
  return CommitWrittenFile(file, path);
}

}  // namespace hetslam
