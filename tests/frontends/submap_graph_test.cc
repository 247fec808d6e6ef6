// Degenerate loop closures (the ambiguity issue): a closure matched in a corridor says little
// along it (ConstraintCandidate::weak_direction), so its error there neither pulls the graph
// nor gets it removed; across the corridor it is a closure like any other.
#include <cmath>
#include <algorithm>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "frontends/submap_graph.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

// A straight run along x, 0.5 m a scan; as the front end does, a submap starts every 10 scans
// and takes 20, so each node is in two submaps (one at the start) and they chain up.
std::unique_ptr<SubmapGraph> StraightRun(int nodes) {
  auto graph = std::make_unique<SubmapGraph>(SubmapGraphOptions());
  std::vector<Pose2> submap_origins;
  for (int i = 0; i < nodes; ++i) {
    LocalResult result;
    result.inserted = true;
    result.stamp_seconds = i;
    result.local_pose = Pose2(0.5 * i, 0.0, 0.0);
    if (i % 10 == 0) {
      submap_origins.push_back(result.local_pose);
      result.new_submaps.push_back({i / 10, result.local_pose});
    }
    for (int submap = std::max(0, i / 10 - 1); submap <= i / 10; ++submap) {
      result.insertions.push_back({submap, submap_origins[submap].inverse() * result.local_pose});
    }
    graph->AddNode(0, std::move(result));
  }
  return graph;
}

ConstraintCandidate Closure(const NodeId& node, const Pose2& submap_T_node, const Eigen::Vector2d& weak) {
  ConstraintCandidate closure;
  closure.submap = {0, 0};
  closure.node = node;
  closure.submap_T_node = submap_T_node;
  closure.score = 0.8;
  closure.weak_direction = weak;
  closure.weak_information_fraction = 0.0;
  return closure;
}

TEST(SubmapGraphTest, ConstraintSigmasMustBePositiveAndFinite) {
  std::string error;
  EXPECT_TRUE(SubmapGraphOptions().IsValid(&error)) << error;
  for (const double bad : {0.0, -0.01, 1e4, std::numeric_limits<double>::infinity(),
                           std::numeric_limits<double>::quiet_NaN()}) {
    for (double SubmapGraphOptions::*sigma :
         {&SubmapGraphOptions::intra_translation_sigma_meters, &SubmapGraphOptions::intra_rotation_sigma_radians,
          &SubmapGraphOptions::loop_translation_sigma_meters, &SubmapGraphOptions::loop_rotation_sigma_radians}) {
      SubmapGraphOptions options;
      options.*sigma = bad;
      EXPECT_FALSE(options.IsValid(&error)) << bad;
      EXPECT_NE(error.find("constraint sigmas"), std::string::npos) << error;
    }
  }
}

TEST(SubmapGraphTest, ClosureAgreesIgnoresTheWeakDirection) {
  LoopClosureReport loop;
  loop.measured_submap_T_node = Pose2(5.0, 0.0, 0.5);
  loop.estimated_submap_T_node = loop.measured_submap_T_node * Pose2(1.0, 0.05, 0.0);  // node frame
  EXPECT_FALSE(ClosureAgrees(loop, 0.2, M_PI / 180));
  // The weak direction is given in the submap frame: the node's x axis rotated by 0.5 rad.
  loop.weak_direction = Eigen::Vector2d(std::cos(0.5), std::sin(0.5));
  EXPECT_TRUE(ClosureAgrees(loop, 0.2, M_PI / 180));
  loop.estimated_submap_T_node = loop.measured_submap_T_node * Pose2(0.05, 1.0, 0.0);
  EXPECT_FALSE(ClosureAgrees(loop, 0.2, M_PI / 180));
  loop.estimated_submap_T_node = loop.measured_submap_T_node * Pose2(1.0, 0.0, 0.1);
  EXPECT_FALSE(ClosureAgrees(loop, 0.2, M_PI / 180));
}

TEST(SubmapGraphTest, DegenerateClosureDoesNotPullAlongItsWeakDirection) {
  const NodeId last{0, 29};
  const Pose2 truth(14.5, 0.0, 0.0);  // submap 0 sits at the origin
  // 1 m off along the run (x), right across it.
  const Pose2 measured(truth.x() + 1.0, truth.y(), truth.theta());

  const std::unique_ptr<SubmapGraph> isotropic = StraightRun(30);
  ASSERT_TRUE(isotropic->AddConstraint(Closure(last, measured, Eigen::Vector2d::Zero())));
  ASSERT_TRUE(isotropic->Solve(50).ok());
  ASSERT_EQ(1u, isotropic->LoopClosures().size());
  EXPECT_TRUE(isotropic->LoopClosures()[0].removed) << "a 1 m disagreement is inconsistent";

  const std::unique_ptr<SubmapGraph> degenerate = StraightRun(30);
  ASSERT_TRUE(degenerate->AddConstraint(Closure(last, measured, Eigen::Vector2d::UnitX())));
  ASSERT_TRUE(degenerate->Solve(50).ok());
  ASSERT_EQ(1u, degenerate->LoopClosures().size());
  EXPECT_FALSE(degenerate->LoopClosures()[0].removed) << "it measured nothing along x to disagree with";
  EXPECT_NEAR(truth.x(), degenerate->NodePose(last).x(), 0.05);

  // Off across the corridor: inconsistent whatever the weak direction.
  const std::unique_ptr<SubmapGraph> across = StraightRun(30);
  ASSERT_TRUE(across->AddConstraint(Closure(last, Pose2(truth.x(), 1.0, 0.0), Eigen::Vector2d::UnitX())));
  ASSERT_TRUE(across->Solve(50).ok());
  EXPECT_TRUE(across->LoopClosures()[0].removed);
}

