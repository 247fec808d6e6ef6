// The loop closer (frontends/loop_closer.h). Its drift gate: a closure accepted against a
// submap measures how far the graph's estimate is off that submap; until the next solve, that
// submap's gate is the base plus that offset plus the drift since, where the drift since the
// last solve alone allows more; its wide search leaves out a submap whose own drift bound (the
// travel since the submap began) is within the standard window. Its agreeing search: revisits
// seen the other way round, whose matches score below min_score, close the loop once two nodes
// call for the same correction.
#include "frontends/loop_closer.h"

#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include "core/laser_map.h"
#include "gtest/gtest.h"
#include "tests/frontends/sim_fixtures.h"

namespace hetslam {
namespace {

// What the robot at `pose` sees, in its own frame: one beam per degree over `fov_degrees`
// centred ahead.
std::vector<Eigen::Vector2f> Scan(const sim::World& world, const Pose2& pose, int fov_degrees = 360) {
  std::vector<Eigen::Vector2f> points;
  for (int i = 0; i < fov_degrees; ++i) {
    const double angle = (-0.5 * fov_degrees + i) * M_PI / 180.0;
    double range = 0.0;
    if (!world.CastRay(pose.translation(), pose.theta() + angle, 20.0, &range)) continue;
    points.emplace_back(static_cast<float>(range * std::cos(angle)), static_cast<float>(range * std::sin(angle)));
  }
  return points;
}

LocalResult Node(double stamp, const Pose2& estimate, std::vector<Eigen::Vector2f> points) {
  LocalResult result;
  result.inserted = true;
  result.stamp_seconds = stamp;
  result.local_pose = estimate;
  result.points.all = points;
  result.points.matching = std::move(points);
  result.points.labels.assign(result.points.all.size(), PointLabel::kStructure);
  return result;
}

// Submap 0: the room mapped from the origin, finished with node 0. Then 45 nodes standing at
// the origin in submap 1 (never finished), so that submap 0 is old enough to be searched.
// Then node 46 at truth (0.5, -0.5), estimated `offset_46` metres off along x, and node 47 at
// truth (-0.5, -0.5), estimated `offset_47` metres off along x.
std::unique_ptr<SubmapGraph> Graph(double offset_47, double offset_46 = 0.05) {
  const sim::World world = testing_sim::RoomWithPillar();
  auto map = std::make_shared<LaserMap>(OccupancyGridOptions(), LikelihoodFieldOptions());
  for (int k = 0; k < 3; ++k) map->InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), Scan(world, Pose2::Identity()));
  map->Freeze();
  auto graph = std::make_unique<SubmapGraph>(SubmapGraphOptions());
  LocalResult first = Node(0.0, Pose2::Identity(), Scan(world, Pose2::Identity()));
  first.new_submaps.push_back({0, Pose2::Identity()});
  first.insertions.push_back({0, Pose2::Identity()});
  first.finished = LocalResult::FinishedSubmap{0, map};
  graph->AddNode(0, std::move(first));
  for (int i = 1; i <= 45; ++i) {
    LocalResult standing = Node(i, Pose2::Identity(), Scan(world, Pose2::Identity()));
    if (i == 1) standing.new_submaps.push_back({1, Pose2::Identity()});
    standing.insertions.push_back({1, Pose2::Identity()});
    graph->AddNode(0, std::move(standing));
  }
  const Pose2 truth_46(0.5, -0.5, 0.0), truth_47(-0.5, -0.5, 0.0);
  for (const auto& [truth, offset] : {std::make_pair(truth_46, offset_46), std::make_pair(truth_47, offset_47)}) {
    const Pose2 estimate(truth.translation().x() + offset, truth.translation().y(), truth.theta());
    LocalResult moved = Node(graph->num_nodes(0), estimate, Scan(world, truth));
    moved.insertions.push_back({1, estimate});
    graph->AddNode(0, std::move(moved));
  }
  return graph;
}

bool ClosesWith(const LoopSearchResult& result, int submap, double correction_meters, const SubmapGraph& graph,
                const NodeId& node) {
  for (const ConstraintCandidate& closure : result.closures) {
    if (closure.submap.index != submap) continue;
    const Pose2 estimate = graph.SubmapPose(closure.submap).inverse() * graph.NodePose(node);
    if (std::abs(Between(estimate, closure.submap_T_node).translation().norm() - correction_meters) < 0.03) return true;
  }
  return false;
}

