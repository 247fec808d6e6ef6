#include "merger/team_estimator.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/laser_map.h"
#include "datasets/sim/simulator.h"
#include "datasets/sim/world.h"
#include "glog/logging.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

// An L-shaped 14 m x 9 m floor (no symmetry) with boxes, and three tags on its walls (their
// normals point into the room): tag 1 on the west wall, tag 2 on the east wall, tag 3 on the
// south wall.
constexpr char kWorld[] = R"(
wall 0 0 14 0
wall 14 0 14 6
wall 14 6 9 6
wall 9 6 9 9
wall 9 9 0 9
wall 0 9 0 0
box 3 8.2 1.2 0.6
box 6.5 1.0 0.8 0.8 20
box 11.5 4.8 0.6 1.0
box 1.0 2.5 0.5 0.5 45
box 7.5 5 0.4 0.4
laser 360 361 10 0.01 0.002 5
robot 0.5 45
)";

struct TagTruthPose {
  int id;
  Pose2 world_T_tag;  // planar landmark frame: x along the tag's normal
};
const TagTruthPose kTags[] = {{1, Pose2(0.0, 4.5, 0.0)}, {2, Pose2(14.0, 3.0, M_PI)}, {3, Pose2(5.0, 0.0, M_PI / 2)}};

struct SimulatedRobot {
  sim::SimulationResult simulation;
  Pose2 world_T_start;
};

// `route` driven in `world` (the scenario's statements without the route).
SimulatedRobot Simulate(const std::string& route, uint64_t seed, const std::string& world = kWorld) {
  sim::Scenario scenario;
  const Status parsed = sim::ParseScenario(world + route, "team_test", &scenario);
  CHECK(parsed.ok()) << parsed.message();
  std::mt19937_64 rng(seed);
  SimulatedRobot robot;
  const Status simulated = sim::Simulate(scenario, sim::SimulatorOptions(), &rng, &robot.simulation);
  CHECK(simulated.ok()) << simulated.message();
  robot.world_T_start = robot.simulation.truth.front().pose;
  return robot;
}

// Which tags a robot sees at each scan and with which id (to inject wrong ids).
using IdMap = std::map<int, int>;  // true id -> reported id (-1: never seen)

// The tag path alone (these robots' maps overlap, so the map-overlap search would link them by
// itself); the map-overlap tests below turn it on.
TeamEstimatorOptions TestTeamOptions() {
  TeamEstimatorOptions options;
  options.tag_sizes_meters = {{1, 0.2}, {2, 0.2}, {3, 0.2}};
  options.overlap_search = false;
  return options;
}

OnlineEstimatorOptions TestRobotOptions() {
  OnlineEstimatorOptions options;
  options.local.scans_per_submap = 20;
  return options;
}

// Feeds the robots' scans interleaved by stamp; after each scan, the tags within 3.5 m whose
// normal faces the robot (within 60°) are reported as sightings with their true planar pose,
// under the id `ids` maps them to.
void RunTeam(const std::vector<SimulatedRobot>& robots, const std::vector<IdMap>& ids, TeamEstimator* team,
             const std::vector<TagTruthPose>& tags = std::vector<TagTruthPose>(std::begin(kTags), std::end(kTags))) {
  for (size_t r = 0; r < robots.size(); ++r) {
    TeamRobotOptions options;
    options.name = "robot" + std::to_string(r);
    options.estimator = TestRobotOptions();
    int index = -1;
    ASSERT_TRUE(team->AddRobot(options, &index).ok());
    ASSERT_EQ(static_cast<int>(r), index);
  }
  std::vector<size_t> next(robots.size(), 0);
  while (true) {
    int pick = -1;
    for (size_t r = 0; r < robots.size(); ++r) {
      const auto& lasers = robots[r].simulation.log.lasers;
      if (next[r] >= lasers.size()) continue;
      if (pick < 0 || lasers[next[r]].scan.stamp_seconds <
                          robots[pick].simulation.log.lasers[next[pick]].scan.stamp_seconds) {
        pick = static_cast<int>(r);
      }
    }
    if (pick < 0) break;
    const size_t k = next[pick]++;
    const LaserReading& reading = robots[pick].simulation.log.lasers[k];
    ASSERT_TRUE(team->Add(pick, reading).ok());
    const Pose2& world_T_body = robots[pick].simulation.truth[k].pose;
    for (const TagTruthPose& tag : tags) {
      const auto id = ids[pick].find(tag.id);
      if (id == ids[pick].end() || id->second < 0) continue;
      PlanarTagSighting sighting;
      sighting.body_T_tag = Between(world_T_body, tag.world_T_tag);
      const Eigen::Vector2d to_robot = world_T_body.translation() - tag.world_T_tag.translation();
      const double range = to_robot.norm();
      const Eigen::Vector2d normal(std::cos(tag.world_T_tag.theta()), std::sin(tag.world_T_tag.theta()));
      if (range > 3.5 || normal.dot(to_robot) < std::cos(60 * kDeg) * range) continue;
      sighting.range_meters = range;
      sighting.covariance = Eigen::Vector3d(0.02 * 0.02, 0.02 * 0.02, 0.01 * 0.01).asDiagonal();
      ASSERT_TRUE(team->AddTagSighting(pick, reading.scan.stamp_seconds, id->second, sighting).ok());
    }
  }
  team->Finish();
}