// Along the weak direction the closure still pulls in proportion to its information.
TEST(SubmapGraphTest, WeakInformationFractionScalesThePull) {
  const NodeId last{0, 29};
  const Pose2 measured(14.5 + 0.2, 0.0, 0.0);
  double previous_pull = 0.0;
  for (double fraction : {0.0, 0.1, 1.0}) {
    const std::unique_ptr<SubmapGraph> graph = StraightRun(30);
    ConstraintCandidate closure = Closure(last, measured, Eigen::Vector2d::UnitX());
    closure.weak_information_fraction = fraction;
    closure.robust = false;
    ASSERT_TRUE(graph->AddConstraint(closure));
    ASSERT_TRUE(graph->Solve(50).ok());
    const double pull = graph->NodePose(last).x() - 14.5;
    EXPECT_GE(pull, previous_pull) << "fraction " << fraction;
    previous_pull = pull;
  }
  EXPECT_GT(previous_pull, 0.02);
}

// The robot's frame is its first node: revising that node's place in the first submap turns
// and shifts the rest of the robot around it, rigidly, and a solve keeps it so.
TEST(SubmapGraphTest, RevisingTheFirstNodeMovesTheRobotAroundIt) {
  const std::unique_ptr<SubmapGraph> graph = StraightRun(30);
  ASSERT_TRUE(graph->Solve(50).ok());
  Pose2 inserted;
  ASSERT_TRUE(graph->IntraSubmapPose({0, 0}, {0, 0}, &inserted));
  EXPECT_NEAR(0.0, inserted.translation().norm(), 1e-12);
  EXPECT_FALSE(graph->IntraSubmapPose({0, 0}, {0, 1}, &inserted)) << "node 0 never entered submap 1";
  const std::vector<StampedPose2> before = graph->Trajectory(0);
  const Pose2 local_before = graph->LocalToRobot(0);

  // The finished submap puts the first scan 0.5 degrees and 2 cm off where it was inserted.
  const Pose2 revised(0.01, -0.02, 0.5 * M_PI / 180);
  ASSERT_TRUE(graph->ReviseFirstNodeInFirstSubmap(0, revised));
  ASSERT_TRUE(graph->IntraSubmapPose({0, 0}, {0, 0}, &inserted));
  EXPECT_NEAR(0.0, (inserted.ToVector() - revised.ToVector()).norm(), 1e-12);
  // Everything but the first node moved by the one rigid motion that keeps the first node's
  // pose with the submap where the revised constraint puts it.
  const Pose2 moved = before[0].pose * revised.inverse();  // the first submap, was the identity
  for (const Pose2& p : {graph->NodePose({0, 0}), before[0].pose}) EXPECT_NEAR(0.0, p.translation().norm(), 1e-9);
  EXPECT_NEAR(0.0, (graph->SubmapPose({0, 0}).ToVector() - moved.ToVector()).norm(), 1e-9);
  for (int k = 1; k < 30; ++k) {
    const Pose2 expected = moved * before[k].pose;
    EXPECT_NEAR(0.0, (graph->NodePose({0, k}).ToVector() - expected.ToVector()).norm(), 1e-9) << "node " << k;
  }
  EXPECT_NEAR(0.0, (graph->LocalToRobot(0).ToVector() - (moved * local_before).ToVector()).norm(), 1e-9);
  // Every constraint holds as before: a solve leaves the poses where they are.
  ASSERT_TRUE(graph->Solve(50).ok());
  EXPECT_NEAR(0.0, graph->NodePose({0, 0}).translation().norm(), 1e-6);
  EXPECT_NEAR(0.0, graph->NodePose({0, 0}).theta(), 1e-7);
  EXPECT_NEAR(0.0, (graph->NodePose({0, 29}).ToVector() - (moved * before[29].pose).ToVector()).norm(), 1e-6);

  EXPECT_FALSE(graph->ReviseFirstNodeInFirstSubmap(1, revised)) << "an unknown robot";
  // Once a robot has an anchor (a teammate's constraint reached it), its frame stays.
  LocalResult first;
  first.inserted = true;
  first.new_submaps.push_back({0, Pose2::Identity()});
  first.insertions.push_back({0, Pose2::Identity()});
  graph->AddNode(1, first);
  ASSERT_TRUE(graph->SetAnchorEstimate(1, Pose2(1.0, 0.0, 0.0)));
  EXPECT_FALSE(graph->ReviseFirstNodeInFirstSubmap(1, revised));
  ASSERT_TRUE(graph->IntraSubmapPose({1, 0}, {1, 0}, &inserted));
  EXPECT_NEAR(0.0, inserted.ToVector().norm(), 1e-12);
}

