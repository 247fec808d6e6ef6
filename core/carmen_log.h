// CARMEN laser logs (the `.clf` format of the Radish and Freiburg datasets).
//
// Messages read (one per line, fields separated by white space):
//   FLASER n r_1..r_n x y theta odom_x odom_y odom_theta ipc_timestamp ipc_hostname logger_timestamp
//   ROBOTLASER1 laser_type start_angle fov angular_res max_range accuracy remission_mode
//               n r_1..r_n m rem_1..rem_m laser_x laser_y laser_theta robot_x robot_y robot_theta
//               tv rv forward_safety side_safety turn_axis ipc_timestamp ipc_hostname logger_timestamp
//   RAWLASER1 laser_type start_angle fov angular_res max_range accuracy remission_mode
//             n r_1..r_n m rem_1..rem_m ipc_timestamp ipc_hostname logger_timestamp
//   ODOM x y theta tv rv accel ipc_timestamp ipc_hostname logger_timestamp
//   PARAM name value ...   (kept as strings; laser geometry params are used for FLASER beams)
// '#' lines and blank lines are comments. Other message types are skipped and counted.
// The timestamp used is ipc_timestamp.
//
// FLASER beam geometry: not in the message. Beams are spread evenly over
// `flaser_fov_radians` (default pi) starting at -fov/2, i.e. increment fov / n for
// n = 180 or 360 (SICK 1° / 0.5° modes: -90° .. +89°/+89.5°), and fov / (n - 1) when n is odd
// (361 beams: -90° .. +90°). PARAM laser_front_laser_fov / _resolution override the defaults
// for the FLASER lines after them (fov: radians when <= 2*pi, else degrees; resolution:
// degrees, as in CARMEN; a single beam looks straight ahead). Readings >= max range
// (`flaser_max_range_meters`, default 81.0: the shared logs write 81.83/81.91 for "no return";
// PARAM laser_front_laser_max_range, written by WriteCarmenLog, overrides it) are invalid and
// dropped downstream.
//
// Errors: a malformed line (too few fields, a non-numeric or non-finite field where a number
// is required, a beam count that is negative, over 100000 or larger than the fields present,
// a position beyond +-1e7 m or a timestamp beyond +-1e12 s, ROBOTLASER1/RAWLASER1 angles outside
// the range of CheckBeamAngles in core/laser_scan.h) is an error naming file and line, unless
// `lenient` is set, in which case the line is skipped and counted. Timestamps that go
// backwards are counted (and the first few reported in `warnings`), never reordered.
#ifndef HETSLAM_CORE_CARMEN_LOG_H_
#define HETSLAM_CORE_CARMEN_LOG_H_

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/laser_scan.h"
#include "core/measurement.h"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

struct CarmenReadOptions {
  bool lenient = false;                // skip malformed lines with a count instead of failing
  double flaser_fov_radians = M_PI;
  double flaser_max_range_meters = 81.0;
  double range_min_meters = 0.0;
  int max_warnings_kept = 10;          // how many warning messages to keep verbatim
  // false: CarmenLog::lasers and odometry stay empty (a validating pass that only counts,
  // checks and warns; CarmenReadStats::lasers_read and odometry_read still count them).
  bool keep_readings = true;
};

struct CarmenReadStats {
  int lines = 0;
  int comment_lines = 0;
  int malformed_lines_skipped = 0;     // only in lenient mode
  int unknown_messages_skipped = 0;
  int laser_timestamps_backwards = 0;
  int odometry_timestamps_backwards = 0;
  int lasers_read = 0;                 // well-formed laser lines (kept or not: keep_readings)
  int odometry_read = 0;               // well-formed ODOM lines
  std::map<std::string, int> unknown_message_counts;
};

struct CarmenLog {
  std::vector<LaserReading> lasers;      // in file order
  std::vector<OdometryReading> odometry; // in file order
  std::map<std::string, std::string> params;
  CarmenReadStats stats;
  std::vector<std::string> warnings;     // first few, "file:line: message"
};

Status ReadCarmenLog(const std::string& path, const CarmenReadOptions& options, CarmenLog* log);

// One kind of CARMEN message read lazily in file order: each Next() reads on to the next line
// of that kind and parses it exactly as ReadCarmenLog does (lasers with the FLASER geometry of
// the PARAM lines before them). The streaming reader of core/measurement_log.h runs one for the
// lasers and one for ODOM and merges them. Malformed lines are errors naming file and line, or
// with `lenient` skipped silently (ReadCarmenLog is the pass that counts and reports them);
// stats and warnings are not kept here.
class CarmenMessageReader {
 public:
  enum class Kind { kLaser, kOdometry };
  CarmenMessageReader(std::string path, const CarmenReadOptions& options, Kind kind);
  ~CarmenMessageReader();
  CarmenMessageReader(const CarmenMessageReader&) = delete;
  CarmenMessageReader& operator=(const CarmenMessageReader&) = delete;

  // Opens (or reopens from the start) the file.
  Status Open();
  // The next message of the kind as a LaserReading or an OdometryReading; *got is false at the
  // end of the file.
  Status Next(Measurement* measurement, bool* got);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Writes FLASER (using each scan's ranges; all scans must share one fan of evenly spaced
// beams starting at -fov/2 and one max range, stored as PARAM laser_front_laser_fov /
// _resolution / _max_range so that the reader recovers them, else an error; invalid ranges
// are written as the scan's max range; the sensor mount is not stored) and ODOM lines merged
// in timestamp order (ODOM first at equal times), with PARAM lines for the laser geometry and
// `log.params`, and `comment_lines` as '#' lines first. Used by the simulator.
Status WriteCarmenLog(const std::string& path, const CarmenLog& log,
                      const std::vector<std::string>& comment_lines);

}  // namespace hetslam

#endif  // HETSLAM_CORE_CARMEN_LOG_H_