void ExpectRelativePoseNear(const TeamEstimator& team, const std::vector<SimulatedRobot>& robots, int i, int j,
                            double meters, double radians) {
  Pose2 i_T_j;
  ASSERT_TRUE(team.RelativePose(i, j, &i_T_j)) << i << "-" << j << " not linked";
  const Pose2 error = Between(Between(robots[i].world_T_start, robots[j].world_T_start), i_T_j);
  EXPECT_LT(error.translation().norm(), meters) << i << "-" << j << ": " << i_T_j;
  EXPECT_LT(std::abs(error.theta()), radians) << i << "-" << j << ": " << i_T_j;
}

// Robot 0 starts in the west, robot 1 in the east facing the other way; both pass tag 1.
const char kRouteA[] = "start 2 2 90\nwaypoint 2 6\nwaypoint 5 7.5\nwaypoint 5 4\nwaypoint 2 4.5\nwaypoint 3 2\n";
const char kRouteB[] = "start 12 2 180\nwaypoint 8 3\nwaypoint 3 3.5\nwaypoint 2.2 5\nwaypoint 4 7.5\nwaypoint 8 4\n";
// Robot 2 stays in the east: it shares tag 2 with robot 1 only.
const char kRouteC[] = "start 12.5 5 -90\nwaypoint 12.5 1.5\nwaypoint 10 2\nwaypoint 11 4.5\n";
// Robot 1 variant that also passes tag 2 (for the chain through robot 1).
const char kRouteBEast[] = "start 12 2 180\nwaypoint 8 3\nwaypoint 3 3.5\nwaypoint 2.2 5\nwaypoint 4 7.5\n"
                           "waypoint 8 4\nwaypoint 12 3\nwaypoint 12.5 4.5\n";

TEST(TeamEstimatorTest, LinksThroughASharedTagAndRecoversTheRelativePose) {
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteB, 2)};
  TeamEstimator team(TestTeamOptions());
  RunTeam(robots, {{{1, 1}, {3, 3}}, {{1, 1}, {3, 3}}}, &team);
  ASSERT_TRUE(team.InCommonFrame(1));
  ExpectRelativePoseNear(team, robots, 0, 1, 0.10, 1.0 * kDeg);
  ASSERT_FALSE(team.events().empty());
  EXPECT_EQ(TeamMergeEvent::Kind::kFirstLink, team.events().front().kind);
  // The link's scan matches were recorded as accepted inter-robot constraints.
  const auto& records = team.constraints();
  EXPECT_TRUE(std::any_of(records.begin(), records.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kTagScanMatch && r.accepted;
  }));
  // The common-frame trajectory of robot 1 follows its truth in robot 0's start frame.
  const std::vector<StampedPose2> trajectory = team.CommonTrajectory(1);
  ASSERT_EQ(robots[1].simulation.truth.size(), trajectory.size());
  const Pose2 common_T_world = robots[0].world_T_start.inverse();
  const Pose2 last_truth = common_T_world * robots[1].simulation.truth.back().pose;
  EXPECT_LT((trajectory.back().pose.translation() - last_truth.translation()).norm(), 0.2);
}

