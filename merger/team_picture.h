// The team's merged map as a picture: the map (occupied black, free white, unknown grey, as
// core/map_io.h draws it), each robot's trajectory in its colour (core/map_io.h TrajectoryColor)
// with a disc at its start, the tags the robots placed (a square in the robot's colour with the
// id), the inter-robot constraints (a line from the constrained node to the origin of the
// teammate's submap it was matched in: thick for the first link, thin for the later ones) and a
// legend. Written as an RGB PNG (core/map_io.h WritePng); drawn with OpenCV.
#ifndef HETSLAM_MERGER_TEAM_PICTURE_H_
#define HETSLAM_MERGER_TEAM_PICTURE_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/occupancy_grid.h"
#include "core/se2.h"
#include "core/status.h"

namespace hetslam {

// Everything in the grid's (world) frame.
struct TeamPicture {
  struct Robot {
    std::string name;
    std::vector<Pose2> trajectory;  // empty: not drawn (e.g. a robot in another frame)
    std::string note;               // appended to its legend line
  };
  struct Tag {
    int robot = 0;
    int id = 0;
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
  };
  struct Link {
    int robot = 0;  // the colour: the node's robot
    Eigen::Vector2d from = Eigen::Vector2d::Zero(), to = Eigen::Vector2d::Zero();
    bool first_link = false;
  };
  std::vector<Robot> robots;  // indexed by robot: colour TrajectoryColor(index)
  std::vector<Tag> tags;
  std::vector<Link> links;
};

struct TeamPictureOptions {
  int pixels_per_cell = 2;

  bool IsValid(std::string* error) const;
};

// Errors: nothing observed in the grid, non-finite positions, a picture over 100 million pixels,
// the file cannot be written.
Status WriteTeamPicturePng(const OccupancyGrid& grid, const TeamPicture& picture, const TeamPictureOptions& options,
                           const std::string& path);

}  // namespace hetslam

#endif  // HETSLAM_MERGER_TEAM_PICTURE_H_
