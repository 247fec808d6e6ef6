#include "core/measurement_log.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <utility>

#include "core/carmen_log.h"
#include "core/euler.h"
#include "core/robot_log.h"
#include "core/robot_log_text.h"
#include "glog/logging.h"

namespace hetslam {

const char* MeasurementKindName(const Measurement& m) {
  static constexpr std::array<const char*, std::variant_size_v<Measurement>> kNames = {
      "laser", "odometry", "marg", "attitude", "altitude", "command", "image"};
  return kNames[m.index()];
}

const char* LogFormatName(LogFormat format) {
  switch (format) {
    case LogFormat::kRobotLog:
      return "hetslam robot log";
    case LogFormat::kRosBag:
      return "ROS 1 bag";
    case LogFormat::kCarmen:
      break;
  }
  return "CARMEN log";
}

namespace {

constexpr char kRos2Refusal[] =
    ": a ROS 2 bag; hetslam reads ROS 1 bags only (convert it to a ROS 1 bag first, e.g. with the "
    "`rosbags-convert` tool)";

}  // namespace

Status DetectLogFormat(const std::string& path, LogFormat* format) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    if (std::filesystem::exists(std::filesystem::path(path) / "metadata.yaml", ec)) {
      return Status::Error("'" + path + "'" + kRos2Refusal);
    }
    return Status::Error("'" + path + "' is a folder, not a log file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error("cannot open '" + path + "': " + std::strerror(errno));
  // Binary formats by their magic bytes.
  char magic[16] = {};
  in.read(magic, sizeof(magic));
  const std::string head(magic, static_cast<size_t>(in.gcount()));
  if (head.compare(0, 9, "#ROSBAG V") == 0) {
    *format = LogFormat::kRosBag;
    return Status::Ok();
  }
  if (head.compare(0, 16, std::string("SQLite format 3\0", 16)) == 0) {
    return Status::Error("'" + path + "' is an SQLite file, probably" + kRos2Refusal);
  }
  in.clear();
  in.seekg(0);
  *format = LogFormat::kCarmen;
  std::string line;
  while (std::getline(in, line)) {
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    if (line.compare(start, 5, "HSLOG") == 0) *format = LogFormat::kRobotLog;
    break;
  }
  return Status::Ok();
}

Status ReadTruthTrajectory(const std::string& path, std::vector<StampedPose2>* truth) {
  CHECK(truth != nullptr);
  LogFormat format;
  HETSLAM_RETURN_IF_ERROR(DetectLogFormat(path, &format));
  if (format == LogFormat::kRosBag) {
    return Status::Error("'" + path + "' is a ROS bag; ground truth is read from a trajectory file or a robot log");
  }
  if (format != LogFormat::kRobotLog) return ReadTrajectory(path, truth);
  MeasurementLog log;
  HETSLAM_RETURN_IF_ERROR(ReadMeasurementLog(path, MeasurementLogOptions(), &log));
  if (log.truth.empty()) return Status::Error("'" + path + "' has no TRUTH lines");
  *truth = std::move(log.truth);
  return Status::Ok();
}

bool MeasurementLogOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(flaser_fov_radians > 0 && flaser_fov_radians <= 2 * M_PI)) {
    why << "flaser_fov_radians must be in (0, 2 pi], got " << flaser_fov_radians;
  } else if (!(flaser_max_range_meters > 0 && std::isfinite(flaser_max_range_meters))) {
    why << "flaser_max_range_meters must be > 0 and finite, got " << flaser_max_range_meters;
  } else if (max_warnings_kept < 0) {
    why << "max_warnings_kept must be >= 0, got " << max_warnings_kept;
  } else if (!(max_time_gap_seconds >= 0 && std::isfinite(max_time_gap_seconds))) {
    why << "max_time_gap_seconds must be >= 0 and finite (0 = no bound), got " << max_time_gap_seconds;
  } else {
    std::string ros_bag_error;
    if (!ros_bag.IsValid(&ros_bag_error)) why << ros_bag_error;
  }
  if (error != nullptr) *error = why.str();
  return why.str().empty();
}

