// One reader entry point for every log format: a file becomes a single time-ordered stream of
// measurements (core/measurement.h), the input of an online estimator. Format detection lives
// here: a file that starts with `#ROSBAG V2.0` is a ROS 1 bag (core/ros_bag.h), a file whose
// first non-blank, non-comment line starts with `HSLOG` is a hetslam robot log
// (core/robot_log.h), anything else is read as a CARMEN log (core/carmen_log.h). A ROS 2 bag
// (an SQLite .db3 file or its folder) is recognised and refused with a message: not supported.
//
// Order: the messages of each kind stay in file order (a kind whose stamps go backwards is not
// re-sorted; the readers count and report that), and the kinds are merged by stamp; at equal
// stamps in the order odometry, command, MARG, attitude, altitude, laser, image (a scan sees the
// motion and attitude readings stamped with it). A CARMEN scan keeps the odometry pose its line
// stores; the log's ODOM lines become odometry readings.
#ifndef HETSLAM_CORE_MEASUREMENT_LOG_H_
#define HETSLAM_CORE_MEASUREMENT_LOG_H_

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/measurement.h"
#include "core/ros_bag.h"
#include "core/status.h"
#include "core/trajectory_io.h"

namespace hetslam {

enum class LogFormat { kCarmen, kRobotLog, kRosBag };
const char* LogFormatName(LogFormat format);  // "CARMEN log", "hetslam robot log", "ROS 1 bag"

// Which format `path` is in (see above); an error naming the file if it cannot be opened or is
// a ROS 2 bag.
Status DetectLogFormat(const std::string& path, LogFormat* format);

struct MeasurementLogOptions {
  bool lenient = false;  // skip malformed lines with a count instead of failing
  // CARMEN FLASER lines record neither field of view nor max range (PARAM lines override).
  double flaser_fov_radians = M_PI;
  double flaser_max_range_meters = 81.0;
  int max_warnings_kept = 10;
  // ROS 1 bags: topics, laser mount, image folder (its lenient and max_warnings_kept are
  // taken from the fields above).
  RosBagReadOptions ros_bag;
  // Time gaps: a measurement stamped more than this many seconds after every earlier one (in
  // the merged order) is not bridged: the EKF would integrate the gap (a 10-hour pause moves the
  // next scan tens of metres; a corrupt 1e20 s stamp makes the data duration meaningless). An
  // error naming file:line, or with `lenient` the measurement is dropped, counted in
  // `time_gaps_dropped` and reported in `warnings`. 0 = no bound. Real logs have gaps of a
  // few seconds (Intel: 3.5 s, ACES: 3.0 s).
  double max_time_gap_seconds = 60.0;

  bool IsValid(std::string* error) const;
};

struct MeasurementLog {
  std::string path;
  LogFormat format = LogFormat::kCarmen;
  std::map<std::string, std::string> params;  // a ROS bag's: RosBagContents::params
  std::vector<Measurement> measurements;  // merged by stamp, see above
  // The log's ground truth as planar world_T_body (x, y, yaw of a robot log's TRUTH); empty
  // for CARMEN logs.
  std::vector<StampedPose2> truth;
  std::vector<std::string> warnings;  // first few, "file:line: message"
  int malformed_lines_skipped = 0;    // lenient mode only (a ROS bag's skipped messages)
  int time_gaps_dropped = 0;          // lenient mode only: measurements after a gap (see above)
  int num_scans = 0;

  // The time span of the laser scans (0 without scans).
  double ScanDurationSeconds() const;
};

Status ReadMeasurementLog(const std::string& path, const MeasurementLogOptions& options, MeasurementLog* log);

// The measurements of a log one at a time, in ReadMeasurementLog's order, with its errors,
// warnings and counts, without holding the whole log (issue #15: a long log in bounded memory).
// A CARMEN log is read lazily: Open() first reads it through once, keeping nothing but what it
// reports (the reader's errors and warnings, the time-gap bound, the counts), so a bad file
// fails before the first measurement as with ReadMeasurementLog; Next() then merges a laser
// and an ODOM reader (core/carmen_log.h) by stamp. Robot logs and ROS bags are read whole and
// handed out one at a time, each freed as it goes.
class MeasurementStream {
 public:
  static Status Open(const std::string& path, const MeasurementLogOptions& options,
                     std::unique_ptr<MeasurementStream>* stream);
  ~MeasurementStream();
  MeasurementStream(const MeasurementStream&) = delete;
  MeasurementStream& operator=(const MeasurementStream&) = delete;

  // What ReadMeasurementLog fills in, but `measurements` (empty): path, format, params, truth,
  // warnings, malformed_lines_skipped, time_gaps_dropped, num_scans.
  const MeasurementLog& info() const { return info_; }
  size_t num_measurements() const { return num_measurements_; }
  double ScanDurationSeconds() const { return scan_duration_seconds_; }

  // The next measurement; *got is false at the end. An error only if the file changed since
  // Open() (or cannot be read again).
  Status Next(Measurement* measurement, bool* got);

 private:
  struct CarmenMerge;
  MeasurementStream();

  MeasurementLog info_;
  size_t num_measurements_ = 0;
  double scan_duration_seconds_ = 0.0;
  MeasurementLogOptions options_;
  std::unique_ptr<CarmenMerge> carmen_;          // CARMEN logs
  std::vector<Measurement> whole_;               // other formats, handed out in order
  size_t next_ = 0;
};

// The ground truth stored in `path`: the TRUTH lines of a hetslam robot log (planar
// world_T_body, as MeasurementLog::truth), or else a `timestamp x y theta` trajectory file
// (core/trajectory_io.h, e.g. a simulator's truth.txt). Errors name the file; a robot log
// without TRUTH lines is an error.
Status ReadTruthTrajectory(const std::string& path, std::vector<StampedPose2>* truth);

struct RobotLog;
// The stream of a robot log already in memory (a simulator's output): `robot` is consumed.
// Image paths become `robot.directory`/path; params, warnings and the planar truth are kept.
MeasurementLog MeasurementLogFromRobotLog(RobotLog robot);

}  // namespace hetslam

#endif  // HETSLAM_CORE_MEASUREMENT_LOG_H_
