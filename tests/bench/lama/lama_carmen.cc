// lama_carmen: LaMa's online SLAM (`lama::Slam2D` of iris_lama 1.3.1: scan-to-map Gauss–Newton
// matching on a dynamic likelihood field, predicted by odometry, no loop closure) on a CARMEN
// log, for the side-by-side benchmark tests/bench/run_lama.sh. Not part of hetslam's build:
// tests/bench/lama/CMakeLists.txt builds it against a LaMa install, and it links nothing of
// hetslam, so that its peak memory is LaMa's and the C++ runtime's only.
//
//   lama_carmen --log=intel.clf --trajectory=out/trajectory.txt [--distance_cutoff_meters=3]
//               [--max_range_meters=16] [--min_translation_meters=0.01]
//               [--min_rotation_radians=0.25] [--resolution_meters=0.05] [--nostage_times]
//
// Input (read as a stream, one line at a time; the log is never held whole):
//   FLASER n r_1..r_n x y theta odom_x odom_y odom_theta ipc_timestamp ipc_hostname logger_timestamp
//   ROBOTLASER1 laser_type start_angle fov angular_res max_range accuracy remission_mode
//               n r_1..r_n m rem_1..rem_m laser_x laser_y laser_theta robot_x robot_y robot_theta
//               tv rv forward_safety side_safety turn_axis ipc_timestamp ipc_hostname logger_timestamp
//   RAWLASER1 (as ROBOTLASER1 up to the remissions, then the three timestamp fields)
//   ODOM x y theta tv rv accel ipc_timestamp ipc_hostname logger_timestamp
//   PARAM laser_front_laser_fov | laser_front_laser_resolution | laser_front_laser_max_range VALUE
// read as hetslam's reader (core/carmen_log.h) reads them, so that both systems see the same
// scans: the stamp is ipc_timestamp; a FLASER's beams span the fov (default pi, or the PARAM:
// radians up to 2 pi, degrees above) from -fov/2 in steps of fov / n (fov / (n - 1) for odd n)
// or of the PARAM resolution (degrees); its odometry is odom_x/y/theta and the laser sits at the
// robot's origin; a ROBOTLASER1's odometry is robot_x/y/theta and its laser mount is
// robot^-1 * laser; a RAWLASER1 takes the pose of the last ODOM line before it. Readings at or
// above the no-return range (81 m, or the PARAM max range; ROBOTLASER1/RAWLASER1: the message's
// max_range) or at or below 0 are dropped, and so are readings at or above
// --max_range_meters (LaMa's ROS node does the same with its `mrange`). ODOM lines are checked
// and counted; the scans carry their own odometry. '#' and blank lines are comments; other
// messages are counted and skipped.
//
// Errors: a malformed line (too few or too many fields, a field that is not a finite number, a
// beam count outside 0..100000, a position beyond +-1e7 m, a stamp beyond +-1e12 s, a RAWLASER1
// before any ODOM line) stops the program with exit status 1 and a message naming file, line
// and field; so does a file that cannot be opened or written, a log without scans, a scan
// whose points would fall outside what LaMa's map can index (about +-1e6 m at 0.05 m cells) and
// a non-finite pose from LaMa. Bad flags: exit status 2. Readings that are not finite (nan, inf)
// are "no return", as in hetslam's reader.
//
// Pose per scan (one line each, the format of hetslam_run's trajectory.txt, core/trajectory_io.h):
// LaMa's pose after the update when Slam2D::update ran on the scan; otherwise (the robot moved
// less than --min_translation_meters and --min_rotation_radians since the last update, or the
// scan has no usable beam) the last updated pose composed with the odometry increment since it,
// which is LaMa's own prediction. The first scan defines the map frame (pose 0 0 0), or with
// --start_at_odometry the odometry frame does.
//
// Printed on stdout (tests/bench/run_lama.sh reads these lines):
//   scans: N processed (U updates, S below the motion thresholds, E without usable beams), data duration D s
//   time per stage (wall s, share of T s): reading the log a (p%), matching b (p%), map update c (p%),
//     other d (p%), outputs e (p%)
// Matching and map update are LaMa's own timers (Slam2D::Options::create_summary); "other" is
// the rest of the update calls (point clouds, motion test); with --nostage_times matching, map
// update and other are one "LaMa update" stage.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lama/pose2d.h"
#include "lama/sdm/map.h"
#include "lama/slam2d.h"
#include "lama/types.h"