double MeasurementLog::ScanDurationSeconds() const {
  double first = std::numeric_limits<double>::infinity(), last = -first;
  for (const Measurement& m : measurements) {
    if (const auto* laser = std::get_if<LaserReading>(&m)) {
      first = std::min(first, laser->scan.stamp_seconds);
      last = std::max(last, laser->scan.stamp_seconds);
    }
  }
  return last >= first ? last - first : 0.0;
}

namespace {

// Merge priority at equal stamps (see the header): lower first.
int TiePriority(const Measurement& m) {
  struct Visitor {
    int operator()(const OdometryReading&) const { return 0; }
    int operator()(const VelocityCommand&) const { return 1; }
    int operator()(const MargSample&) const { return 2; }
    int operator()(const AttitudeReading&) const { return 3; }
    int operator()(const AltitudeReading&) const { return 4; }
    int operator()(const LaserReading&) const { return 5; }
    int operator()(const CameraImage&) const { return 6; }
  };
  return std::visit(Visitor(), m);
}

// Appends the k-way merge of `streams` (each kept in its own order) to *out: at every step the
// head with the smallest (stamp, priority) is taken.
void MergeByStamp(std::vector<std::vector<Measurement>>* streams, std::vector<Measurement>* out) {
  size_t total = 0;
  for (const auto& s : *streams) total += s.size();
  out->reserve(out->size() + total);
  std::vector<size_t> next(streams->size(), 0);
  for (size_t n = 0; n < total; ++n) {
    int best = -1;
    double best_stamp = 0.0;
    int best_priority = 0;
    for (size_t k = 0; k < streams->size(); ++k) {
      if (next[k] >= (*streams)[k].size()) continue;
      const Measurement& m = (*streams)[k][next[k]];
      const double stamp = StampOf(m);
      const int priority = TiePriority(m);
      if (best < 0 || stamp < best_stamp || (stamp == best_stamp && priority < best_priority)) {
        best = static_cast<int>(k);
        best_stamp = stamp;
        best_priority = priority;
      }
    }
    out->push_back(std::move((*streams)[best][next[best]++]));
  }
}

template <typename T>
std::vector<Measurement> AsMeasurements(std::vector<T>* readings) {
  std::vector<Measurement> out;
  out.reserve(readings->size());
  for (T& r : *readings) out.emplace_back(std::move(r));
  readings->clear();
  return out;
}

CarmenReadOptions CarmenOptions(const MeasurementLogOptions& options) {
  CarmenReadOptions read;
  read.lenient = options.lenient;
  read.flaser_fov_radians = options.flaser_fov_radians;
  read.flaser_max_range_meters = options.flaser_max_range_meters;
  read.max_warnings_kept = options.max_warnings_kept;
  return read;
}

Status ReadCarmen(const std::string& path, const MeasurementLogOptions& options, MeasurementLog* log) {
  CarmenLog carmen;
  const Status status = ReadCarmenLog(path, CarmenOptions(options), &carmen);
  if (!status.ok()) return status;
  log->params = std::move(carmen.params);
  log->warnings = std::move(carmen.warnings);
  log->malformed_lines_skipped = carmen.stats.malformed_lines_skipped;
  std::vector<std::vector<Measurement>> streams;
  streams.push_back(AsMeasurements(&carmen.odometry));
  streams.push_back(AsMeasurements(&carmen.lasers));
  MergeByStamp(&streams, &log->measurements);
  return Status::Ok();
}

}  // namespace