// Robot 1 never sees tag 1; its sightings of tag 2 all come labelled 1 (a consistently wrong
// id, which no vote can catch). Eq. 4 then puts robot 1 metres off, and its scans do not fit
// robot 0's map there: never linked, and the rejection is recorded with its reason.
TEST(TeamEstimatorTest, AWrongTagIdNeverMergesTheRobots) {
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteBEast, 2)};
  TeamEstimator team(TestTeamOptions());
  RunTeam(robots, {{{1, 1}}, {{2, 1}}}, &team);
  EXPECT_FALSE(team.InCommonFrame(1));
  Pose2 unused;
  EXPECT_FALSE(team.RelativePose(0, 1, &unused));
  const auto& records = team.constraints();
  ASSERT_FALSE(records.empty());
  for (const TeamConstraintRecord& r : records) {
    EXPECT_FALSE(r.accepted) << r.reason;
  }
  EXPECT_TRUE(std::any_of(records.begin(), records.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kTagRelativePose && r.reason.find("rejected") == 0;
  }));
}

// A second tag both robots placed contradicts the first: the link is refused outright.
TEST(TeamEstimatorTest, TwoTagsThatDisagreeAreRejected) {
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteBEast, 2)};
  TeamEstimator team(TestTeamOptions());
  // Robot 0 sees tags 1 and 3; robot 1 sees tag 3 right and tag 2 labelled 1.
  RunTeam(robots, {{{1, 1}, {3, 3}}, {{2, 1}, {3, 3}}}, &team);
  EXPECT_FALSE(team.InCommonFrame(1));
  const auto& records = team.constraints();
  EXPECT_TRUE(std::any_of(records.begin(), records.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kTagRelativePose && r.reason.find("rejected: tag") == 0;
  }));
}

// Robots 0 and 2 never share a tag; robot 1 shares tag 1 with robot 0 and tag 2 with robot 2.
// The shared graph puts robot 2 in robot 0's frame through robot 1.
TEST(TeamEstimatorTest, ChainsTransitivelyThroughTheMiddleRobot) {
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteBEast, 2),
                                              Simulate(kRouteC, 3)};
  TeamEstimator team(TestTeamOptions());
  RunTeam(robots, {{{1, 1}}, {{1, 1}, {2, 2}}, {{2, 2}}}, &team);
  ASSERT_TRUE(team.InCommonFrame(1));
  ASSERT_TRUE(team.InCommonFrame(2));
  EXPECT_EQ((std::vector<int>{0, 1, 2}), team.Group(2));
  ExpectRelativePoseNear(team, robots, 0, 1, 0.10, 1.0 * kDeg);
  ExpectRelativePoseNear(team, robots, 1, 2, 0.10, 1.0 * kDeg);
  ExpectRelativePoseNear(team, robots, 0, 2, 0.15, 1.0 * kDeg);
  // No tag record links robots 0 and 2 directly.
  for (const TeamConstraintRecord& r : team.constraints()) {
    if (r.kind != TeamConstraintKind::kScanMatch) {
      EXPECT_FALSE(r.robot_a == 0 && r.robot_b == 2);
    }
  }
}