// The graph keeps a node's matching points as indices into its points when they are points of
// them in order (the voxel filter's output), and as they are otherwise; either way
// NodeMatchingPoints gives back exactly what the LocalResult held, weights included.
// Node points are kept to the millimetre in 16 bits when every one is within 32.7 m of the
// robot (node 3: one point 40 m away, so its points are kept as they are). Asked for, every
// point the matching points were thinned from comes along (LocalSlamOptions::
// refine_on_all_points), but not for matching points with weights or not a subset.
TEST(SubmapGraphTest, NodeMatchingPointsAreTheLocalResultsToTheMillimetre) {
  SubmapGraph graph{SubmapGraphOptions()};
  std::vector<std::vector<Eigen::Vector2f>> given, given_all;
  std::vector<std::vector<float>> given_weights;
  for (int i = 0; i < 4; ++i) {
    LocalResult result;
    result.inserted = true;
    result.stamp_seconds = i;
    result.local_pose = Pose2(0.5 * i, 0.0, 0.0);
    if (i == 0) result.new_submaps.push_back({0, result.local_pose});
    result.insertions.push_back({0, result.local_pose});
    for (int k = 0; k < 50; ++k) {
      result.points.all.emplace_back(0.1234567f * k - 3.f, 1.f - 0.0314159f * k);
      result.points.labels.push_back(k % 7 == 0 && i == 1 ? PointLabel::kWall : PointLabel::kStructure);
    }
    if (i == 0) {  // every third point: a subset in order
      for (int k = 0; k < 50; k += 3) result.points.matching.push_back(result.points.all[k]);
    } else if (i == 1) {  // a subset, with weights
      for (int k = 1; k < 50; k += 4) {
        result.points.matching.push_back(result.points.all[k]);
        result.points.matching_weights.push_back(0.5f + 0.01f * k);
      }
    } else if (i == 2) {  // out of order and one point that is not in `all`: kept as it is
      result.points.matching = {result.points.all[9], result.points.all[2], Eigen::Vector2f(7.f, 7.f)};
    } else {  // a point beyond the 16-bit millimetres
      result.points.all.back() = Eigen::Vector2f(40.f, 0.123456f);
      result.points.matching = {result.points.all[0], result.points.all.back()};
    }
    given.push_back(result.points.matching);
    given_weights.push_back(result.points.matching_weights);
    given_all.push_back(result.points.all);
    graph.AddNode(0, std::move(result));
  }
  for (int i = 0; i < 4; ++i) {
    const SubmapGraph::MatchingPoints matching = graph.NodeMatchingPoints({0, i});
    EXPECT_TRUE(matching.all.empty()) << "node " << i << ": not asked for";
    const SubmapGraph::MatchingPoints with_all = graph.NodeMatchingPoints({0, i}, true);
    EXPECT_EQ(matching.points, with_all.points) << "node " << i;
    EXPECT_EQ(matching.weights, with_all.weights) << "node " << i;
    if (i == 1 || i == 2) {
      EXPECT_TRUE(with_all.all.empty()) << "node " << i << ": weights, or not a subset";
    } else {
      ASSERT_EQ(given_all[i].size(), with_all.all.size()) << "node " << i;
      for (size_t k = 0; k < given_all[i].size(); ++k) {
        EXPECT_LE((given_all[i][k] - with_all.all[k]).cwiseAbs().maxCoeff(), 0.0005f + 1e-6f)
            << "node " << i << " point " << k;
      }
    }
    EXPECT_EQ(given_weights[i], matching.weights) << "node " << i;
    ASSERT_EQ(given[i].size(), matching.points.size()) << "node " << i;
    if (i >= 2) {
      EXPECT_EQ(given[i], matching.points) << "node " << i << ": kept as given";
      continue;
    }
    for (size_t k = 0; k < given[i].size(); ++k) {
      EXPECT_LE((given[i][k] - matching.points[k]).cwiseAbs().maxCoeff(), 0.0005f + 1e-6f)
          << "node " << i << " point " << k;
    }
  }
}

// The packed node points (each the difference from the previous one in two bytes, or in full
// after an escape byte) decode to the millimetre values, also across the limits of the short
// form (±127 mm, ±128 mm), for jumps of metres either way and at the 16-bit limits.
TEST(SubmapGraphTest, PackedNodePointsDecodeToTheirMillimetres) {
  SubmapGraph graph{SubmapGraphOptions()};
  const std::vector<Eigen::Vector2i> mm = {{0, 0},        {127, -127},    {0, 0},        {128, 0},      {0, -128},
                                           {-127, 127},   {-254, 0},      {20000, -5},   {-20000, 15},  {32766, -32766},
                                           {-32766, 32766}, {-32766, 32766}, {5, 6},      {-1, -1}};
  LocalResult result;
  result.inserted = true;
  result.new_submaps.push_back({0, Pose2()});
  result.insertions.push_back({0, Pose2()});
  for (const Eigen::Vector2i& p : mm) {
    // A float a little off the millimetre: it is rounded to it.
    result.points.all.emplace_back(p.x() / 1000.f + 0.0002f, p.y() / 1000.f - 0.0002f);
    result.points.labels.push_back(PointLabel::kStructure);
  }
  result.points.matching = result.points.all;
  graph.AddNode(0, std::move(result));
  const SubmapGraph::MatchingPoints matching = graph.NodeMatchingPoints({0, 0});
  ASSERT_EQ(mm.size(), matching.points.size());
  for (size_t k = 0; k < mm.size(); ++k) {
    EXPECT_EQ(Eigen::Vector2f(mm[k].x() / 1000.f, mm[k].y() / 1000.f), matching.points[k]) << "point " << k;
  }
}

