#include "merger/tag_places.h"

#include <random>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

PlacedTagSighting At(int id, double x, double y, double heading_degrees) {
  PlacedTagSighting s;
  s.tag_id = id;
  s.robot_T_tag = Pose2(x, y, heading_degrees * kDeg);
  s.covariance = Eigen::Vector3d(0.01 * 0.01, 0.01 * 0.01, 0.01 * 0.01).asDiagonal();
  return s;
}

// Tag 1 at (0, 5) facing east, tag 2 at (16, 5) facing west, seen with a few cm of noise.
std::vector<PlacedTagSighting> TwoTags(int n1, int n2, std::mt19937_64* rng) {
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<PlacedTagSighting> sightings;
  for (int i = 0; i < std::max(n1, n2); ++i) {
    if (i < n1) sightings.push_back(At(1, noise(*rng), 5 + noise(*rng), noise(*rng) / kDeg));
    if (i < n2) sightings.push_back(At(2, 16 + noise(*rng), 5 + noise(*rng), 180 + noise(*rng) / kDeg));
  }
  return sightings;
}

TEST(TagPlacesTest, OnePlacePerTagWithTheMeanPose) {
  std::mt19937_64 rng(1);
  const std::vector<TagPlace> places = GroupTagSightings(TwoTags(10, 6, &rng), TagPlaceOptions());
  ASSERT_EQ(2u, places.size());
  const TagPlace* one = FindTagPlace(places, 1);
  const TagPlace* two = FindTagPlace(places, 2);
  ASSERT_NE(nullptr, one);
  ASSERT_NE(nullptr, two);
  EXPECT_EQ(10, one->votes);
  EXPECT_EQ(6, two->votes);
  EXPECT_NEAR(0.0, one->robot_T_tag.x(), 0.03);
  EXPECT_NEAR(5.0, one->robot_T_tag.y(), 0.03);
  EXPECT_NEAR(16.0, two->robot_T_tag.x(), 0.03);
  EXPECT_NEAR(M_PI, std::abs(two->robot_T_tag.theta()), 0.03);  // the mean crosses ±pi
  EXPECT_EQ(nullptr, FindTagPlace(places, 3));
}

// Wrong ids: 2 of tag 2's 10 sightings report tag 1. The place at (16, 5) still is tag 2, and
// the only confirmed place of tag 1 is the real one.
TEST(TagPlacesTest, AWrongIdIsOutvotedAtItsPlace) {
  std::mt19937_64 rng(2);
  std::vector<PlacedTagSighting> sightings = TwoTags(8, 10, &rng);
  int relabelled = 0;
  for (PlacedTagSighting& s : sightings) {
    if (s.tag_id == 2 && relabelled < 2) {
      s.tag_id = 1;
      ++relabelled;
    }
  }
  const std::vector<TagPlace> places = GroupTagSightings(sightings, TagPlaceOptions());
  const TagPlace* one = FindTagPlace(places, 1);
  ASSERT_NE(nullptr, one);
  EXPECT_NEAR(0.0, one->robot_T_tag.x(), 0.05);  // the real tag 1, not the relabelled sightings at x = 16
  const TagPlace* two = FindTagPlace(places, 2);
  ASSERT_NE(nullptr, two);
  EXPECT_EQ(8, two->votes);
  EXPECT_EQ(10u, two->members.size());
  EXPECT_NEAR(16.0, two->robot_T_tag.x(), 0.05);  // its mean uses only the sightings that agree
}

// Only wrong sightings of tag 1 (the robot never saw the real one): no place wins id 1.
TEST(TagPlacesTest, AMinorityNeverNamesAPlace) {
  std::mt19937_64 rng(3);
  std::vector<PlacedTagSighting> sightings = TwoTags(0, 10, &rng);
  sightings[3].tag_id = 1;
  sightings[7].tag_id = 1;
  sightings[8].tag_id = 1;
  const std::vector<TagPlace> places = GroupTagSightings(sightings, TagPlaceOptions());
  EXPECT_EQ(nullptr, FindTagPlace(places, 1));
  ASSERT_NE(nullptr, FindTagPlace(places, 2));
}

TEST(TagPlacesTest, TooFewVotesAreNotConfirmed) {
  std::mt19937_64 rng(4);
  const std::vector<TagPlace> places = GroupTagSightings(TwoTags(1, 2, &rng), TagPlaceOptions());
  EXPECT_EQ(nullptr, FindTagPlace(places, 1));  // 1 < min_votes
  EXPECT_NE(nullptr, FindTagPlace(places, 2));
  TagPlaceOptions three;
  three.min_votes = 3;
  EXPECT_EQ(nullptr, FindTagPlace(GroupTagSightings(TwoTags(1, 2, &rng), three), 2));  // 2 < 3
}