// No tag at all: the robots' maps overlap in the L-shaped room, which has no symmetry. The
// wide matches of each robot's scans in the other's submaps agree, the whole maps agree under
// that pose, and the robots are merged by map overlap alone, at the true relative pose.
TEST(TeamEstimatorTest, MergesByMapOverlapWithoutAnyTag) {
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteB, 2)};
  TeamEstimatorOptions options = TestTeamOptions();
  options.overlap_search = true;
  TeamEstimator team(options);
  RunTeam(robots, {{}, {}}, &team);
  ASSERT_TRUE(team.InCommonFrame(1));
  ExpectRelativePoseNear(team, robots, 0, 1, 0.10, 1.0 * kDeg);
  EXPECT_EQ(1, team.stats().overlap_links);
  ASSERT_FALSE(team.events().empty());
  EXPECT_EQ(TeamMergeEvent::Kind::kFirstLink, team.events().front().kind);
  EXPECT_EQ(0u, team.events().front().description.find("map overlap")) << team.events().front().description;
  const auto& records = team.constraints();
  EXPECT_TRUE(std::any_of(records.begin(), records.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kMapOverlap && r.accepted;
  }));
  // No wrong hypothesis was ever accepted.
  for (const TeamConstraintRecord& r : records) {
    if (r.kind != TeamConstraintKind::kMapOverlap || !r.accepted) continue;
    const Pose2 truth = Between(robots[0].world_T_start, robots[1].world_T_start);
    EXPECT_LT(Between(truth, r.a_T_b).translation().norm(), 0.15) << r.reason;
  }
}

// The maps say the robots share the room, but the tags disagree: robot 1 reports its sightings
// of tag 2 (east wall) as tag 1, which robot 0 placed on the west wall. A map-overlap pose that
// puts one tag id at two places 14 m apart is refused (a building of congruent rooms looks like
// this), and the refusal names the tag.
TEST(TeamEstimatorTest, AMapOverlapThatPutsATagAtTwoPlacesIsRefused) {
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteBEast, 2)};
  TeamEstimatorOptions options = TestTeamOptions();
  options.overlap_search = true;
  TeamEstimator team(options);
  RunTeam(robots, {{{1, 1}}, {{2, 1}}}, &team);
  EXPECT_FALSE(team.InCommonFrame(1));
  EXPECT_EQ(0, team.stats().overlap_links);
  const auto& records = team.constraints();
  EXPECT_TRUE(std::any_of(records.begin(), records.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kMapOverlap && !r.accepted && r.reason.find("tag 1 placed") != std::string::npos;
  }));
}

// The maps link the robots first; the tags contradict the link only later. Robot 1 starts next
// to robot 0 in the west (the overlap link is made there) and sees tag 2 (east wall), which it
// reports as tag 1, only at the end of its route: robot 0 placed tag 1 on the west wall, 14 m
// away. The joined group's tags contradict each other, the map-overlap link that joined them
// is withdrawn with every constraint across it, the robots are apart again, and the same pose
// is not accepted again. (In a building of congruent rooms the link would be the wrong one; here
// the id is, which the estimator cannot know: the tags outrank the maps.)
TEST(TeamEstimatorTest, AMapOverlapLinkThatTheTagsContradictLaterIsWithdrawn) {
  const char kRouteLateEast[] = "start 3 3.5 0\nwaypoint 2.2 5\nwaypoint 4 7.5\nwaypoint 8 4\nwaypoint 12 3\n"
                                "waypoint 12.5 4.5\nwaypoint 12 2\n";
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteLateEast, 2)};
  TeamEstimatorOptions options = TestTeamOptions();
  options.overlap_search = true;
  TeamEstimator team(options);
  RunTeam(robots, {{{1, 1}}, {{2, 1}}}, &team);
  EXPECT_EQ(1, team.stats().overlap_links);
  EXPECT_EQ(1, team.stats().overlap_links_withdrawn);
  EXPECT_FALSE(team.InCommonFrame(1));
  Pose2 unused;
  EXPECT_FALSE(team.RelativePose(0, 1, &unused));
  // Linked, a constraint found through the link (its second), then split again.
  const auto& events = team.events();
  ASSERT_GE(events.size(), 2u);
  EXPECT_EQ(TeamMergeEvent::Kind::kFirstLink, events.front().kind);
  EXPECT_EQ(TeamMergeEvent::Kind::kWithdrawn, events.back().kind);
  EXPECT_NE(std::string::npos, events.back().description.find("tag 1 placed")) << events.back().description;
  EXPECT_EQ(1, std::count_if(events.begin(), events.end(),
                             [](const TeamMergeEvent& e) { return e.kind == TeamMergeEvent::Kind::kWithdrawn; }));
  const auto& records = team.constraints();
  EXPECT_TRUE(std::any_of(records.begin(), records.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kMapOverlap && !r.accepted && r.reason.find("withdrawn") == 0;
  }));
}