// The rendered map leaves out the noise tail behind a wall (SubmapGraphOptions::
// map_min_hit_share; OccupancyGrid::DropWeakOccupiedCells): ten nodes see a wall 2 m ahead,
// one of them with a stray point 6 cm behind it, in the next cell. By default the stray cell
// is unknown in the map and the wall is whole; with the share at 0 it is occupied.
TEST(SubmapGraphTest, RenderedMapLeavesOutTheNoiseTailBehindAWall) {
  auto render = [](double share) {
    SubmapGraphOptions options;
    options.map_min_hit_share = share;
    SubmapGraph graph{options};
    for (int i = 0; i < 10; ++i) {
      LocalResult result;
      result.inserted = true;
      result.stamp_seconds = i;
      result.local_pose = Pose2(0.0, 0.05 * i, 0.0);
      if (i == 0) result.new_submaps.push_back({0, Pose2::Identity()});
      result.insertions.push_back({0, result.local_pose});
      for (int k = -20; k <= 20; ++k) result.points.all.emplace_back(2.02f, 0.02f * k);  // the wall at x = 2.02 m
      if (i == 4) result.points.all.emplace_back(2.08f, 0.01f);                         // the stray point
      result.points.labels.assign(result.points.all.size(), PointLabel::kStructure);
      graph.AddNode(0, std::move(result));
    }
    return graph.RenderMap(0, OccupancyGridOptions());
  };
  // World positions: node 4 is at y = 0.2, so its stray point lies at (2.08, 0.21).
  const std::unique_ptr<OccupancyGrid> kept_all = render(0.0);
  const std::unique_ptr<OccupancyGrid> cleaned = render(SubmapGraphOptions().map_min_hit_share);
  EXPECT_EQ(CellState::kOccupied, kept_all->StateAt({2.08, 0.21}));
  EXPECT_EQ(CellState::kUnknown, cleaned->StateAt({2.08, 0.21}));
  for (double y = -0.35; y <= 0.55; y += 0.05) {
    EXPECT_EQ(CellState::kOccupied, cleaned->StateAt({2.02, y})) << "wall at y = " << y;
  }
  EXPECT_EQ(CellState::kFree, cleaned->StateAt({1.0, 0.2}));
}

// Four scans from the origin of a wall 3 m ahead and a 10 cm box: the first sees the box's
// front face at x = first_box_x, the other three its top at x = 2.2 m.
void AddScansOfAWallAndABox(float first_box_x, SubmapGraph* graph) {
  for (int i = 0; i < 4; ++i) {
    LocalResult result;
    result.inserted = true;
    result.stamp_seconds = i;
    result.local_pose = Pose2::Identity();
    if (i == 0) result.new_submaps.push_back({0, Pose2::Identity()});
    result.insertions.push_back({0, result.local_pose});
    for (int k = -20; k <= 20; ++k) result.points.all.emplace_back(3.02f, 0.02f * k);  // the wall
    result.points.labels.assign(result.points.all.size(), PointLabel::kStructure);
    const float x = i == 0 ? first_box_x : 2.22f;
    for (int k = -2; k <= 2; ++k) result.points.floor_obstacles.emplace_back(x, 0.02f * k);
    graph->AddNode(0, std::move(result));
  }
}

// Floor obstacles are drawn from their hits alone (paper §III-E): a beam that ends on a box's
// top passed over its front face higher than the box, so it does not clear it. Four scans from
// the origin see a wall 3 m ahead; the first also a 10 cm box's front face at x = 2.0 m, the
// other three the box's top behind it, at x = 2.2 m. The front face stays a floor obstacle
// (rays cast from the later scans cleared it), and in the planner layer too, where the
// structure's beams saw its cells free.
TEST(SubmapGraphTest, FloorObstaclesKeepTheFaceBeamsToTheTopPassedOver) {
  SubmapGraph graph{SubmapGraphOptions()};
  AddScansOfAWallAndABox(2.02f, &graph);
  const std::unique_ptr<OccupancyGrid> obstacles =
      graph.RenderMap(0, OccupancyGridOptions(), SubmapGraph::Layer::kFloorObstacles);
  const std::unique_ptr<OccupancyGrid> planner = graph.RenderMap(0, OccupancyGridOptions(), SubmapGraph::Layer::kPlanner);
  const std::unique_ptr<OccupancyGrid> structure = graph.RenderMap(0, OccupancyGridOptions());
  for (const double x : {2.02, 2.22}) {
    EXPECT_EQ(CellState::kOccupied, obstacles->StateAt({x, 0.0})) << "x = " << x;
    EXPECT_EQ(CellState::kOccupied, planner->StateAt({x, 0.0})) << "x = " << x;
    EXPECT_EQ(CellState::kFree, structure->StateAt({x, 0.0})) << "x = " << x;
  }
  EXPECT_EQ(CellState::kOccupied, planner->StateAt({3.02, 0.0}));
  EXPECT_NE(CellState::kOccupied, obstacles->StateAt({1.0, 0.0}));
  EXPECT_NE(CellState::kOccupied, planner->StateAt({1.0, 0.0}));
}

