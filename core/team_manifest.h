// The hetslam team manifest `team.txt`: the robots of a dataset and the ground truth of its
// fiducial tags. A dataset is a directory with this manifest and one directory per robot
// holding `log.txt` (a robot log, core/robot_log.h) and its camera images. Full description
// with examples in datasets/README.md.
//
// Text as in robot logs: one message per line, fields separated by white space, '#' lines and
// blank lines are comments, numbers in C locale. Frames and units as in core/robot_log.h
// (poses "x y z roll pitch yaw", Euler angles Z-Y-X). Messages:
//   HSTEAM version                      first non-comment line; version 1
//   robot name kind directory           one per robot; directory relative to the manifest
//   tag id family size x y z roll pitch yaw
//                                       ground truth of a fiducial: world_T_tag, size = edge of
//                                       the black square in metres (evaluation only)
//
// Reading stops at the first error, which names file and line ("team.txt:4: robot b has
// unknown kind 'tank' (wheeled, uav or humanoid)"); there is no lenient mode.
#ifndef HETSLAM_CORE_TEAM_MANIFEST_H_
#define HETSLAM_CORE_TEAM_MANIFEST_H_

#include <string>
#include <vector>

#include "Eigen/Geometry"
#include "core/status.h"

namespace hetslam {

struct TeamRobot {
  std::string name;
  std::string kind;       // wheeled | uav | humanoid
  std::string directory;  // as written (relative to the manifest)
  int line_number = 0;
};

struct TagTruth {
  int id = 0;
  std::string family;  // e.g. tag36h11
  double size_meters = 0.0;
  Eigen::Isometry3d world_T_tag = Eigen::Isometry3d::Identity();
  int line_number = 0;
};

struct TeamManifest {
  std::string path;
  std::string directory;
  std::vector<TeamRobot> robots;
  std::vector<TagTruth> tags;

  // `directory`/robot.directory/log.txt
  std::string RobotLogPath(const TeamRobot& robot) const;
};

// Errors name file and line; robot names must be unique and kinds known; tag sizes > 0.
Status ReadTeamManifest(const std::string& path, TeamManifest* manifest);
Status WriteTeamManifest(const std::string& path, const TeamManifest& manifest,
                         const std::vector<std::string>& comment_lines);

}  // namespace hetslam

#endif  // HETSLAM_CORE_TEAM_MANIFEST_H_