// Two ids at one place: robot 1 reports tag 1 (west wall) as tag 3. The map-overlap pose puts
// robot 1's tag 3 where robot 0's tag 1 is, facing the same way: two tags cannot hang there.
// The link (made before robot 1 reaches the tag) does not stand, and the record names both.
TEST(TeamEstimatorTest, AMapOverlapThatPutsTwoTagsAtOnePlaceDoesNotStand) {
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteB, 2)};
  TeamEstimatorOptions options = TestTeamOptions();
  options.overlap_search = true;
  TeamEstimator team(options);
  RunTeam(robots, {{{1, 1}}, {{1, 3}}}, &team);
  EXPECT_FALSE(team.InCommonFrame(1));
  EXPECT_EQ(team.stats().overlap_links, team.stats().overlap_links_withdrawn);
  const auto& records = team.constraints();
  EXPECT_TRUE(std::any_of(records.begin(), records.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kMapOverlap && !r.accepted &&
           r.reason.find("tags 1 and 3 placed") != std::string::npos &&
           r.reason.find("facing the same way") != std::string::npos;
  }));
}

// Two congruent rooms 20 m apart (the same walls and boxes, no symmetry within a room), a tag at
// the same place of each: tag 1 in the west room, tag 2 in the east one. Robot 0 maps the west
// room and sees tag 1 at once; robot 1 maps the east room and reaches tag 2 only at the end of
// its short route. Robot 1's scans fit robot 0's room perfectly 20 m off: the map-overlap pose
// passes every check while robot 1 has no tag place yet. It is held, not linked; by its
// re-confirmation robot 1 has placed tag 2 where robot 0's tag 1 hangs (two tags at one place):
// the pose is dropped and refused from then on. The robots are never merged (they share no
// place), and no wrong link is ever made and withdrawn (without the hold the pose is linked at
// t = 10 s and withdrawn at t = 14 s, when robot 1's tag 2 place has two sightings).
TEST(TeamEstimatorTest, AMapOverlapPoseInCongruentRoomsIsHeldAndNeverLinked) {
  const std::string rooms = R"(
wall 0 0 8 0
wall 8 0 8 6
wall 8 6 0 6
wall 0 6 0 0
box 2 4.8 1.2 0.6
box 6 1.2 0.8 0.8 20
box 5.5 4 0.4 0.4
box 1.2 1.5 0.5 0.5 45
wall 20 0 28 0
wall 28 0 28 6
wall 28 6 20 6
wall 20 6 20 0
box 22 4.8 1.2 0.6
box 26 1.2 0.8 0.8 20
box 25.5 4 0.4 0.4
box 21.2 1.5 0.5 0.5 45
laser 360 361 10 0.01 0.002 5
robot 0.5 45
)";
  const std::vector<SimulatedRobot> robots = {
      Simulate("start 2 3 0\nwaypoint 4 2.5\nwaypoint 6.5 3\nwaypoint 6.5 5\nwaypoint 3.5 3\nwaypoint 2 2\n", 1, rooms),
      Simulate("start 26.5 3 90\nwaypoint 26.5 5\nwaypoint 24 4\nwaypoint 22.5 3\n", 2, rooms)};
  const std::vector<TagTruthPose> tags = {{1, Pose2(0.0, 3.0, 0.0)}, {2, Pose2(20.0, 3.0, 0.0)}};
  TeamEstimatorOptions options = TestTeamOptions();
  options.tag_sizes_meters = {{1, 0.2}, {2, 0.2}};
  options.overlap_search = true;
  TeamEstimator team(options);
  RunTeam(robots, {{{1, 1}}, {{2, 2}}}, &team, tags);
  std::string records;
  for (const TeamConstraintRecord& r : team.constraints()) {
    records += std::to_string(r.stamp_seconds) + " " + TeamConstraintKindName(r.kind) + " " + r.reason + "\n";
  }
  EXPECT_FALSE(team.InCommonFrame(1)) << records;
  EXPECT_EQ(0, team.stats().overlap_links) << records;
  EXPECT_EQ(0, team.stats().overlap_links_withdrawn) << records;
  // The wrong pose was held, and its re-confirmation failed on the tags.
  EXPECT_GE(team.stats().overlap_held, 1) << records;
  EXPECT_GE(team.stats().overlap_held_dropped, 1) << records;
  const auto& all = team.constraints();
  EXPECT_TRUE(std::any_of(all.begin(), all.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kMapOverlap && !r.accepted &&
           r.reason.find("tags 1 and 2 placed") != std::string::npos;
  })) << records;
}