// A team renders each robot's map in the common frame (RenderMap's frame_T_robot): the scans
// are placed there, so the same cells come out where the frame puts them, without resampling a
// rendered grid (which moved cells of a map turned by 150 degrees up to a cell). A wall and a
// box rendered in a frame where the robot's sits at (1, -2) turned by 90 degrees: every
// layer's cells where the frame puts the robot's.
TEST(SubmapGraphTest, RenderedInAnotherFrameTheCellsAreWhereTheFramePutsThem) {
  SubmapGraph graph{SubmapGraphOptions()};
  AddScansOfAWallAndABox(2.22f, &graph);
  const Pose2 frame_T_robot(1.0, -2.0, M_PI / 2);
  for (const SubmapGraph::Layer layer : {SubmapGraph::Layer::kStructure, SubmapGraph::Layer::kFloorObstacles,
                                         SubmapGraph::Layer::kPlanner}) {
    const std::unique_ptr<OccupancyGrid> own = graph.RenderMap(0, OccupancyGridOptions(), layer);
    const std::unique_ptr<OccupancyGrid> turned = graph.RenderMap(0, OccupancyGridOptions(), layer, {}, frame_T_robot);
    int occupied = 0;
    for (double x = 0.52; x < 3.2; x += 0.05) {
      for (double y = -0.48; y < 0.5; y += 0.05) {
        const Eigen::Vector2d p(x, y);
        occupied += own->StateAt(p) == CellState::kOccupied ? 1 : 0;
        EXPECT_EQ(own->StateAt(p) == CellState::kOccupied, turned->StateAt(frame_T_robot * p) == CellState::kOccupied)
            << "layer " << static_cast<int>(layer) << " at (" << x << ", " << y << ")";
      }
    }
    EXPECT_GE(occupied, 2) << "layer " << static_cast<int>(layer);  // the obstacle: two cells
  }
  const std::unique_ptr<OccupancyGrid> turned = graph.RenderMap(0, OccupancyGridOptions(), SubmapGraph::Layer::kStructure,
                                                                {}, frame_T_robot);
  EXPECT_EQ(CellState::kOccupied, turned->StateAt(frame_T_robot * Eigen::Vector2d(3.02, 0.0)));
  EXPECT_EQ(CellState::kFree, turned->StateAt(frame_T_robot * Eigen::Vector2d(1.5, 0.0)));
}

// Issue #15, revisits: the share of a finished submap's occupied cells that other finished
// submaps hold too (within the likelihood field's sigma, 0.1 m), at the graph's poses.
std::shared_ptr<const LaserMap> FrozenWalls(const std::vector<std::pair<Eigen::Vector2f, Eigen::Vector2f>>& walls) {
  auto map = std::make_shared<LaserMap>(OccupancyGridOptions(), LikelihoodFieldOptions());
  std::vector<Eigen::Vector2f> points;
  for (const auto& [a, b] : walls) {
    const int steps = static_cast<int>(std::ceil((b - a).norm() / 0.02f));
    for (int k = 0; k <= steps; ++k) points.push_back(a + (b - a) * (static_cast<float>(k) / steps));
  }
  for (int repeat = 0; repeat < 3; ++repeat) map->InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), points);
  map->Freeze();
  return map;
}

