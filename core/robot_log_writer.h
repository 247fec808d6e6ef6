// Writing the hetslam multi-sensor robot log (format and frames: core/robot_log.h; full
// description with examples in datasets/README.md).
#ifndef HETSLAM_CORE_ROBOT_LOG_WRITER_H_
#define HETSLAM_CORE_ROBOT_LOG_WRITER_H_

#include <string>
#include <vector>

#include "core/robot_log.h"
#include "core/status.h"

namespace hetslam {

// Writes every message of `log` merged by time stamp (at equal stamps in the order MOUNT,
// ODOM, MARG, ATTITUDE, ALTITUDE, COMMAND, TRUTH, LASER, IMAGE; within a type in vector
// order), after the HSLOG line, `comment_lines` as '#' lines and the PARAMs (sorted by name).
// Numbers are printed so that reading gives back the same doubles (the shortest such text,
// std::to_chars: locale independent); the same log gives the same bytes. Laser scans must
// have evenly spaced angles (else an error), and each scan's robot_T_sensor must be the MOUNT
// in force at its stamp (identity before the first MOUNT), else an error: the log stores
// mounts only as MOUNT messages. Poses are stored as roll/pitch/yaw, so rotations read back
// equal to rounding (~1e-16), not bit for bit; non-finite ranges are written as "nan".
// The log is checked before the file is opened: an invalid log leaves no file behind.
Status WriteRobotLog(const std::string& path, const RobotLog& log,
                     const std::vector<std::string>& comment_lines);

}  // namespace hetslam

#endif  // HETSLAM_CORE_ROBOT_LOG_WRITER_H_