// Both robots pass tag 1. The map-overlap pose is held when it first passes (neither place of
// tag 1 is confirmed yet); once both are and the pose puts them together, the shared tag tells
// congruent places apart and the pose is linked at once, long before its re-confirmation (held
// here beyond the end of the run) would link it.
TEST(TeamEstimatorTest, ASharedTagThatTheMapOverlapPosePutsTogetherLinksItWithoutWaiting) {
  const std::vector<SimulatedRobot> robots = {Simulate(kRouteA, 1), Simulate(kRouteB, 2)};
  TeamEstimatorOptions options = TestTeamOptions();
  options.overlap_search = true;
  options.overlap_confirm_seconds = 1000.0;
  options.link_min_matches = 100;  // no tag link: the map overlap links them
  TeamEstimator team(options);
  RunTeam(robots, {{{1, 1}}, {{1, 1}}}, &team);
  std::string records;
  for (const TeamConstraintRecord& r : team.constraints()) {
    records += std::to_string(r.stamp_seconds) + " " + TeamConstraintKindName(r.kind) + " " + r.reason + "\n";
  }
  ASSERT_TRUE(team.InCommonFrame(1)) << records;
  ExpectRelativePoseNear(team, robots, 0, 1, 0.10, 1.0 * kDeg);
  EXPECT_EQ(1, team.stats().overlap_links) << records;
  const auto& all = team.constraints();
  EXPECT_TRUE(std::any_of(all.begin(), all.end(), [](const TeamConstraintRecord& r) {
    return r.kind == TeamConstraintKind::kMapOverlap && r.accepted &&
           r.reason.find("corroborated by tag 1") != std::string::npos;
  })) << records;
}

TEST(TeamEstimatorTest, ErrorsAreReturned) {
  TeamEstimator team(TestTeamOptions());
  TeamRobotOptions robot;
  robot.name = "bad";
  robot.estimator.local.scans_per_submap = 1;  // invalid with loop closure
  int index = -1;
  EXPECT_FALSE(team.AddRobot(robot, &index).ok());
  robot.estimator = TestRobotOptions();
  ASSERT_TRUE(team.AddRobot(robot, &index).ok());
  EXPECT_FALSE(team.Add(5, LaserReading()).ok());
  CameraImage image;
  image.path = "/nonexistent/image.png";
  EXPECT_TRUE(team.Add(0, image).ok());  // no camera: images are ignored
  EXPECT_FALSE(team.AddRobot(robot, &index).ok());  // after the first measurement
  TeamEstimatorOptions options = TestTeamOptions();
  std::string error;
  options.wrong_tag_id_rate = 1.5;
  EXPECT_FALSE(options.IsValid(&error));
  options = TestTeamOptions();
  options.overlap_height_margin_meters = 0.1;  // on (off by default): valid
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.overlap_height_margin_meters = std::nan("");
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(std::string::npos, error.find("overlap_height_margin_meters")) << error;
}

// ---- The anchored team graph itself (frontends/submap_graph.h with anchors) ----

// A robot's nodes on a straight line in its own frame, one submap at its origin.
void AddStraightRobot(int robot, int nodes, SubmapGraph* graph) {
  for (int i = 0; i < nodes; ++i) {
    LocalResult result;
    result.inserted = true;
    result.stamp_seconds = i;
    result.local_pose = Pose2(0.5 * i, 0.0, 0.0);
    if (i == 0) result.new_submaps.push_back({0, Pose2::Identity()});
    result.insertions.push_back({0, result.local_pose});
    graph->AddNode(robot, std::move(result));
  }
}