namespace hetslam_bench {
namespace {

constexpr double kMaxPositionMeters = 1e7;
constexpr double kMaxStampSeconds = 1e12;
constexpr long kMaxBeams = 100000;
constexpr double kDegToRad = M_PI / 180.0;
// A CARMEN fov above this is in degrees (a fov over 2 pi radians cannot exist).
constexpr double kFovDegreesAbove = 2.0 * M_PI + 1e-3;

struct LamaCarmenOptions {
  std::string log_path;
  std::string trajectory_path;
  // Slam2D::Options::l2_max: distances in the likelihood field are cut off here (LaMa's
  // default 0.5 m; BENCHMARKS.md's runs used 3.0 m).
  double distance_cutoff_meters = 3.0;
  // Readings at or beyond this are dropped before LaMa sees them (the ROS node's `mrange`,
  // default 16 m there too); 0 keeps every reading below the no-return range.
  double max_range_meters = 16.0;
  // Slam2D::Options::trans_thresh / rot_thresh: the motion since the last update below which a
  // scan is not used (the ROS node's d_thresh / a_thresh defaults).
  double min_translation_meters = 0.01;
  double min_rotation_radians = 0.25;
  double resolution_meters = 0.05;  // Slam2D::Options::resolution, both maps
  int max_iterations = 100;         // Slam2D::Options::max_iter
  double flaser_fov_radians = M_PI;
  double no_return_meters = 81.0;  // FLASER readings >= this mean "no return" (hetslam's default)
  bool stage_times = true;         // Slam2D::Options::create_summary, for matching vs map update
  // The map frame: false, the first scan's pose is 0 0 0; true, the odometry frame (the first
  // scan starts at its odometry pose). The same up to a rigid motion, but LaMa's grids are
  // anchored to the frame, so the cells (and, on fragile logs, the result) differ.
  bool start_at_odometry = false;

