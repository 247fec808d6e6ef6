#include "merger/tag_places.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "glog/logging.h"

namespace hetslam {

bool TagPlaceOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(radius_meters > 0 && max_heading_difference_radians > 0)) msg << "place radius and heading bound must be > 0; ";
  if (min_votes < 1) msg << "min_votes must be >= 1; ";
  if (!(min_vote_fraction > 0.5 && min_vote_fraction <= 1.0)) msg << "min_vote_fraction must be in (0.5, 1]; ";
  if (max_independent_sightings < 1) msg << "max_independent_sightings must be >= 1; ";
  if (error != nullptr) *error = msg.str();
  return msg.str().empty();
}

namespace {

// Running sums of a place's members (all ids) to find the nearest place.
struct PlaceSums {
  Eigen::Vector2d position_sum = Eigen::Vector2d::Zero();
  Eigen::Vector2d heading_sum = Eigen::Vector2d::Zero();  // sum of (cos, sin)
  int count = 0;
  Pose2 Mean() const {
    return Pose2(position_sum / count, std::atan2(heading_sum.y(), heading_sum.x()));
  }
};

}  // namespace

std::vector<TagPlace> GroupTagSightings(const std::vector<PlacedTagSighting>& sightings,
                                        const TagPlaceOptions& options) {
  std::string error;
  CHECK(options.IsValid(&error)) << "invalid TagPlaceOptions: " << error;
  std::vector<TagPlace> places;
  std::vector<PlaceSums> sums;
  for (int i = 0; i < static_cast<int>(sightings.size()); ++i) {
    const Pose2& pose = sightings[i].robot_T_tag;
    int best = -1;
    double best_distance = options.radius_meters;
    for (int p = 0; p < static_cast<int>(places.size()); ++p) {
      const Pose2 mean = sums[p].Mean();
      const double distance = (mean.translation() - pose.translation()).norm();
      if (distance <= best_distance &&
          std::abs(WrapAngle(mean.theta() - pose.theta())) <= options.max_heading_difference_radians) {
        best = p;
        best_distance = distance;
      }
    }
    if (best < 0) {
      best = static_cast<int>(places.size());
      places.emplace_back();
      sums.emplace_back();
    }
    places[best].members.push_back(i);
    sums[best].position_sum += pose.translation();
    sums[best].heading_sum += Eigen::Vector2d(std::cos(pose.theta()), std::sin(pose.theta()));
    ++sums[best].count;
  }

  for (TagPlace& place : places) {
    std::map<int, int> votes;
    for (int i : place.members) ++votes[sightings[i].tag_id];
    for (const auto& [id, count] : votes) {
      if (count > place.votes) {  // std::map order: ties keep the smallest id
        place.tag_id = id;
        place.votes = count;
      }
    }
    place.confirmed = place.votes >= options.min_votes &&
                      place.votes >= options.min_vote_fraction * static_cast<double>(place.members.size());
    // The mean of the sightings that agree with the vote.
    Eigen::Vector2d position_sum = Eigen::Vector2d::Zero(), heading_sum = Eigen::Vector2d::Zero();
    double position_weight = 0.0;
    Eigen::Matrix3d covariance_sum = Eigen::Matrix3d::Zero();
    for (int i : place.members) {
      const PlacedTagSighting& s = sightings[i];
      if (s.tag_id != place.tag_id) continue;
      const double w = 1.0 / std::max(1e-12, s.covariance.topLeftCorner<2, 2>().trace());
      const double w_theta = 1.0 / std::max(1e-12, s.covariance(2, 2));
      position_sum += w * s.robot_T_tag.translation();
      position_weight += w;
      heading_sum += w_theta * Eigen::Vector2d(std::cos(s.robot_T_tag.theta()), std::sin(s.robot_T_tag.theta()));
      covariance_sum += s.covariance;
    }
    place.robot_T_tag = Pose2(position_sum / position_weight, std::atan2(heading_sum.y(), heading_sum.x()));
    place.covariance = covariance_sum / (static_cast<double>(place.votes) *
                                         std::min(place.votes, options.max_independent_sightings));
  }
  // Two confirmed places of one id side by side are one tag whose heading came out split (a
  // far tag's pose can flip between two solutions): the place with more votes keeps the id.
  // Confirmed places of one id farther apart make it ambiguous.
  for (TagPlace& place : places) {
    if (!place.confirmed) continue;
    for (const TagPlace& other : places) {
      if (&other == &place || !other.confirmed || other.tag_id != place.tag_id) continue;
      const double distance = (other.robot_T_tag.translation() - place.robot_T_tag.translation()).norm();
      if (distance > 2.0 * options.radius_meters) {
        place.ambiguous = true;
      } else if (other.votes > place.votes || (other.votes == place.votes && &other < &place)) {
        place.outvoted = true;
      }
    }
  }
  for (TagPlace& place : places) {
    if (place.outvoted) place.confirmed = false;
  }
  return places;
}

const TagPlace* FindTagPlace(const std::vector<TagPlace>& places, int tag_id) {
  for (const TagPlace& place : places) {
    if (place.confirmed && !place.ambiguous && place.tag_id == tag_id) return &place;
  }
  return nullptr;
}

}  // namespace hetslam