TEST(SubmapGraphTest, CoveredShareCountsTheStructureOtherSubmapsHold) {
  using Wall = std::pair<Eigen::Vector2f, Eigen::Vector2f>;
  const Wall east{{2.0f, -1.0f}, {2.0f, 1.0f}};
  const Wall north{{-1.0f, 2.0f}, {1.0f, 2.0f}};
  const Wall east_shifted{{2.3f, -1.0f}, {2.3f, 1.0f}};  // 0.3 m off: beyond the sigma
  const std::vector<std::shared_ptr<const LaserMap>> maps = {FrozenWalls({east}), FrozenWalls({east}),
                                                             FrozenWalls({east, north}), FrozenWalls({east_shifted})};
  SubmapGraph graph{SubmapGraphOptions()};
  for (int i = 0; i < static_cast<int>(maps.size()); ++i) {
    // Each a submap of one node at the origin, finished at once.
    LocalResult result;
    result.inserted = true;
    result.stamp_seconds = i;
    result.new_submaps.push_back({i, Pose2::Identity()});
    result.insertions.push_back({i, Pose2::Identity()});
    result.finished = LocalResult::FinishedSubmap{i, maps[i]};
    graph.AddNode(0, std::move(result));
  }
  EXPECT_EQ(2, graph.SubmapFirstNode({0, 2}));
  EXPECT_EQ(2, graph.SubmapLastNode({0, 2}));
  const SubmapId first{0, 0};
  EXPECT_DOUBLE_EQ(1.0, graph.CoveredShare({0, 1}, {first}, 1));
  // The east wall and the north wall are the same length: about half is covered.
  const double half = graph.CoveredShare({0, 2}, {first}, 1);
  EXPECT_GT(half, 0.4);
  EXPECT_LT(half, 0.6);
  EXPECT_NEAR(half, graph.CoveredShare({0, 2}, {first}, 4), 0.05);
  EXPECT_DOUBLE_EQ(0.0, graph.CoveredShare({0, 3}, {first}, 1));
  // Itself does not count; an evicted submap holds nothing, and has no share.
  EXPECT_DOUBLE_EQ(0.0, graph.CoveredShare({0, 3}, {{0, 3}}, 1));
  ASSERT_TRUE(graph.EvictSubmapMap(first, SubmapGraph::EvictionReason::kRevisited));
  EXPECT_DOUBLE_EQ(0.0, graph.CoveredShare({0, 1}, {first}, 1));
  EXPECT_DOUBLE_EQ(-1.0, graph.CoveredShare(first, {{0, 1}}, 1));
  EXPECT_EQ(1, graph.stats().submaps_retired);
  EXPECT_EQ(0, graph.stats().submaps_evicted);
  EXPECT_GT(graph.stats().retired_bytes, 0u);
}

// A straight run of 60 scans, 0.5 m apart, each with three points; a submap starts every 10
// scans and takes 20 (finished then, with a small frozen map), as the front end does. Scan i
// faces i * yaw_per_scan (0: along the run; else the scans turn as they go, a robot crabbing).
std::unique_ptr<SubmapGraph> FinishedRun(const SubmapGraphOptions& options = SubmapGraphOptions(),
                                         double yaw_per_scan = 0.0) {
  auto graph = std::make_unique<SubmapGraph>(options);
  const std::shared_ptr<const LaserMap> map = FrozenWalls({{{2.0f, -1.0f}, {2.0f, 1.0f}}});
  std::vector<Pose2> submap_origins;
  for (int i = 0; i < 60; ++i) {
    LocalResult result;
    result.inserted = true;
    result.stamp_seconds = i;
    result.local_pose = Pose2(0.5 * i, 0.0, yaw_per_scan * i);
    result.points.all = {{1.0f, 0.0f}, {1.0f, 0.5f}, {1.0f, -0.5f}};
    result.points.matching = result.points.all;
    if (i % 10 == 0) {
      submap_origins.push_back(result.local_pose);
      result.new_submaps.push_back({i / 10, result.local_pose});
    }
    for (int submap = std::max(0, i / 10 - 1); submap <= i / 10; ++submap) {
      result.insertions.push_back({submap, submap_origins[submap].inverse() * result.local_pose});
    }
    if (i >= 19 && i % 10 == 9) result.finished = LocalResult::FinishedSubmap{i / 10 - 1, map};
    graph->AddNode(0, std::move(result));
  }
  return graph;
}