TEST(LoopCloserTest, AClosureNarrowsItsSubmapsGateUntilTheNextSolve) {
  const NodeId node_46{0, 46}, node_47{0, 47};
  // Node 47's estimate is 0.5 m off: within the gate after 5.5 m of travel since the solve
  // (0.3 + 0.1 * 5.5 = 0.85 m)...
  const std::unique_ptr<SubmapGraph> graph = Graph(0.5);
  LoopCloser fresh{LoopCloserOptions()};
  fresh.AddTravel(5.5);
  EXPECT_TRUE(ClosesWith(fresh.Search(*graph, node_47), 0, 0.5, *graph, node_47));

  // ... but not after node 46's closure to submap 0 measured the estimate 5 cm off it, 0.5 m
  // of travel before: 0.3 + 0.05 + 0.1 * 0.5 = 0.4 m. An estimate that far off that submap
  // is an alias, not drift.
  LoopCloser measured{LoopCloserOptions()};
  measured.AddTravel(5.0);
  EXPECT_TRUE(ClosesWith(measured.Search(*graph, node_46), 0, 0.05, *graph, node_46));
  measured.AddTravel(0.5);
  EXPECT_TRUE(measured.Search(*graph, node_47).closures.empty());

  // A solve forgets what closures measured: the drift since it decides again.
  LoopCloser solved{LoopCloserOptions()};
  solved.AddTravel(5.0);
  ASSERT_FALSE(solved.Search(*graph, node_46).closures.empty());
  solved.OnSolve();
  solved.AddTravel(5.5);
  EXPECT_TRUE(ClosesWith(solved.Search(*graph, node_47), 0, 0.5, *graph, node_47));

  // Within the narrowed gate it still closes: 0.3 m off is drift it allows.
  const std::unique_ptr<SubmapGraph> near = Graph(0.3);
  LoopCloser narrowed{LoopCloserOptions()};
  narrowed.AddTravel(5.0);
  ASSERT_FALSE(narrowed.Search(*near, node_46).closures.empty());
  narrowed.AddTravel(0.5);
  EXPECT_TRUE(ClosesWith(narrowed.Search(*near, node_47), 0, 0.3, *near, node_47));
}

TEST(LoopCloserTest, TheWideSearchLeavesOutSubmapsWhoseDriftBoundIsWithinTheStandardWindow) {
  const NodeId node_0{0, 0}, node_46{0, 46}, node_47{0, 47};
  // Nodes 46 and 47 both estimated 3 m off submap 0 along x: beyond the standard ±2 m window,
  // a correction only the wide search can find.
  const std::unique_ptr<SubmapGraph> graph = Graph(3.0, 3.0);
  // The loop closer searched node 0 after `before` metres since the last solve, node 46
  // `after` metres later and node 47 a metre after that: the closures each of them returned.
  const auto closures = [&](LoopCloser* closer, double before, double after) {
    closer->AddTravel(before);
    EXPECT_TRUE(closer->Search(*graph, node_0).closures.empty());
    closer->AddTravel(after);
    const size_t first = closer->Search(*graph, node_46).closures.size();
    closer->AddTravel(1.0);
    return std::make_pair(first, closer->Search(*graph, node_47).closures.size());
  };
  // 40 m since the solve, all of it since submap 0 began: a drift bound of 4.3 m from it. The
  // first wide match is a candidate, the second confirms it.
  LoopCloser far{LoopCloserOptions()};
  EXPECT_EQ(closures(&far, 0.0, 40.0), std::make_pair(size_t{0}, size_t{2}));
  EXPECT_EQ(far.stats().wide_accepted, 2);
  EXPECT_EQ(far.stats().wide_within_standard, 0);
  // 55 m since the solve (a drift bound of 5.8 m), but submap 0 began 15 m before node 46: its
  // estimate is chained to theirs over 15-16 m, a drift bound of 1.8-1.9 m, within the
  // standard window that found nothing. 3 m off it is an alias, not drift: no wide search.
  LoopCloser near{LoopCloserOptions()};
  EXPECT_EQ(closures(&near, 40.0, 15.0), std::make_pair(size_t{0}, size_t{0}));
  EXPECT_EQ(near.stats().wide_searches, 0);
  EXPECT_EQ(near.stats().wide_within_standard, 2);
  // A node the loop closer never searched tells it nothing: the drift since the solve decides.
  LoopCloser unknown{LoopCloserOptions()};
  unknown.AddTravel(55.0);
  EXPECT_TRUE(unknown.Search(*graph, node_46).closures.empty());
  unknown.AddTravel(1.0);
  EXPECT_EQ(unknown.Search(*graph, node_47).closures.size(), 2u);
}