// A tag passed by, seen three times, one of them with the other tag's id (team_three's drone
// with wrong ids): the two that agree name the place; one against one does not.
TEST(TagPlacesTest, TwoOfThreeNameAPlaceSeenInPassing) {
  std::mt19937_64 rng(5);
  std::vector<PlacedTagSighting> sightings = TwoTags(10, 3, &rng);
  for (PlacedTagSighting& s : sightings) {
    if (s.tag_id == 2) {
      s.tag_id = 1;  // the first of tag 2's sightings
      break;
    }
  }
  std::vector<TagPlace> places = GroupTagSightings(sightings, TagPlaceOptions());
  const TagPlace* two = FindTagPlace(places, 2);
  ASSERT_NE(nullptr, two);
  EXPECT_EQ(2, two->votes);
  EXPECT_EQ(3u, two->members.size());
  EXPECT_NEAR(16.0, two->robot_T_tag.x(), 0.05);
  const TagPlace* one = FindTagPlace(places, 1);
  ASSERT_NE(nullptr, one);
  EXPECT_NEAR(0.0, one->robot_T_tag.x(), 0.05);  // not the relabelled sighting at x = 16
  // Two sightings of tag 2, one relabelled: 1 of 2 is no majority.
  sightings = TwoTags(10, 2, &rng);
  for (PlacedTagSighting& s : sightings) {
    if (s.tag_id == 2) {
      s.tag_id = 1;
      break;
    }
  }
  places = GroupTagSightings(sightings, TagPlaceOptions());
  EXPECT_EQ(nullptr, FindTagPlace(places, 2));
  ASSERT_NE(nullptr, FindTagPlace(places, 1));
  EXPECT_NEAR(0.0, FindTagPlace(places, 1)->robot_T_tag.x(), 0.05);
}

// One id confirmed at two places (a relabelled tag seen often enough): ambiguous, not used.
TEST(TagPlacesTest, AnIdWinningTwoPlacesIsAmbiguous) {
  std::mt19937_64 rng(5);
  std::vector<PlacedTagSighting> sightings = TwoTags(5, 5, &rng);
  for (PlacedTagSighting& s : sightings) s.tag_id = 1;
  const std::vector<TagPlace> places = GroupTagSightings(sightings, TagPlaceOptions());
  ASSERT_EQ(2u, places.size());
  EXPECT_TRUE(places[0].confirmed && places[0].ambiguous);
  EXPECT_TRUE(places[1].confirmed && places[1].ambiguous);
  EXPECT_EQ(nullptr, FindTagPlace(places, 1));
}

// A far tag whose heading flipped in a few sightings: two places side by side, one id. The
// place with more votes keeps it; the id is not ambiguous.
TEST(TagPlacesTest, ASplitHeadingAtOnePlaceIsNotAmbiguous) {
  std::vector<PlacedTagSighting> sightings;
  for (int i = 0; i < 10; ++i) sightings.push_back(At(2, 16.0, 5.0, 180));
  for (int i = 0; i < 4; ++i) sightings.push_back(At(2, 16.1, 5.05, 140));
  const std::vector<TagPlace> places = GroupTagSightings(sightings, TagPlaceOptions());
  ASSERT_EQ(2u, places.size());
  const TagPlace* two = FindTagPlace(places, 2);
  ASSERT_NE(nullptr, two);
  EXPECT_EQ(10, two->votes);
  EXPECT_TRUE(places[1].outvoted);
  EXPECT_FALSE(places[1].confirmed);
}

TEST(TagPlacesTest, SameHeadingRequired) {
  // Two tags on either side of a thin wall: same place, opposite normals.
  std::vector<PlacedTagSighting> sightings;
  for (int i = 0; i < 3; ++i) {
    sightings.push_back(At(4, 3.0, 3.0, 0));
    sightings.push_back(At(5, 3.0, 3.05, 180));
  }
  const std::vector<TagPlace> places = GroupTagSightings(sightings, TagPlaceOptions());
  EXPECT_EQ(2u, places.size());
  EXPECT_NE(nullptr, FindTagPlace(places, 4));
  EXPECT_NE(nullptr, FindTagPlace(places, 5));
}

TEST(TagPlacesTest, OptionsValidation) {
  TagPlaceOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.min_vote_fraction = 0.5;  // a tie could name a place
  EXPECT_FALSE(options.IsValid(&error));
  options = TagPlaceOptions();
  options.radius_meters = 0;
  EXPECT_FALSE(options.IsValid(&error));
}

}  // namespace
}  // namespace hetslam
