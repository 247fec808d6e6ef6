#include "core/robot_log_writer.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <initializer_list>
#include <limits>
#include <utility>

#include "core/file_io.h"
#include "core/robot_log_text.h"
#include "core/text_fields.h"

namespace hetslam {

namespace {

using robot_log_text::FormatDouble;
using robot_log_text::FormatPose;
using robot_log_text::IsPlainWord;
using robot_log_text::IsWritablePose;
using robot_log_text::kMaxBeams;
using robot_log_text::kVersion;

// A scan is written with a first angle and an increment; angles that differ from that fan by
// more than this are not "evenly spaced" (rounding of first + i * increment stays far below).
constexpr double kAngleTolerance = 1e-9;
// A MOUNT in force and a scan's robot_T_sensor must agree this well for the writer.
constexpr double kMountTolerance = 1e-9;

// A PARAM value reads back identically when it is its own fields joined by single spaces.
bool IsCanonicalValue(const std::string& value) {
  std::vector<std::string> fields;
  text_fields::Split(value, &fields);
  if (fields.empty()) return false;
  std::string joined;
  for (size_t i = 0; i < fields.size(); ++i) joined += (i > 0 ? " " : "") + fields[i];
  return joined == value;
}

bool AllFinite(std::initializer_list<double> values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

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

  FILE* file = nullptr;
  HETSLAM_RETURN_IF_ERROR(OpenForWriting(path, "w", &file));
  std::fprintf(file, "HSLOG %d\n", kVersion);
  WriteCommentLines(file, comment_lines);
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
  return CommitWrittenFile(file, path);
}

}  // namespace hetslam