MeasurementLog MeasurementLogFromRobotLog(RobotLog robot) {
  MeasurementLog log;
  log.path = robot.path;
  log.format = LogFormat::kRobotLog;
  log.params = std::move(robot.params);
  log.warnings = std::move(robot.warnings);
  log.malformed_lines_skipped = robot.stats.malformed_lines_skipped;
  for (const StampedPose3& pose : robot.truth) {
    const Eigen::Vector3d rpy = RollPitchYawFromRotation(pose.pose.linear());
    log.truth.push_back({pose.stamp_seconds, Pose2(pose.pose.translation().x(), pose.pose.translation().y(), rpy.z())});
  }
  for (CameraImage& image : robot.images) image.path = robot.ImagePath(image);
  std::vector<std::vector<Measurement>> streams;
  streams.push_back(AsMeasurements(&robot.odometry));
  streams.push_back(AsMeasurements(&robot.commands));
  streams.push_back(AsMeasurements(&robot.marg));
  streams.push_back(AsMeasurements(&robot.attitudes));
  streams.push_back(AsMeasurements(&robot.altitudes));
  streams.push_back(AsMeasurements(&robot.lasers));
  streams.push_back(AsMeasurements(&robot.images));
  MergeByStamp(&streams, &log.measurements);
  for (const Measurement& m : log.measurements) log.num_scans += std::holds_alternative<LaserReading>(m);
  return log;
}

namespace {

Status ReadHetslamRobotLog(const std::string& path, const MeasurementLogOptions& options, MeasurementLog* log) {
  RobotLogReadOptions read;
  read.lenient = options.lenient;
  read.max_warnings_kept = options.max_warnings_kept;
  RobotLog robot;
  const Status status = ReadRobotLog(path, read, &robot);
  if (!status.ok()) return status;
  *log = MeasurementLogFromRobotLog(std::move(robot));
  log->path = path;
  return Status::Ok();
}

Status ReadBag(const std::string& path, const MeasurementLogOptions& options, MeasurementLog* log) {
  RosBagReadOptions read = options.ros_bag;
  read.lenient = options.lenient;
  read.max_warnings_kept = options.max_warnings_kept;
  RosBagContents bag;
  HETSLAM_RETURN_IF_ERROR(ReadRosBag(path, read, &bag));
  log->params = std::move(bag.params);
  log->warnings = std::move(bag.warnings);
  log->malformed_lines_skipped = bag.malformed_messages_skipped;
  std::vector<std::vector<Measurement>> streams;
  streams.push_back(AsMeasurements(&bag.odometry));
  streams.push_back(AsMeasurements(&bag.commands));
  streams.push_back(AsMeasurements(&bag.marg));
  streams.push_back(AsMeasurements(&bag.attitudes));
  streams.push_back(AsMeasurements(&bag.lasers));
  streams.push_back(AsMeasurements(&bag.images));
  MergeByStamp(&streams, &log->measurements);
  return Status::Ok();
}

std::string NumberText(double value) {
  std::ostringstream out;
  out.precision(15);
  out << value;
  return out.str();
}

// The time-gap bound of MeasurementLogOptions::max_time_gap_seconds on the merged stream, one
// measurement at a time. The reference is the newest stamp accepted so far, so one corrupt
// stamp far in the future is dropped alone (lenient) and the stamps after it are compared with
// the ones before it.
class TimeGapBound {
 public:
  TimeGapBound(const MeasurementLogOptions& options, std::string path) : options_(options), path_(std::move(path)) {}

  // Whether `m` is kept; if not, *message says why (an error unless lenient).
  bool Keep(const Measurement& m, std::string* message) {
    if (options_.max_time_gap_seconds <= 0) return true;
    const double stamp = StampOf(m);
    if (std::isfinite(newest_) && stamp - newest_ > options_.max_time_gap_seconds) {
      *message = path_ + ":" + std::to_string(LineOf(m)) + ": " + MeasurementKindName(m) + " stamp " +
                 NumberText(stamp) + " is " + NumberText(stamp - newest_) + " s after the newest earlier stamp " +
                 NumberText(newest_) + " (line " + std::to_string(newest_line_) +
                 "): gaps over max_time_gap_seconds = " + NumberText(options_.max_time_gap_seconds) +
                 " s are not integrated";
      return false;
    }
    if (stamp > newest_) {
      newest_ = stamp;
      newest_line_ = LineOf(m);
    }
    return true;
  }

