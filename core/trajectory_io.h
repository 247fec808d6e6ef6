// Trajectories as text: one pose per line, `timestamp x y theta` (seconds, metres, metres,
// radians), '#' starts a comment line. This is also the layout of the shared `.gmapping.txt`
// reference files and of simulator truth files.
#ifndef HETSLAM_CORE_TRAJECTORY_IO_H_
#define HETSLAM_CORE_TRAJECTORY_IO_H_

#include <string>
#include <vector>

#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

struct StampedPose2 {
  double stamp_seconds = 0.0;
  Pose2 pose;
};

// Writes with full precision (timestamps to the microsecond, poses to 1e-9), one header
// comment line `# timestamp x y theta` first. An error names the file.
Status WriteTrajectory(const std::string& path, const std::vector<StampedPose2>& trajectory);

// Reads `timestamp x y theta` lines; blank and '#' lines are skipped. A malformed or
// non-finite line is an error naming file and line number.
Status ReadTrajectory(const std::string& path, std::vector<StampedPose2>* trajectory);

// What ReadTrajectoryChecked found about the stamp order of a trajectory file.
struct TrajectoryStampReport {
  int duplicate_rows_dropped = 0;  // rows repeating the previous row exactly (stamp and pose)
  int repeated_stamps = 0;         // rows with the previous row's stamp but another pose (kept)
  int stamps_backwards = 0;        // rows stamped before the previous row (kept, file order)
  std::vector<std::string> warnings;  // the first few, "file:line: message"
};

// ReadTrajectory, then the stamp order checked row by row: an exact repeat of the previous row
// (a tool that printed a pose twice) is dropped, so that it cannot change which poses count as
// ambiguous matches in an evaluation; a repeated stamp with another pose and a stamp going
// backwards are kept and counted. Every case is reported in `report` (not null) with file:line.
Status ReadTrajectoryChecked(const std::string& path, std::vector<StampedPose2>* trajectory,
                             TrajectoryStampReport* report);

}  // namespace hetslam

#endif  // HETSLAM_CORE_TRAJECTORY_IO_H_