// Submap 0: the room seen from the origin looking east with a 240° laser, finished with node
// 0; 45 nodes standing there in submap 1. Then nodes 46 and 47 near the south wall looking
// north-west (half of what they see is what submap 0 had behind it: their right matches score
// 0.43-0.44, below min_score), estimated off their truth by `offset_46` and `offset_47` (world
// frame).
std::unique_ptr<SubmapGraph> LookingBackGraph(const Eigen::Vector2d& offset_46, const Eigen::Vector2d& offset_47) {
  const sim::World world = testing_sim::RoomWithPillar();
  constexpr int kFov = 240;
  auto map = std::make_shared<LaserMap>(OccupancyGridOptions(), LikelihoodFieldOptions());
  for (int k = 0; k < 3; ++k) {
    map->InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), Scan(world, Pose2::Identity(), kFov));
  }
  map->Freeze();
  auto graph = std::make_unique<SubmapGraph>(SubmapGraphOptions());
  LocalResult first = Node(0.0, Pose2::Identity(), Scan(world, Pose2::Identity(), kFov));
  first.new_submaps.push_back({0, Pose2::Identity()});
  first.insertions.push_back({0, Pose2::Identity()});
  first.finished = LocalResult::FinishedSubmap{0, map};
  graph->AddNode(0, std::move(first));
  for (int i = 1; i <= 45; ++i) {
    LocalResult standing = Node(i, Pose2::Identity(), Scan(world, Pose2::Identity(), kFov));
    if (i == 1) standing.new_submaps.push_back({1, Pose2::Identity()});
    standing.insertions.push_back({1, Pose2::Identity()});
    graph->AddNode(0, std::move(standing));
  }
  const Pose2 truth_46(0.1, -1.5, 0.75 * M_PI), truth_47(0.4, -1.2, 0.75 * M_PI);
  for (const auto& [truth, offset] : {std::make_pair(truth_46, offset_46), std::make_pair(truth_47, offset_47)}) {
    const Pose2 estimate(truth.translation() + offset, truth.theta());
    LocalResult moved = Node(graph->num_nodes(0), estimate, Scan(world, truth, kFov));
    moved.insertions.push_back({1, estimate});
    graph->AddNode(0, std::move(moved));
  }
  return graph;
}

// The agreeing search on (off by default), as examples/flags/unbiased.flags sets it.
LoopCloserOptions Agreeing() {
  LoopCloserOptions options;
  options.agreeing_min_score = 0.35;
  return options;
}

TEST(LoopCloserTest, RevisitsSeenTheOtherWayRoundCloseWhenTwoNodesAgree) {
  const NodeId node_46{0, 46}, node_47{0, 47};
  const Eigen::Vector2d offset(0.2, 0.05);
  const std::unique_ptr<SubmapGraph> graph = LookingBackGraph(offset, offset);
  // 20 m since the last solve: a drift bound of 2.3 m, beyond the standard window.
  LoopCloser closer{Agreeing()};
  closer.AddTravel(20.0);
  const LoopSearchResult first = closer.Search(*graph, node_46);
  EXPECT_TRUE(first.closures.empty()) << "one node's match below min_score is only a candidate";
  EXPECT_EQ(closer.stats().agreeing_candidates, 1);
  closer.AddTravel(1.0);
  const LoopSearchResult second = closer.Search(*graph, node_47);
  ASSERT_EQ(second.closures.size(), 2u);
  EXPECT_TRUE(second.solve_now);
  EXPECT_EQ(closer.stats().agreeing_accepted, 2);
  for (const ConstraintCandidate& closure : second.closures) {
    EXPECT_LT(closure.score, closer.options().min_score);
    EXPECT_GE(closure.score, closer.options().agreeing_min_score);
    EXPECT_TRUE(closure.robust);
    EXPECT_EQ(closure.submap.index, 0);
  }
  EXPECT_TRUE(ClosesWith(second, 0, offset.norm(), *graph, node_46));
  EXPECT_TRUE(ClosesWith(second, 0, offset.norm(), *graph, node_47));

  // Node 46 searched 20 m after the last solve, node 47 a metre later (with a solve between
  // them if asked): how many closures each search returned.
  const auto closures_of_both = [&](LoopCloser* closer, const SubmapGraph& g, bool solve_between) {
    closer->AddTravel(20.0);
    const size_t first = closer->Search(g, node_46).closures.size();
    if (solve_between) {
      closer->OnSolve();
      closer->AddTravel(20.0);
    }
    closer->AddTravel(1.0);
    return std::make_pair(first, closer->Search(g, node_47).closures.size());
  };
  const std::pair<size_t, size_t> none{0, 0};
  // Off (the default): the standard and wide searches find nothing (the matches score below
  // their minimum).
  LoopCloser off{LoopCloserOptions()};
  EXPECT_EQ(closures_of_both(&off, *graph, false), none);
  EXPECT_EQ(off.stats().agreeing_searches, 0);
  // Two nodes that call for corrections 0.15 m apart: neither closes.
  const std::unique_ptr<SubmapGraph> apart = LookingBackGraph(offset, Eigen::Vector2d(0.2, -0.1));
  LoopCloser disagreeing{Agreeing()};
  EXPECT_EQ(closures_of_both(&disagreeing, *apart, false), none);
  EXPECT_EQ(disagreeing.stats().agreeing_candidates, 2);
  // A solve between them: the first candidate's correction was of the estimate before it.
  LoopCloser solved{Agreeing()};
  EXPECT_EQ(closures_of_both(&solved, *graph, true), none);
  EXPECT_EQ(solved.stats().agreeing_candidates, 2);
}

}  // namespace
}  // namespace hetslam
