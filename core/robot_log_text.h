// Helpers shared by the hetslam robot log reader (core/robot_log.h), its writer
// (core/robot_log_writer.h) and the team manifest reader and writer (core/team_manifest.h):
// the format version, number and pose text, the header line, comments and paths. Not a public
// API of hetslam; the field splitting and number parsing they build on is core/text_fields.h.
#ifndef HETSLAM_CORE_ROBOT_LOG_TEXT_H_
#define HETSLAM_CORE_ROBOT_LOG_TEXT_H_

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "Eigen/Geometry"
#include "core/status.h"

namespace hetslam {
namespace robot_log_text {

// The version of both HSLOG and HSTEAM files that this code reads and writes.
constexpr int kVersion = 1;
// Largest beam count of a LASER message (reader and writer).
constexpr long long kMaxBeams = 100000;
// Magnitude limits of the numbers a robot log describes (beyond them the value is corrupt, and
// using it would overflow a grid or an integration): positions |x|, |y|, |z| <= 1e7 m (pose
// lines: MOUNT, TRUTH, ODOM), command and MARG rates and speeds |v| <= 1e3 (m/s, rad/s),
// stamps |t| <= 1e12 s (about 31700 years), LASER range_max <= 1e5 m.
constexpr double kMaxPositionMeters = 1e7;
constexpr double kMaxRate = 1e3;
constexpr double kMaxStampSeconds = 1e12;
constexpr double kMaxRangeMeters = 1e5;  // LASER range_max
// The six numbers of a pose "x y z roll pitch yaw", named for the errors.
inline const std::vector<const char*> kPoseNames = {"x", "y", "z", "roll", "pitch", "yaw"};

// Shortest decimal text that reads back as the same double (std::to_chars, locale
// independent). Non-finite values print as "nan", "inf", "-inf".
std::string FormatDouble(double v);

// "x y z roll pitch yaw" of a pose.
std::string FormatPose(const Eigen::Isometry3d& pose);

// The pose of the six numbers "x y z roll pitch yaw" at `v`.
Eigen::Isometry3d PoseFromValues(const double* v);

// A pose the writers can store: finite, with a rotation matrix (orthonormal, det +1).
bool IsWritablePose(const Eigen::Isometry3d& pose);

// The directory of `path` ("." when it has none, "/" for a file in the root).
std::string DirectoryOf(const std::string& path);

// `relative` inside `directory`; an absolute `relative` as it is.
std::string JoinPath(const std::string& directory, const std::string& relative);

// True when `relative` stays inside the directory it is relative to: not empty, not absolute
// (no leading '/' or '\\'), and no ".." component. Paths in a dataset's files (manifest robot
// directories, IMAGE paths) must pass, so that a file cannot make a reader open files outside
// the dataset ("../../../../etc").
bool StaysInside(const std::string& relative);

// The header line "<magic> 1" (first non-comment line), split into `fields` (not empty).
// Errors even in lenient mode; the caller prefixes "file:line: ".
Status CheckHeader(const std::vector<std::string>& fields, const char* magic, int* version);

// Opens `path` for reading; an error naming it when it is missing, a directory or unreadable.
Status OpenForReading(const std::string& path, std::ifstream* in);

// After the last line (`line_number` lines read from `in`): an error when reading failed, or
// when no "<magic> 1" header was found ("path:1: missing 'HSLOG 1' header: ...").
Status CheckEndOfFile(const std::ifstream& in, const std::string& path, int line_number,
                      bool have_header, const char* magic);

// Non-empty, no white space, not starting with '#': reads back as the same single field.
bool IsPlainWord(const std::string& s);

}  // namespace robot_log_text
}  // namespace hetslam

#endif  // HETSLAM_CORE_ROBOT_LOG_TEXT_H_