 private:
  MeasurementLogOptions options_;
  std::string path_;
  double newest_ = -std::numeric_limits<double>::infinity();
  int newest_line_ = 0;
};

// A dropped measurement's message kept in `log` (lenient), or the error.
Status DropForGap(const MeasurementLogOptions& options, const std::string& message, MeasurementLog* log) {
  if (!options.lenient) return Status::Error(message);
  if (log->time_gaps_dropped++ < options.max_warnings_kept) log->warnings.push_back(message + " (measurement dropped)");
  return Status::Ok();
}

Status BoundTimeGaps(const MeasurementLogOptions& options, MeasurementLog* log) {
  if (options.max_time_gap_seconds <= 0 || log->measurements.empty()) return Status::Ok();
  std::vector<Measurement> kept;
  kept.reserve(log->measurements.size());
  TimeGapBound bound(options, log->path);
  for (Measurement& m : log->measurements) {
    std::string message;
    if (!bound.Keep(m, &message)) {
      HETSLAM_RETURN_IF_ERROR(DropForGap(options, message, log));
      continue;
    }
    kept.push_back(std::move(m));
  }
  log->measurements = std::move(kept);
  return Status::Ok();
}

}  // namespace

Status ReadMeasurementLog(const std::string& path, const MeasurementLogOptions& options, MeasurementLog* log) {
  *log = MeasurementLog();
  log->path = path;
  std::string invalid;
  if (!options.IsValid(&invalid)) return Status::Error("invalid MeasurementLogOptions: " + invalid);
  const Status detected = DetectLogFormat(path, &log->format);
  if (!detected.ok()) return detected;
  Status status;
  switch (log->format) {
    case LogFormat::kRobotLog:
      status = ReadHetslamRobotLog(path, options, log);
      break;
    case LogFormat::kRosBag:
      status = ReadBag(path, options, log);
      break;
    case LogFormat::kCarmen:
      status = ReadCarmen(path, options, log);
      break;
  }
  if (!status.ok()) return status;
  HETSLAM_RETURN_IF_ERROR(BoundTimeGaps(options, log));
  log->num_scans = 0;
  for (const Measurement& m : log->measurements) log->num_scans += std::holds_alternative<LaserReading>(m);
  return Status::Ok();
}

// A laser and an ODOM reader of one CARMEN log merged by stamp as MergeByStamp merges the
// whole streams (odometry first, then lasers), then bounded by TimeGapBound.
struct MeasurementStream::CarmenMerge {
  CarmenMerge(const std::string& path, const MeasurementLogOptions& options) : bound(options, path) {
    const CarmenReadOptions read = CarmenOptions(options);
    readers.push_back(std::make_unique<CarmenMessageReader>(path, read, CarmenMessageReader::Kind::kOdometry));
    readers.push_back(std::make_unique<CarmenMessageReader>(path, read, CarmenMessageReader::Kind::kLaser));
    heads.resize(readers.size());
  }

  Status Open() {
    for (size_t k = 0; k < readers.size(); ++k) {
      HETSLAM_RETURN_IF_ERROR(readers[k]->Open());
      HETSLAM_RETURN_IF_ERROR(Fill(k));
    }
    return Status::Ok();
  }

  Status Fill(size_t k) {
    Measurement m;
    bool got = false;
    HETSLAM_RETURN_IF_ERROR(readers[k]->Next(&m, &got));
    heads[k] = got ? std::optional<Measurement>(std::move(m)) : std::nullopt;
    return Status::Ok();
  }

  // The next merged measurement, before the gap bound.
  Status NextMerged(Measurement* measurement, bool* got) {
    int best = -1;
    double best_stamp = 0.0;
    int best_priority = 0;
    for (size_t k = 0; k < heads.size(); ++k) {
      if (!heads[k].has_value()) continue;
      const double stamp = StampOf(*heads[k]);
      const int priority = TiePriority(*heads[k]);
      if (best < 0 || stamp < best_stamp || (stamp == best_stamp && priority < best_priority)) {
        best = static_cast<int>(k);
        best_stamp = stamp;
        best_priority = priority;
      }
    }
    *got = best >= 0;
    if (!*got) return Status::Ok();
    *measurement = std::move(*heads[best]);
    return Fill(best);
  }