  bool IsValid(std::string* error) const {
    auto fail = [error](const std::string& message) {
      *error = message;
      return false;
    };
    if (log_path.empty()) return fail("--log is required (a CARMEN .clf file)");
    if (trajectory_path.empty()) return fail("--trajectory is required (the output file)");
    if (!(distance_cutoff_meters > 0.0 && distance_cutoff_meters <= 100.0)) {
      return fail("--distance_cutoff_meters must be in (0, 100] (got " + std::to_string(distance_cutoff_meters) + ")");
    }
    if (!(max_range_meters >= 0.0 && max_range_meters <= 1000.0)) {
      return fail("--max_range_meters must be in [0, 1000] (got " + std::to_string(max_range_meters) + ")");
    }
    if (!(min_translation_meters >= 0.0 && min_translation_meters < 100.0)) {
      return fail("--min_translation_meters must be in [0, 100) (got " + std::to_string(min_translation_meters) + ")");
    }
    if (!(min_rotation_radians >= 0.0 && min_rotation_radians < 2.0 * M_PI)) {
      return fail("--min_rotation_radians must be in [0, 2 pi) (got " + std::to_string(min_rotation_radians) + ")");
    }
    if (!(resolution_meters >= 0.005 && resolution_meters <= 1.0)) {
      return fail("--resolution_meters must be in [0.005, 1] (got " + std::to_string(resolution_meters) + ")");
    }
    if (max_iterations < 1 || max_iterations > 10000) {
      return fail("--max_iterations must be in [1, 10000] (got " + std::to_string(max_iterations) + ")");
    }
    if (!(flaser_fov_radians > 0.0 && flaser_fov_radians <= kFovDegreesAbove)) {
      return fail("--flaser_fov_radians must be in (0, 2 pi] (got " + std::to_string(flaser_fov_radians) + ")");
    }
    if (!(no_return_meters > 0.0 && no_return_meters <= 1000.0)) {
      return fail("--no_return_meters must be in (0, 1000] (got " + std::to_string(no_return_meters) + ")");
    }
    return true;
  }
};

constexpr char kUsage[] =
    "lama_carmen: LaMa's lama::Slam2D (iris_lama) on a CARMEN log; writes `stamp x y theta` per scan.\n"
    "  lama_carmen --log=FILE.clf --trajectory=OUT.txt [flags]\n"
    "Flags (--name=value; booleans also --name / --noname):\n"
    "  --log                     CARMEN log (FLASER / ROBOTLASER1 / RAWLASER1, ODOM, PARAM lines). Required.\n"
    "  --trajectory              output trajectory file. Required.\n"
    "  --distance_cutoff_meters  likelihood field cut-off, Slam2D l2_max (default 3)\n"
    "  --max_range_meters        drop readings at or beyond this; 0: keep all below no-return (default 16)\n"
    "  --min_translation_meters  Slam2D trans_thresh (default 0.01)\n"
    "  --min_rotation_radians    Slam2D rot_thresh (default 0.25)\n"
    "  --resolution_meters       map resolution (default 0.05)\n"
    "  --max_iterations          Gauss-Newton iterations at most (default 100)\n"
    "  --flaser_fov_radians      FLASER field of view without a PARAM (default pi)\n"
    "  --no_return_meters        FLASER readings at or above this mean no return (default 81)\n"
    "  --stage_times             LaMa's timers split matching from map update (default on)\n"
    "  --start_at_odometry       map frame = odometry frame, not the first scan's pose (default off)\n";

// A whole field as a number (strtod's syntax, so also "nan" and "inf"); false when it is not one.
bool ParseNumber(std::string_view text, double* value) {
  if (text.empty()) return false;
  const std::string copy(text);
  char* end = nullptr;
  *value = std::strtod(copy.c_str(), &end);
  return end == copy.c_str() + copy.size();
}

bool ParseDouble(std::string_view text, double* value) { return ParseNumber(text, value) && std::isfinite(*value); }

std::string FormatNumber(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%g", value);
  return buffer;
}

// Reads `--name=value`, `--name`, `--noname`. Returns 0 to run, 1 when --help was printed, 2 on
// a bad flag (message in *error).
int OptionsFromArgs(int argc, char** argv, LamaCarmenOptions* options, std::string* error) {
  std::map<std::string, double*> doubles = {
      {"distance_cutoff_meters", &options->distance_cutoff_meters},
      {"max_range_meters", &options->max_range_meters},
      {"min_translation_meters", &options->min_translation_meters},
      {"min_rotation_radians", &options->min_rotation_radians},
      {"resolution_meters", &options->resolution_meters},
      {"flaser_fov_radians", &options->flaser_fov_radians},
      {"no_return_meters", &options->no_return_meters}};
  std::map<std::string, bool*> bools = {{"stage_times", &options->stage_times},
                                        {"start_at_odometry", &options->start_at_odometry}};
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h" || arg == "-help") {
      std::fputs(kUsage, stdout);
      return 1;
    }
    if (arg.rfind("--", 0) != 0) {
      *error = "unexpected argument '" + arg + "' (flags are --name=value; see --help)";
      return 2;
    }
    arg = arg.substr(2);
    const size_t eq = arg.find('=');
    const std::string name = arg.substr(0, eq);
    const bool has_value = eq != std::string::npos;
    const std::string value = has_value ? arg.substr(eq + 1) : "";
    if (name == "log" || name == "trajectory") {
      if (!has_value || value.empty()) {
        *error = "--" + name + " needs a value (--" + name + "=FILE)";
        return 2;
      }
      (name == "log" ? options->log_path : options->trajectory_path) = value;
    } else if (bools.count(name) > 0 || (name.rfind("no", 0) == 0 && bools.count(name.substr(2)) > 0)) {
      const bool negated = bools.count(name) == 0;
      bool* flag = bools[negated ? name.substr(2) : name];
      if (has_value) {
        if (value != "true" && value != "false") {
          *error = "--" + name + " takes true or false (got '" + value + "')";
          return 2;
        }
        *flag = (value == "true") != negated;
      } else {
        *flag = !negated;
      }
    } else if (name == "max_iterations") {
      double v = 0.0;
      if (!has_value || !ParseDouble(value, &v) || v != std::floor(v) || std::fabs(v) > 1e9) {
        *error = "--max_iterations needs an integer value (got '" + value + "')";
        return 2;
      }
      options->max_iterations = static_cast<int>(v);
    } else if (doubles.count(name) > 0) {
      if (!has_value || !ParseDouble(value, doubles[name])) {
        *error = "--" + name + " needs a finite number (got '" + value + "')";
        return 2;
      }
    } else {
      *error = "unknown flag --" + name + " (see --help)";
      return 2;
    }
  }
  return options->IsValid(error) ? 0 : 2;
}

// A planar pose in the odometry frame.
struct PlanarPose {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;
};

// One laser message with what LaMa needs of it.
struct CarmenScan {
  double stamp_seconds = 0.0;
  PlanarPose odometry;           // odom_T_robot at the scan
  PlanarPose robot_T_laser;      // the laser mount
  double first_angle_radians = 0.0;
  double increment_radians = 0.0;
  double no_return_meters = 81.0;  // readings >= this are not returns
  std::vector<double> ranges_meters;
  int line_number = 0;
};

struct CarmenCounts {
  int lines = 0;
  int scans = 0;
  int odometry = 0;
  int scan_stamps_backwards = 0;
  std::map<std::string, int> unknown_messages;
};

// The fields of one line, as views into the line (which outlives them).
class FieldCursor {
 public:
  FieldCursor(const std::vector<std::string_view>& fields, const char* message)
      : fields_(fields), message_(message) {}

  size_t remaining() const { return fields_.size() - next_; }

