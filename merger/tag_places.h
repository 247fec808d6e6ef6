// Which tag hangs where, as one robot has seen it: the robot's tag sightings grouped by place,
// each place named by a vote of the ids detected there.
//
// A wrong id (a mis-decoded tag, or the fault injection of merger/team_estimator.h) puts a
// sighting of tag j where the robot has otherwise seen tag i. Eq. 4 from such a sighting would
// place the teammate metres off, and in a building of look-alike rooms a scan match cannot tell.
// A tag, though, stays where it is: all sightings of one physical tag fall at one place of the
// robot's map. So places, not single sightings, carry ids: a place's id is the one most of its
// sightings report, trusted once it has `min_votes` of them and at least `min_vote_fraction` of
// the place's sightings; the others are outvoted. An id that wins at two places of one robot more
// than twice the radius apart is ambiguous there (one of them must be wrong) and not used; two
// such places side by side are one tag whose heading estimates split (a far tag's pose can flip
// between two solutions), and the one with more votes keeps the id.
//
// Places are built greedily in sighting order: a sighting joins the place whose mean is nearest
// within `radius_meters` and `max_heading_difference_radians`, else starts one. Tags of a team are
// assumed to hang at least twice the radius apart. Deterministic for a given input order.
#ifndef HETSLAM_MERGER_TAG_PLACES_H_
#define HETSLAM_MERGER_TAG_PLACES_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "core/se2.h"

namespace hetslam {

struct TagPlaceOptions {
  double radius_meters = 0.5;
  double max_heading_difference_radians = 0.6;
  // 2: a tag a robot only passes by is seen two or three times (team_three's drone sees tag 2
  // three times, 20 m from its start); with 3, one wrong id among those three left the place
  // unnamed and the teammate it would link never merged (--wrong_tag_id_rate=0.2: team_three's
  // nao on no seed of 1-5). Two of three agreeing pass min_vote_fraction; a lone sighting, or
  // two that disagree, never name a place. Two wrong ids agreeing at a place seen three times
  // name it wrongly; the id then wins two places and both are ambiguous (unused), and a link
  // still needs agreeing scan matches and agreeing tags (merger/team_estimator.h). Measured
  // with wrong ids, seeds 1-15 of team_two and team_three, 1-5 of team_overlap: every robot
  // merged, none wrongly; without wrong ids the runs are as with 3.
  int min_votes = 2;
  double min_vote_fraction = 0.6;
  // Sightings from one pass share the robot's pose error, so a place's mean is credited with at
  // most this many independent sightings (its covariance: the members' mean over this).
  int max_independent_sightings = 4;

  bool IsValid(std::string* error) const;
};

struct PlacedTagSighting {
  int tag_id = 0;
  Pose2 robot_T_tag;  // planar landmark frame (merger/landmark_pose.h) in the robot frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

struct TagPlace {
  std::vector<int> members;  // indices of the input sightings at this place
  int tag_id = -1;           // the most voted id (ties: the smallest)
  int votes = 0;             // sightings reporting it
  // Mean of the members that report tag_id (position weighted by 1 / trace of their
  // translational covariance, heading by 1 / its variance), and its covariance.
  Pose2 robot_T_tag;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  bool confirmed = false;  // enough votes (see the header), and not outvoted
  // Another place within twice the radius won the same id with more votes (a split heading):
  // this one is then not confirmed.
  bool outvoted = false;
  bool ambiguous = false;  // a confirmed place farther away won the same id
};

std::vector<TagPlace> GroupTagSightings(const std::vector<PlacedTagSighting>& sightings,
                                        const TagPlaceOptions& options);

// The confirmed, unambiguous place of `tag_id`, or null.
const TagPlace* FindTagPlace(const std::vector<TagPlace>& places, int tag_id);

}  // namespace hetslam

#endif  // HETSLAM_MERGER_TAG_PLACES_H_