  std::vector<std::unique_ptr<CarmenMessageReader>> readers;
  std::vector<std::optional<Measurement>> heads;
  TimeGapBound bound;
};

MeasurementStream::MeasurementStream() = default;
MeasurementStream::~MeasurementStream() = default;

Status MeasurementStream::Open(const std::string& path, const MeasurementLogOptions& options,
                               std::unique_ptr<MeasurementStream>* stream) {
  std::unique_ptr<MeasurementStream> s(new MeasurementStream());
  s->options_ = options;
  MeasurementLog& info = s->info_;
  info.path = path;
  std::string invalid;
  if (!options.IsValid(&invalid)) return Status::Error("invalid MeasurementLogOptions: " + invalid);
  HETSLAM_RETURN_IF_ERROR(DetectLogFormat(path, &info.format));
  if (info.format != LogFormat::kCarmen) {
    MeasurementLog whole;
    HETSLAM_RETURN_IF_ERROR(ReadMeasurementLog(path, options, &whole));
    s->scan_duration_seconds_ = whole.ScanDurationSeconds();
    s->whole_ = std::move(whole.measurements);
    s->num_measurements_ = s->whole_.size();
    info = std::move(whole);
    info.measurements.clear();
    *stream = std::move(s);
    return Status::Ok();
  }
  // The reader's pass: errors, warnings, params, counts; no reading kept.
  CarmenReadOptions check = CarmenOptions(options);
  check.keep_readings = false;
  CarmenLog carmen;
  HETSLAM_RETURN_IF_ERROR(ReadCarmenLog(path, check, &carmen));
  info.params = std::move(carmen.params);
  info.warnings = std::move(carmen.warnings);
  info.malformed_lines_skipped = carmen.stats.malformed_lines_skipped;
  // The merged pass: the time-gap bound and what is left.
  {
    CarmenMerge merge(path, options);
    HETSLAM_RETURN_IF_ERROR(merge.Open());
    double first = std::numeric_limits<double>::infinity(), last = -first;
    Measurement m;
    bool got = false;
    while (true) {
      HETSLAM_RETURN_IF_ERROR(merge.NextMerged(&m, &got));
      if (!got) break;
      std::string message;
      if (!merge.bound.Keep(m, &message)) {
        HETSLAM_RETURN_IF_ERROR(DropForGap(options, message, &info));
        continue;
      }
      ++s->num_measurements_;
      if (const auto* laser = std::get_if<LaserReading>(&m)) {
        ++info.num_scans;
        first = std::min(first, laser->scan.stamp_seconds);
        last = std::max(last, laser->scan.stamp_seconds);
      }
    }
    s->scan_duration_seconds_ = last >= first ? last - first : 0.0;
  }
  s->carmen_ = std::make_unique<CarmenMerge>(path, options);
  HETSLAM_RETURN_IF_ERROR(s->carmen_->Open());
  *stream = std::move(s);
  return Status::Ok();
}

Status MeasurementStream::Next(Measurement* measurement, bool* got) {
  *got = false;
  if (carmen_ == nullptr) {
    if (next_ >= whole_.size()) return Status::Ok();
    *measurement = std::move(whole_[next_]);
    whole_[next_++] = Measurement();  // its payload goes now
    *got = true;
    return Status::Ok();
  }
  while (true) {
    HETSLAM_RETURN_IF_ERROR(carmen_->NextMerged(measurement, got));
    if (!*got) return Status::Ok();
    std::string message;
    if (carmen_->bound.Keep(*measurement, &message)) return Status::Ok();
    if (!options_.lenient) return Status::Error(message);  // the file changed since Open()
  }
}

}  // namespace hetslam