  // The next field as a finite number within +-limit; an error names it otherwise.
  bool Number(const char* name, double limit, double* value, std::string* error) {
    if (next_ >= fields_.size()) {
      *error = std::string(message_) + " is truncated: no field " + name;
      return false;
    }
    const std::string_view text = fields_[next_++];
    if (!ParseDouble(text, value)) {
      *error = std::string(message_) + ": field " + name + " ('" + std::string(text) + "') is not a finite number";
      return false;
    }
    if (std::fabs(*value) > limit) {
      *error = std::string(message_) + ": field " + name + " (" + std::string(text) + ") is beyond +-" +
               FormatNumber(limit);
      return false;
    }
    return true;
  }

  // A range reading: any number; NaN and infinities (some drivers' "no return") become NaN, a
  // reading that FillCloud drops.
  bool Range(long index, double* value, std::string* error) {
    if (next_ >= fields_.size()) {
      *error = std::string(message_) + " is truncated: no field range";
      return false;
    }
    const std::string_view text = fields_[next_++];
    if (!ParseNumber(text, value)) {
      *error = std::string(message_) + ": range " + std::to_string(index) + " ('" + std::string(text) +
               "') is not a number";
      return false;
    }
    if (!std::isfinite(*value)) *value = std::nan("");
    return true;
  }

  // A count of items that must be followed by at least `after` more fields.
  bool Count(const char* name, size_t after, long* count, std::string* error) {
    double v = 0.0;
    if (!Number(name, 1e12, &v, error)) return false;
    if (v != std::floor(v) || v < 0 || v > kMaxBeams) {
      *error = std::string(message_) + ": " + name + " count " + std::string(fields_[next_ - 1]) +
               " is not an integer in 0.." + std::to_string(kMaxBeams);
      return false;
    }
    *count = static_cast<long>(v);
    if (remaining() < static_cast<size_t>(*count) + after) {
      *error = std::string(message_) + " declares " + std::to_string(*count) + " " + name + ", which with the " +
               std::to_string(after) + " field(s) after them needs " + std::to_string(*count + after) +
               " more fields, but only " + std::to_string(remaining()) + " follow";
      return false;
    }
    return true;
  }

  // A field that may hold any word (the host name).
  bool Word(const char* name, std::string* error) {
    if (next_ >= fields_.size()) {
      *error = std::string(message_) + " is truncated: no field " + name;
      return false;
    }
    ++next_;
    return true;
  }

  bool ExpectEnd(std::string* error) const {
    if (next_ == fields_.size()) return true;
    *error = std::string(message_) + " has " + std::to_string(fields_.size() - next_) + " field(s) too many";
    return false;
  }

 private:
  const std::vector<std::string_view>& fields_;
  const char* message_;
  size_t next_ = 1;  // fields_[0] is the message type
};

bool ReadStamp(FieldCursor* cursor, double* stamp_seconds, std::string* error) {
  double logger_stamp = 0.0;
  return cursor->Number("ipc_timestamp", kMaxStampSeconds, stamp_seconds, error) &&
         cursor->Word("ipc_hostname", error) &&
         cursor->Number("logger_timestamp", kMaxStampSeconds, &logger_stamp, error) && cursor->ExpectEnd(error);
}

// Streams the laser messages of a CARMEN log in file order (see the top of this file).
class CarmenScanReader {
 public:
  enum class Result { kScan, kEnd, kError };

  CarmenScanReader(std::string path, const LamaCarmenOptions& options)
      : path_(std::move(path)),
        fov_radians_(options.flaser_fov_radians),
        no_return_meters_(options.no_return_meters) {}

  bool Open(std::string* error) {
    file_.open(path_);
    if (!file_) {
      *error = "cannot open " + path_;
      return false;
    }
    return true;
  }

  const CarmenCounts& counts() const { return counts_; }

  // Reads on to the next laser message. kError: *error names file and line.
  Result Next(CarmenScan* scan, std::string* error) {
    while (std::getline(file_, line_)) {
      ++counts_.lines;
      if (!line_.empty() && line_.back() == '\r') line_.pop_back();
      Split();
      if (fields_.empty() || fields_[0][0] == '#') continue;
      std::string message_error;
      const std::string_view type = fields_[0];
      bool ok = true;
      bool is_scan = false;
      if (type == "FLASER") {
        ok = ParseFlaser(scan, &message_error);
        is_scan = true;
      } else if (type == "ROBOTLASER1" || type == "RAWLASER1") {
        ok = ParseLaser1(type == "ROBOTLASER1", scan, &message_error);
        is_scan = true;
      } else if (type == "ODOM") {
        ok = ParseOdom(&message_error);
      } else if (type == "PARAM") {
        ok = ParseParam(&message_error);
      } else {
        ++counts_.unknown_messages[std::string(type)];
      }
      if (!ok) {
        *error = path_ + ":" + std::to_string(counts_.lines) + ": " + message_error;
        return Result::kError;
      }
      if (is_scan) {
        scan->line_number = counts_.lines;
        if (counts_.scans > 0 && scan->stamp_seconds < last_scan_stamp_) ++counts_.scan_stamps_backwards;
        last_scan_stamp_ = scan->stamp_seconds;
        ++counts_.scans;
        return Result::kScan;
      }
    }
    if (file_.bad()) {
      *error = path_ + ": read error after line " + std::to_string(counts_.lines);
      return Result::kError;
    }
    return Result::kEnd;
  }