// Robot 1's frame sits at (3, 4, 30°) in robot 0's: two inter-robot constraints that say so,
// robot 1's anchor started 0.5 m and 5° off (SetAnchorEstimate), solve: the anchor is the answer.
// A match whose correction lies within a cell of its search window's border is not kept (the
// peak may lie beyond it); inside, and on the angular border, it is.
TEST(TeamEstimatorTest, AMatchPressingAgainstTheWindowBorderIsNotKept) {
  constexpr double kWindow = 0.3, kAngle = 0.05, kCell = 0.05;
  EXPECT_TRUE(InsideSearchWindow(Pose2(0.0, 0.0, 0.0), kWindow, kAngle, kCell));
  EXPECT_TRUE(InsideSearchWindow(Pose2(0.25, -0.25, kAngle), kWindow, kAngle, kCell));
  EXPECT_FALSE(InsideSearchWindow(Pose2(0.26, 0.0, 0.0), kWindow, kAngle, kCell));
  EXPECT_FALSE(InsideSearchWindow(Pose2(0.0, -0.2995, 0.0), kWindow, kAngle, kCell));  // team_three seed 3's
  EXPECT_FALSE(InsideSearchWindow(Pose2(0.0, 0.0, 1.01 * kAngle), kWindow, kAngle, kCell));
  // A window narrower than two cells keeps its inner half.
  EXPECT_TRUE(InsideSearchWindow(Pose2(0.02, 0.0, 0.0), 0.04, kAngle, kCell));
  EXPECT_FALSE(InsideSearchWindow(Pose2(0.021, 0.0, 0.0), 0.04, kAngle, kCell));
}

// A 1° scan of `world` from `world_T_robot`, robot frame (range noise 5 mm, 20 m reach).
std::vector<Eigen::Vector2f> ScanOf(const sim::World& world, const Pose2& world_T_robot, std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, 0.005);
  std::vector<Eigen::Vector2f> points;
  for (int i = 0; i < 360; ++i) {
    const double angle = -M_PI + i * kDeg;
    double range = 0.0;
    if (!world.CastRay(world_T_robot.translation(), world_T_robot.theta() + angle, 20.0, &range)) continue;
    const double r = range + noise(*rng);
    points.emplace_back(static_cast<float>(r * std::cos(angle)), static_cast<float>(r * std::sin(angle)));
  }
  return points;
}

// The team's scan match (its matcher, a ±0.3 m, ±5° window from a prediction 10 cm and 2° off)
// of a scan at `truth` in a map of `world` built from three poses along x.
ScanMatchResult TeamMatchIn(const sim::World& world, const Pose2& truth) {
  std::mt19937 rng(3);
  LaserMap map{OccupancyGridOptions(), LikelihoodFieldOptions()};
  for (const Pose2& pose : {Pose2(-1.5, 0.0, 0.0), Pose2(0.0, 0.2, 2.0), Pose2(1.5, -0.2, -1.0)}) {
    map.InsertScan(pose, Eigen::Vector2d::Zero(), ScanOf(world, pose, &rng));
  }
  const ScanMatcher matcher(TestTeamOptions().matcher);
  return matcher.MatchWithinWindow(map, truth * Pose2(0.1, -0.05, 2 * kDeg), ScanOf(world, truth, &rng), 0.3,
                                   5 * kDeg);
}