TEST(SubmapGraphTest, RevisitsRideOnTheirSubmapWithSummariesInPlaceOfTheirConstraints) {
  std::unique_ptr<SubmapGraph> graph = FinishedRun();
  ASSERT_TRUE(graph->SubmapFinished({0, 4}));
  ASSERT_FALSE(graph->SubmapFinished({0, 5}));
  // Nodes 30-49 revisit submap 0 (and 40-44 submap 1 too): closures at the graph's estimate.
  int closures = 0;
  for (int i = 30; i < 50; ++i) {
    for (int target : {0, 1}) {
      if (target == 1 && (i < 40 || i > 44)) continue;
      ConstraintCandidate closure;
      closure.submap = {0, target};
      closure.node = {0, i};
      closure.submap_T_node = graph->SubmapPose(closure.submap).inverse() * graph->NodePose(closure.node);
      closure.score = 0.8;
      ASSERT_TRUE(graph->AddConstraint(closure));
      ++closures;
    }
  }
  ASSERT_TRUE(graph->Solve(20).ok());
  const std::vector<StampedPose2> before = graph->Trajectory(0);
  // Nothing retired, nothing attached.
  EXPECT_EQ(0, graph->AttachRevisits(0));
  // Submaps 3 and 4 retired: nodes 40-49 entered both and leave the problem; 30-39 entered 2
  // (kept) and 50-59 entered 5 (active): they stay.
  ASSERT_TRUE(graph->EvictSubmapMap({0, 3}, SubmapGraph::EvictionReason::kRevisited));
  ASSERT_TRUE(graph->EvictSubmapMap({0, 4}, SubmapGraph::EvictionReason::kRevisited));
  EXPECT_EQ(10, graph->AttachRevisits(0));
  EXPECT_EQ(10, graph->stats().nodes_attached);
  EXPECT_EQ(15, graph->stats().closures_released);
  EXPECT_EQ(3, graph->stats().revisit_summaries);  // to submaps 0 and 1, and the chain 3 -> 4
  for (int i = 0; i < 60; ++i) {
    const bool attached = i >= 40 && i < 50;
    EXPECT_EQ(attached, graph->NodeAttached({0, i})) << "node " << i;
    EXPECT_EQ(attached, graph->NodeMatchingPoints({0, i}).points.empty()) << "node " << i;
  }
  // The summaries are no closures of a scan: the report lists the 20 closures of nodes 30-39.
  EXPECT_EQ(static_cast<size_t>(closures - 15), graph->LoopClosures().size());
  // An attached node is no variable: no constraint reaches it.
  ConstraintCandidate late;
  late.submap = {0, 0};
  late.node = {0, 41};
  EXPECT_FALSE(graph->AddConstraint(late));
  // Where they were, and after another solve still (the summaries agree with the graph).
  std::vector<StampedPose2> after = graph->Trajectory(0);
  ASSERT_EQ(before.size(), after.size());
  for (size_t k = 0; k < before.size(); ++k) {
    EXPECT_NEAR(0.0, (before[k].pose.translation() - after[k].pose.translation()).norm(), 1e-9) << k;
  }
  ASSERT_TRUE(graph->Solve(20).ok());
  after = graph->Trajectory(0);
  for (size_t k = 0; k < before.size(); ++k) {
    EXPECT_NEAR(0.0, (before[k].pose.translation() - after[k].pose.translation()).norm(), 1e-6) << k;
    EXPECT_NEAR(0.0, WrapAngle(before[k].pose.theta() - after[k].pose.theta()), 1e-6) << k;
  }
  // In the exported graph (the six submaps first, then the nodes): submap 3 hangs on submaps 0
  // and 1 through the summaries and on submap 4 through the chain, 5 m ahead.
  const PoseGraph2d exported = graph->ExportGraph(0);
  auto edge = [&](int from, int to) {
    return std::find_if(exported.edges.begin(), exported.edges.end(),
                        [&](const PoseGraph2dEdge& e) { return e.id_from == from && e.id_to == to; });
  };
  ASSERT_NE(exported.edges.end(), edge(3, 4));
  EXPECT_EQ(EdgeKind::kSequential, edge(3, 4)->kind);
  EXPECT_NEAR(5.0, edge(3, 4)->from_T_to_measured.x(), 1e-6);
  // With the information the solve uses: the chain of 10 nodes is far stiffer than one of them.
  const double intra_sigma = SubmapGraphOptions().intra_translation_sigma_meters;
  EXPECT_GT(edge(3, 4)->information(0, 0), 2.0 / (intra_sigma * intra_sigma));
  for (const int target : {0, 1}) {
    ASSERT_NE(exported.edges.end(), edge(target, 3)) << target;
    EXPECT_EQ(EdgeKind::kLoopClosure, edge(target, 3)->kind);
    EXPECT_NEAR(15.0 - 5.0 * target, edge(target, 3)->from_T_to_measured.x(), 1e-6);
  }
  // Decided once: a second call changes nothing.
  EXPECT_EQ(0, graph->AttachRevisits(0));
  EXPECT_EQ(10, graph->stats().nodes_attached);
}

// A summary of degenerate closures stays weak along their weak direction whatever the heading
// of their scans in the submaps: their covariances are in the scans' frames, the summary's in
// the submap it starts from (wheeled_corridor: closures 0.5 m off along a corridor, their scans
// driving 49° to it, stretched the corridor by 0.2 m while the summaries took the covariances
// in the wrong frames).
TEST(SubmapGraphTest, DegenerateClosuresSummariesStayWeakAlongTheirWeakDirection) {
  // The scans turn 0.02 rad each: scan 45 faces 0.9 rad (52°) in submap 0, submap 3 starts at 0.6.
  std::unique_ptr<SubmapGraph> graph = FinishedRun(SubmapGraphOptions(), 0.02);
  // Nodes 40-49 close with submap 0, flat along its x axis and 0.5 m off along it.
  const Eigen::Vector2d weak_in_submap(1.0, 0.0);
  for (int i = 40; i < 50; ++i) {
    ConstraintCandidate closure;
    closure.submap = {0, 0};
    closure.node = {0, i};
    const Pose2 estimated = graph->SubmapPose(closure.submap).inverse() * graph->NodePose(closure.node);
    closure.submap_T_node = Pose2(estimated.x() + 0.5, estimated.y(), estimated.theta());
    closure.score = 0.8;
    closure.weak_direction = weak_in_submap;
    closure.weak_information_fraction = 0.0;  // nothing measured along it: the weak sigma
    ASSERT_TRUE(graph->AddConstraint(closure));
  }
  ASSERT_TRUE(graph->Solve(20).ok());
  const std::vector<StampedPose2> before = graph->Trajectory(0);
  ASSERT_TRUE(graph->EvictSubmapMap({0, 3}, SubmapGraph::EvictionReason::kRevisited));
  ASSERT_TRUE(graph->EvictSubmapMap({0, 4}, SubmapGraph::EvictionReason::kRevisited));
  ASSERT_EQ(10, graph->AttachRevisits(0));
  // The summary 0 -> 3: its residual is in submap 3's frame, where the weak direction is
  // submap 0's x axis turned back by submap 3's heading in submap 0.
  const PoseGraph2d exported = graph->ExportGraph(0);
  const auto summary = std::find_if(exported.edges.begin(), exported.edges.end(),
                                    [](const PoseGraph2dEdge& e) { return e.id_from == 0 && e.id_to == 3; });
  ASSERT_NE(exported.edges.end(), summary);
  const Eigen::Vector2d weak_in_3 = summary->from_T_to_measured.rotation().transpose() * weak_in_submap;
  const Eigen::Vector2d across_in_3(-weak_in_3.y(), weak_in_3.x());
  const Eigen::Matrix2d translation = summary->information.topLeftCorner<2, 2>();
  const double along_information = weak_in_3.dot(translation * weak_in_3);
  const double across_information = across_in_3.dot(translation * across_in_3);
  EXPECT_LT(along_information, 1e-3 * across_information)
      << "along " << along_information << ", across " << across_information;
  // So another solve leaves the run where it was: the 0.5 m along the weak direction pulls nothing.
  ASSERT_TRUE(graph->Solve(20).ok());
  const std::vector<StampedPose2> after = graph->Trajectory(0);
  ASSERT_EQ(before.size(), after.size());
  for (size_t k = 0; k < before.size(); ++k) {
    EXPECT_NEAR(0.0, (before[k].pose.translation() - after[k].pose.translation()).norm(), 0.01) << k;
  }
}