 private:
  void Split() {
    fields_.clear();
    const std::string_view line(line_);
    size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      const size_t start = i;
      while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      if (i > start) fields_.push_back(line.substr(start, i - start));
    }
  }

  bool ReadRanges(FieldCursor* cursor, long n, CarmenScan* scan, std::string* error) {
    scan->ranges_meters.resize(n);
    for (long i = 0; i < n; ++i) {
      if (!cursor->Range(i, &scan->ranges_meters[i], error)) return false;
    }
    return true;
  }

  bool ParseFlaser(CarmenScan* scan, std::string* error) {
    FieldCursor cursor(fields_, "FLASER");
    long n = 0;
    if (!cursor.Count("ranges", 9, &n, error) || !ReadRanges(&cursor, n, scan, error)) return false;
    PlanarPose laser;
    if (!cursor.Number("x", kMaxPositionMeters, &laser.x, error) ||
        !cursor.Number("y", kMaxPositionMeters, &laser.y, error) ||
        !cursor.Number("theta", kMaxPositionMeters, &laser.theta, error) ||
        !cursor.Number("odom_x", kMaxPositionMeters, &scan->odometry.x, error) ||
        !cursor.Number("odom_y", kMaxPositionMeters, &scan->odometry.y, error) ||
        !cursor.Number("odom_theta", kMaxPositionMeters, &scan->odometry.theta, error) ||
        !ReadStamp(&cursor, &scan->stamp_seconds, error)) {
      return false;
    }
    scan->robot_T_laser = PlanarPose();
    if (n == 1) {
      scan->first_angle_radians = 0.0;  // a single beam looks straight ahead
      scan->increment_radians = 0.0;
    } else {
      scan->first_angle_radians = -0.5 * fov_radians_;
      scan->increment_radians = has_resolution_ ? resolution_radians_
                                                : fov_radians_ / static_cast<double>(n % 2 == 1 ? n - 1 : n);
    }
    scan->no_return_meters = no_return_meters_;
    return true;
  }

  bool ParseLaser1(bool robot_laser, CarmenScan* scan, std::string* error) {
    const char* type = robot_laser ? "ROBOTLASER1" : "RAWLASER1";
    FieldCursor cursor(fields_, type);
    double unused = 0.0;
    double fov = 0.0;
    if (!cursor.Number("laser_type", 1e12, &unused, error) ||
        !cursor.Number("start_angle", 4.0 * M_PI, &scan->first_angle_radians, error) ||
        !cursor.Number("fov", 4.0 * M_PI, &fov, error) ||
        !cursor.Number("angular_res", 2.0 * M_PI, &scan->increment_radians, error) ||
        !cursor.Number("max_range", kMaxPositionMeters, &scan->no_return_meters, error) ||
        !cursor.Number("accuracy", 1e12, &unused, error) || !cursor.Number("remission_mode", 1e12, &unused, error)) {
      return false;
    }
    const size_t trailing = robot_laser ? 14 : 3;
    long n = 0;
    long m = 0;
    if (!cursor.Count("ranges", 1 + trailing, &n, error) || !ReadRanges(&cursor, n, scan, error) ||
        !cursor.Count("remissions", trailing, &m, error)) {
      return false;
    }
    for (long i = 0; i < m; ++i) {
      if (!cursor.Number("remission", 1e12, &unused, error)) return false;
    }
    const double span_radians = std::fabs(scan->increment_radians) * static_cast<double>(n - 1);
    if (n >= 2 && (scan->increment_radians == 0.0 || span_radians > 2.0 * M_PI + 1e-6)) {
      *error = std::string(type) + ": angular_res " + FormatNumber(scan->increment_radians) + " with " +
               std::to_string(n) + " beams does not span (0, 2 pi]";
      return false;
    }
    if (robot_laser) {
      PlanarPose laser;
      if (!cursor.Number("laser_x", kMaxPositionMeters, &laser.x, error) ||
          !cursor.Number("laser_y", kMaxPositionMeters, &laser.y, error) ||
          !cursor.Number("laser_theta", kMaxPositionMeters, &laser.theta, error) ||
          !cursor.Number("robot_x", kMaxPositionMeters, &scan->odometry.x, error) ||
          !cursor.Number("robot_y", kMaxPositionMeters, &scan->odometry.y, error) ||
          !cursor.Number("robot_theta", kMaxPositionMeters, &scan->odometry.theta, error)) {
        return false;
      }
      for (const char* name : {"tv", "rv", "forward_safety", "side_safety", "turn_axis"}) {
        if (!cursor.Number(name, 1e12, &unused, error)) return false;
      }
      // Both poses are in the odometry frame: robot_T_laser = odom_T_robot^-1 * odom_T_laser.
      const double c = std::cos(scan->odometry.theta);
      const double s = std::sin(scan->odometry.theta);
      const double dx = laser.x - scan->odometry.x;
      const double dy = laser.y - scan->odometry.y;
      scan->robot_T_laser = {c * dx + s * dy, -s * dx + c * dy, laser.theta - scan->odometry.theta};
    } else {
      if (!has_odometry_) {
        *error = "RAWLASER1 before any ODOM line: no odometry for this scan";
        return false;
      }
      scan->odometry = last_odometry_;
      scan->robot_T_laser = PlanarPose();
    }
    return ReadStamp(&cursor, &scan->stamp_seconds, error);
  }

  bool ParseOdom(std::string* error) {
    FieldCursor cursor(fields_, "ODOM");
    PlanarPose pose;
    double unused = 0.0;
    double stamp = 0.0;
    if (!cursor.Number("x", kMaxPositionMeters, &pose.x, error) ||
        !cursor.Number("y", kMaxPositionMeters, &pose.y, error) ||
        !cursor.Number("theta", kMaxPositionMeters, &pose.theta, error) || !cursor.Number("tv", 1e12, &unused, error) ||
        !cursor.Number("rv", 1e12, &unused, error) || !cursor.Number("accel", 1e12, &unused, error) ||
        !ReadStamp(&cursor, &stamp, error)) {
      return false;
    }
    last_odometry_ = pose;
    has_odometry_ = true;
    ++counts_.odometry;
    return true;
  }

  // PARAM name value [...]: the laser geometry ones change the FLASER lines after them.
  bool ParseParam(std::string* error) {
    if (fields_.size() < 3) {
      *error = "PARAM is truncated: needs a name and a value";
      return false;
    }
    const std::string_view name = fields_[1];
    const bool fov = name == "laser_front_laser_fov";
    const bool resolution = name == "laser_front_laser_resolution";
    const bool max_range = name == "laser_front_laser_max_range";
    if (!fov && !resolution && !max_range) return true;
    double v = 0.0;
    if (!ParseDouble(fields_[2], &v) || !(v > 0.0)) {
      *error = "PARAM " + std::string(name) + " value '" + std::string(fields_[2]) + "' is not a positive number";
      return false;
    }
    if (fov) {
      const double radians = v > kFovDegreesAbove ? v * kDegToRad : v;
      if (radians > kFovDegreesAbove) {
        *error = "PARAM " + std::string(name) + " value '" + std::string(fields_[2]) + "' exceeds 360 degrees";
        return false;
      }
      fov_radians_ = radians;
    } else if (resolution) {
      if (v > 360.0) {
        *error = "PARAM " + std::string(name) + " value '" + std::string(fields_[2]) + "' exceeds 360 degrees";
        return false;
      }
      has_resolution_ = true;
      resolution_radians_ = v * kDegToRad;
    } else {
      no_return_meters_ = v;
    }
    return true;
  }

  std::string path_;
  std::ifstream file_;
  std::string line_;
  std::vector<std::string_view> fields_;
  CarmenCounts counts_;
  double last_scan_stamp_ = 0.0;
  // FLASER geometry in force (options, then PARAM lines).
  double fov_radians_;
  bool has_resolution_ = false;
  double resolution_radians_ = 0.0;
  double no_return_meters_;
  PlanarPose last_odometry_;
  bool has_odometry_ = false;
};