// A match in a corridor slides along it (its profile is flat there: it refines no tag link and,
// as a constraint, weighs little along the corridor); one in a room with a box pins every
// direction. (team_three seeds 2 and 5: drone scans in a door, 0.07-0.20 m off along it in the
// nao's submaps, passed the information-ratio test.)
TEST(TeamEstimatorTest, AMatchInACorridorSlidesOneInARoomDoesNot) {
  sim::World corridor;
  corridor.AddWall(Eigen::Vector2d(-15.0, -0.8), Eigen::Vector2d(15.0, -0.8));
  corridor.AddWall(Eigen::Vector2d(-15.0, 0.8), Eigen::Vector2d(15.0, 0.8));
  sim::World room;
  room.AddBox(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(8.0, 5.0), 0.0);
  room.AddBox(Eigen::Vector2d(1.5, 1.0), Eigen::Vector2d(0.5, 0.5), 0.0);
  const Pose2 truth(0.3, 0.1, 0.05);
  const ScanMatchResult in_corridor = TeamMatchIn(corridor, truth);
  const ScanMatchResult in_room = TeamMatchIn(room, truth);
  ASSERT_TRUE(in_corridor.converged) << in_corridor.message;
  ASSERT_TRUE(in_room.converged) << in_room.message;
  const double ratio = TeamEstimatorOptions().min_profile_drop_ratio;
  EXPECT_TRUE(MatchSlides(in_corridor, ratio)) << "weak drop " << in_corridor.weak_direction_score_drop
                                               << ", strong " << in_corridor.strong_direction_score_drop;
  EXPECT_NEAR(1.0, std::abs(in_corridor.weak_direction.x()), 0.05) << "it slides along the corridor";
  EXPECT_FALSE(MatchSlides(in_room, ratio)) << "weak drop " << in_room.weak_direction_score_drop << ", strong "
                                            << in_room.strong_direction_score_drop;
  EXPECT_FALSE(MatchSlides(in_corridor, 0.0)) << "0 turns the test off";
  EXPECT_FALSE(MatchSlides(ScanMatchResult(), ratio)) << "no profile: nothing to say";
  TeamEstimatorOptions bad;
  bad.min_profile_drop_ratio = 1.5;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(std::string::npos, why.find("min_profile_drop_ratio")) << why;
}

TEST(TeamGraphTest, AnchorSolveRecoversAKnownRelativePose) {
  SubmapGraph graph{SubmapGraphOptions()};
  AddStraightRobot(0, 5, &graph);
  AddStraightRobot(1, 5, &graph);
  EXPECT_EQ(0, graph.world_robot());
  const Pose2 r0_T_r1(3.0, 4.0, 30 * kDeg);
  EXPECT_FALSE(graph.SetAnchorEstimate(0, r0_T_r1));  // the world's anchor stays at identity
  EXPECT_FALSE(graph.SetAnchorEstimate(7, r0_T_r1));  // unknown robot
  ASSERT_TRUE(graph.SetAnchorEstimate(1, r0_T_r1 * Pose2(0.4, -0.3, 5 * kDeg)));
  for (int node : {1, 4}) {
    ConstraintCandidate c;
    c.submap = {0, 0};
    c.node = {1, node};
    c.submap_T_node = r0_T_r1 * graph.NodePose(c.node);  // robot 0's submap sits at its origin
    ASSERT_TRUE(graph.AddConstraint(c));
  }
  ASSERT_TRUE(graph.Solve(50).ok());
  const Pose2 error = Between(r0_T_r1, Between(graph.Anchor(0), graph.Anchor(1)));
  EXPECT_LT(error.translation().norm(), 1e-6);
  EXPECT_LT(std::abs(error.theta()), 1e-6);
  EXPECT_EQ(Pose2::Identity().ToVector(), graph.Anchor(0).ToVector());
  EXPECT_EQ(2, graph.stats().inter_robot_constraints);

  // Withdrawn: the constraint is reported removed, once.
  EXPECT_FALSE(graph.RemoveInterRobotConstraint({0, 0}, {1, 2}));  // no such constraint
  ASSERT_TRUE(graph.RemoveInterRobotConstraint({0, 0}, {1, 4}));
  EXPECT_FALSE(graph.RemoveInterRobotConstraint({0, 0}, {1, 4}));
  EXPECT_EQ(1, graph.stats().inter_robot_constraints_withdrawn);
  int removed = 0;
  for (const LoopClosureReport& report : graph.LoopClosures()) {
    if (report.kind == EdgeKind::kInterRobot && report.removed) {
      ++removed;
      EXPECT_EQ(4, report.node.index);
    }
  }
  EXPECT_EQ(1, removed);
  ASSERT_TRUE(graph.Solve(50).ok());  // the other constraint still holds the anchor
  EXPECT_LT(Between(r0_T_r1, Between(graph.Anchor(0), graph.Anchor(1))).translation().norm(), 1e-6);
}

}  // namespace
}  // namespace hetslam