// Issue #15: an attached scan keeps its points for the rendered maps once per so much travel
// in its retired submap; the others keep their pose.
TEST(SubmapGraphTest, AttachedScansKeepTheirPointsOncePerSoMuchTravel) {
  SubmapGraphOptions thinning;
  thinning.revisit_points_min_travel_meters = 1.2;  // nodes 0.5 m apart: every third keeps them
  thinning.revisit_points_min_turn_radians = 0.0;   // (straight: the turn never counts)
  SubmapGraphOptions keep_all = thinning;
  keep_all.revisit_points_min_travel_meters = 0.0;
  std::unique_ptr<SubmapGraph> thinned = FinishedRun(thinning);
  std::unique_ptr<SubmapGraph> full = FinishedRun(keep_all);
  for (SubmapGraph* graph : {thinned.get(), full.get()}) {
    ASSERT_TRUE(graph->Solve(20).ok());
    ASSERT_TRUE(graph->EvictSubmapMap({0, 3}, SubmapGraph::EvictionReason::kRevisited));
    ASSERT_TRUE(graph->EvictSubmapMap({0, 4}, SubmapGraph::EvictionReason::kRevisited));
    ASSERT_EQ(10, graph->AttachRevisits(0));  // nodes 40-49, 0.5 m apart in submap 3
  }
  EXPECT_EQ(0, full->stats().nodes_points_released);
  EXPECT_EQ(0u, full->stats().points_released_bytes);
  // 40 keeps them, then 43 (1.5 m on), 46 and 49: six of the ten released.
  EXPECT_EQ(6, thinned->stats().nodes_points_released);
  EXPECT_GE(thinned->stats().points_released_bytes, 6 * 3 * 2u);  // at least 2 bytes a point
  // Every scan keeps its place in the trajectory.
  EXPECT_EQ(full->Trajectory(0).size(), thinned->Trajectory(0).size());
  // The rendered map: every cell the thinned graph marks occupied, the full one does too; the
  // kept scans' hits are there, the released ones' are not.
  const OccupancyGridOptions grid_options;
  const std::unique_ptr<OccupancyGrid> thin_map = thinned->RenderMap(0, grid_options);
  const std::unique_ptr<OccupancyGrid> full_map = full->RenderMap(0, grid_options);
  auto occupied_at = [](const OccupancyGrid& grid, const Eigen::Vector2d& world) {
    const CellIndex c = grid.geometry().WorldToCell(world);
    return grid.geometry().Contains(c) && grid.IsOccupied(grid.geometry().LinearIndex(c));
  };
  int thin_occupied = 0, full_occupied = 0;
  for (int i = 0; i < full_map->geometry().num_cells(); ++i) full_occupied += full_map->IsOccupied(i);
  for (int i = 0; i < thin_map->geometry().num_cells(); ++i) {
    if (!thin_map->IsOccupied(i)) continue;
    ++thin_occupied;
    EXPECT_TRUE(occupied_at(*full_map, thin_map->geometry().CellCenter(thin_map->geometry().FromLinearIndex(i))));
  }
  EXPECT_LT(thin_occupied, full_occupied);
  for (const int node : {43, 46}) {  // kept: its points (1, +-0.5) and (1, 0) ahead of it
    const Eigen::Vector2d ahead = thinned->NodePose({0, node}) * Eigen::Vector2d(1.0, 0.5);
    EXPECT_TRUE(occupied_at(*thin_map, ahead)) << node;
  }
  for (const int node : {44, 45}) {  // released
    const Eigen::Vector2d ahead = thinned->NodePose({0, node}) * Eigen::Vector2d(1.0, 0.5);
    EXPECT_FALSE(occupied_at(*thin_map, ahead)) << node;
    EXPECT_TRUE(occupied_at(*full_map, ahead)) << node;
  }
}

}  // namespace
}  // namespace hetslam