double WrapAngle(double radians) {
  double wrapped = std::remainder(radians, 2.0 * M_PI);  // [-pi, pi]
  if (wrapped <= -M_PI) wrapped += 2.0 * M_PI;
  return wrapped;
}

lama::Pose2D ToLama(const PlanarPose& pose) { return lama::Pose2D(pose.x, pose.y, pose.theta); }

// The scan's usable end points in the laser frame, and the mount as LaMa's sensor origin.
// Returns the longest reading kept (0 when none).
double FillCloud(const CarmenScan& scan, double max_range_meters, lama::PointCloudXYZ* cloud) {
  cloud->points.clear();
  double longest = 0.0;
  const double limit = max_range_meters > 0.0 ? std::min(max_range_meters, scan.no_return_meters)
                                              : scan.no_return_meters;
  for (size_t i = 0; i < scan.ranges_meters.size(); ++i) {
    const double range = scan.ranges_meters[i];
    if (!(range > 0.0 && range < limit)) continue;
    longest = std::max(longest, range);
    const double angle = scan.first_angle_radians + static_cast<double>(i) * scan.increment_radians;
    cloud->points.emplace_back(range * std::cos(angle), range * std::sin(angle), 0.0);
  }
  cloud->sensor_origin_ = lama::Vector3d(scan.robot_T_laser.x, scan.robot_T_laser.y, 0.0);
  cloud->sensor_orientation_ = lama::Quaterniond(lama::AngleAxisd(scan.robot_T_laser.theta, lama::Vector3d::UnitZ()));
  return longest;
}

struct StampedPose {
  double stamp_seconds;
  double x;
  double y;
  double theta;
};

bool WriteTrajectory(const std::string& path, const std::vector<StampedPose>& trajectory, std::string* error) {
  std::FILE* file = std::fopen(path.c_str(), "w");
  if (file == nullptr) {
    *error = "cannot write " + path;
    return false;
  }
  std::fprintf(file, "# timestamp x y theta\n");
  for (const StampedPose& p : trajectory) {
    std::fprintf(file, "%.6f %.9f %.9f %.9f\n", p.stamp_seconds, p.x, p.y, WrapAngle(p.theta));
  }
  const bool ok = std::ferror(file) == 0;
  if (std::fclose(file) != 0 || !ok) {
    *error = "error while writing " + path;
    return false;
  }
  return true;
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double Sum(const lama::DynamicArray<double>& values) {
  double sum = 0.0;
  for (double v : values) sum += v;
  return sum;
}

int Fail(const std::string& message) {
  std::fprintf(stderr, "lama_carmen: %s\n", message.c_str());
  return 1;
}

int Run(const LamaCarmenOptions& options) {
  CarmenScanReader reader(options.log_path, options);
  std::string error;
  if (!reader.Open(&error)) return Fail(error);

  lama::Slam2D::Options slam_options;
  slam_options.l2_max = options.distance_cutoff_meters;
  slam_options.trans_thresh = options.min_translation_meters;
  slam_options.rot_thresh = options.min_rotation_radians;
  slam_options.resolution = options.resolution_meters;
  slam_options.max_iter = static_cast<uint32_t>(options.max_iterations);
  slam_options.create_summary = options.stage_times;
  auto slam = std::make_unique<lama::Slam2D>(slam_options);

  // LaMa's map indexes UNIVERSAL_CONSTANT / 2 patches on each side of its origin; half of that
  // is allowed, as a margin.
  const double map_reach_meters =
      0.5 * (lama::Map::UNIVERSAL_CONSTANT / 2) * slam_options.patch_size * slam_options.resolution;
  std::vector<StampedPose> trajectory;
  auto cloud = std::make_shared<lama::PointCloudXYZ>();
  CarmenScan scan;
  // The pose and odometry of the last update (or of the first scan, before any update): every
  // other scan's pose is anchor_pose * (anchor_odometry^-1 * odometry), LaMa's prediction.
  lama::Pose2D anchor_pose;
  lama::Pose2D anchor_odometry;
  bool updated_once = false;
  int updates = 0;
  int below_thresholds = 0;
  int without_beams = 0;
  double read_seconds = 0.0;
  double update_seconds = 0.0;
  while (true) {
    auto start = std::chrono::steady_clock::now();
    const CarmenScanReader::Result result = reader.Next(&scan, &error);
    read_seconds += SecondsSince(start);
    if (result == CarmenScanReader::Result::kError) return Fail(error);
    if (result == CarmenScanReader::Result::kEnd) break;

    const lama::Pose2D odometry = ToLama(scan.odometry);
    if (trajectory.empty()) {
      anchor_odometry = odometry;  // the first scan is the map origin, or starts at its odometry
      if (options.start_at_odometry) anchor_pose = odometry;
    }
    const lama::Pose2D predicted = anchor_pose + (anchor_odometry - odometry);
    lama::Pose2D pose = predicted;

    start = std::chrono::steady_clock::now();
    const double longest_meters = FillCloud(scan, options.max_range_meters, cloud.get());
    // LaMa's maps index cells from a fixed origin and cannot reach beyond map_reach_meters;
    // further out its cell coordinates would wrap (lama/sdm/map.h, UNIVERSAL_CONSTANT).
    const double reach_meters = std::max(std::fabs(predicted.x()), std::fabs(predicted.y())) +
                                std::hypot(scan.robot_T_laser.x, scan.robot_T_laser.y) + longest_meters;
    if (!(reach_meters < map_reach_meters)) {
      return Fail(options.log_path + ":" + std::to_string(scan.line_number) + ": this scan reaches " +
                  FormatNumber(reach_meters) + " m from the map origin, beyond the " + FormatNumber(map_reach_meters) +
                  " m that LaMa's map can index at resolution " + FormatNumber(options.resolution_meters) +
                  " m (an odometry jump?)");
    }
    if (cloud->points.empty()) {
      ++without_beams;
    } else {
      // Before its first update LaMa keeps the pose it was given: start it where the odometry
      // says, so that scans without beams before it do not shift the map frame.
      if (!updated_once) slam->setPose(predicted);
      if (slam->update(cloud, odometry, scan.stamp_seconds)) {
        pose = slam->getPose();
        anchor_pose = pose;
        anchor_odometry = odometry;
        updated_once = true;
        ++updates;
      } else {
        ++below_thresholds;
      }
    }
    update_seconds += SecondsSince(start);
    if (!std::isfinite(pose.x()) || !std::isfinite(pose.y()) || !std::isfinite(pose.rotation())) {
      return Fail(options.log_path + ":" + std::to_string(scan.line_number) +
                  ": LaMa's pose is not finite after this scan");
    }
    trajectory.push_back({scan.stamp_seconds, pose.x(), pose.y(), pose.rotation()});
  }
  if (trajectory.empty()) return Fail(options.log_path + ": no laser scans (FLASER, ROBOTLASER1 or RAWLASER1 lines)");

  const auto write_start = std::chrono::steady_clock::now();
  if (!WriteTrajectory(options.trajectory_path, trajectory, &error)) return Fail(error);
  const double write_seconds = SecondsSince(write_start);

  const CarmenCounts& counts = reader.counts();
  std::printf("lama_carmen: %s -> %s\n", options.log_path.c_str(), options.trajectory_path.c_str());
  std::printf("options: distance cut-off %g m, max range %g m, update after %g m or %g rad, resolution %g m, "
              "at most %d iterations\n",
              options.distance_cutoff_meters, options.max_range_meters, options.min_translation_meters,
              options.min_rotation_radians, options.resolution_meters, options.max_iterations);
  std::printf("log: %d lines, %d scans, %d ODOM lines (checked; the scans carry their own odometry)",
              counts.lines, counts.scans, counts.odometry);
  for (const auto& [type, count] : counts.unknown_messages) std::printf(", %d %s skipped", count, type.c_str());
  if (counts.scan_stamps_backwards > 0) std::printf(", %d scan stamps backwards", counts.scan_stamps_backwards);
  std::printf("\n");
  const double duration = trajectory.back().stamp_seconds - trajectory.front().stamp_seconds;
  std::printf("scans: %zu processed (%d updates, %d below the motion thresholds, %d without usable beams), "
              "data duration %.1f s\n",
              trajectory.size(), updates, below_thresholds, without_beams, duration);

  std::vector<std::pair<const char*, double>> stages = {{"reading the log", read_seconds}};
  if (slam->summary != nullptr) {
    const double matching = Sum(slam->summary->time_solving);
    const double mapping = Sum(slam->summary->time_mapping);
    stages.push_back({"matching", matching});
    stages.push_back({"map update", mapping});
    // Building the point clouds, the motion test and LaMa's bookkeeping.
    stages.push_back({"other", std::max(0.0, update_seconds - matching - mapping)});
    double peak_bytes = 0.0;
    for (double bytes : slam->summary->memory) peak_bytes = std::max(peak_bytes, bytes);
    std::printf("LaMa's own count of its maps' memory: %.1f MiB at most\n", peak_bytes / (1024.0 * 1024.0));
  } else {
    stages.push_back({"LaMa update", update_seconds});
  }
  stages.push_back({"outputs", write_seconds});
  double total = 0.0;
  for (const auto& stage : stages) total += stage.second;
  std::printf("time per stage (wall s, share of %.2f s):", total);
  for (size_t k = 0; k < stages.size(); ++k) {
    std::printf("%s %s %.2f (%.0f%%)", k > 0 ? "," : "", stages[k].first, stages[k].second,
                total > 0.0 ? 100.0 * stages[k].second / total : 0.0);
  }
  std::printf("\n");
  return 0;
}

}  // namespace
}  // namespace hetslam_bench

int main(int argc, char** argv) {
  hetslam_bench::LamaCarmenOptions options;
  std::string error;
  const int parsed = hetslam_bench::OptionsFromArgs(argc, argv, &options, &error);
  if (parsed == 1) return 0;
  if (parsed == 2) {
    std::fprintf(stderr, "lama_carmen: %s\n", error.c_str());
    return 2;
  }
  return hetslam_bench::Run(options);
}
