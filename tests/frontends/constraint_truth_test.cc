// Constraints scored against the truth with the trajectories taken out: each submap placed by
// its own nodes' truth, each node at its truth.
#include "frontends/constraint_truth.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A robot whose front end saw `local[i]` (its own frame) where it truly was at truth[i]; a
// submap starts every 10 scans and takes 20 (each node in two submaps, as the front end does).
void AddRun(int robot, const std::vector<Pose2>& local, SubmapGraph* graph) {
  std::vector<Pose2> origins;
  for (size_t i = 0; i < local.size(); ++i) {
    LocalResult result;
    result.inserted = true;
    result.stamp_seconds = static_cast<double>(i);
    result.local_pose = local[i];
    const int index = static_cast<int>(i);
    if (index % 10 == 0) {
      origins.push_back(local[i]);
      result.new_submaps.push_back({index / 10, local[i]});
    }
    for (int submap = std::max(0, index / 10 - 1); submap <= index / 10; ++submap) {
      result.insertions.push_back({submap, origins[submap].inverse() * local[i]});
    }
    graph->AddNode(robot, std::move(result));
  }
}

std::vector<StampedPose2> Stamped(const std::vector<Pose2>& poses) {
  std::vector<StampedPose2> stamped;
  for (size_t i = 0; i < poses.size(); ++i) stamped.push_back({static_cast<double>(i), poses[i]});
  return stamped;
}

ConstraintCandidate Constraint(const SubmapId& submap, const NodeId& node, const Pose2& submap_T_node,
                               const Eigen::Vector2d& weak = Eigen::Vector2d::Zero()) {
  ConstraintCandidate c;
  c.submap = submap;
  c.node = node;
  c.submap_T_node = submap_T_node;
  c.score = 0.8;
  c.weak_direction = weak;
  c.weak_information_fraction = weak.squaredNorm() > 0 ? 0.01 : 1.0;
  return c;
}

TEST(ConstraintTruthTest, AMatchAtTheTruthHasNoErrorWhereverTheRobotsFramesSit) {
  // Robot 0 drives along x in the world; its own frame is the world turned by 30° and moved.
  // Robot 1 drives along y; its frame is its first pose.
  std::vector<Pose2> truth0, local0, truth1, local1;
  const Pose2 frame0_T_world(Eigen::Vector2d(1.0, -2.0), 30 * kDeg);
  for (int i = 0; i < 30; ++i) {
    truth0.push_back(Pose2(0.5 * i, 0.0, 0.0));
    local0.push_back(frame0_T_world * truth0.back());
    truth1.push_back(Pose2(3.0, -4.0 + 0.4 * i, M_PI / 2));
    local1.push_back(truth1.front().inverse() * truth1.back());
  }
  SubmapGraph graph{SubmapGraphOptions()};
  AddRun(0, local0, &graph);
  AddRun(1, local1, &graph);
  // Robot 1's node 12 in robot 0's submap 1 (origin: robot 0's node 10), and robot 0's node 25 in
  // its own submap 0: where the truth puts them, and once 5 cm and 1° off.
  const Pose2 true_1_12 = truth0[10].inverse() * truth1[12];
  const Pose2 true_0_25 = truth0[0].inverse() * truth0[25];
  ASSERT_TRUE(graph.AddConstraint(Constraint({0, 1}, {1, 12}, true_1_12)));
  ASSERT_TRUE(graph.AddConstraint(Constraint({0, 0}, {0, 25}, true_0_25 * Pose2(0.03, -0.04, 1 * kDeg))));
  const std::vector<ConstraintTruthError> errors =
      ConstraintTruthErrors(graph, {{0, Stamped(truth0)}, {1, Stamped(truth1)}});
  ASSERT_EQ(2u, errors.size());
  const ConstraintTruthError* inter = errors[0].kind == EdgeKind::kInterRobot ? &errors[0] : &errors[1];
  const ConstraintTruthError* loop = inter == &errors[0] ? &errors[1] : &errors[0];
  EXPECT_EQ(EdgeKind::kInterRobot, inter->kind);
  EXPECT_EQ(1, inter->node.robot);
  EXPECT_EQ(12, inter->node.index);
  EXPECT_NEAR(0.0, inter->error.translation().norm(), 1e-9);
  EXPECT_NEAR(0.0, inter->error.theta(), 1e-9);
  EXPECT_EQ(20, inter->submap_nodes_aligned);
  EXPECT_NEAR(0.0, inter->submap_fit_rmse_meters, 1e-9);
  EXPECT_EQ(EdgeKind::kLoopClosure, loop->kind);
  EXPECT_NEAR(0.03, loop->error.x(), 1e-9);
  EXPECT_NEAR(-0.04, loop->error.y(), 1e-9);
  EXPECT_NEAR(1 * kDeg, loop->error.theta(), 1e-9);
  EXPECT_NEAR(0.05, loop->claimed_translation_meters, 1e-9);
}

// The trajectory's drift between submaps is taken out; what a submap's map got wrong inside
// itself is not (it is what a match in it inherits).
TEST(ConstraintTruthTest, DriftBetweenSubmapsIsTakenOutInsideOneIsNot) {
  // The front end turns 0.1° a scan: by scan 25 the robot's own frame is 2.5° off.
  std::vector<Pose2> truth, local;
  Pose2 pose;
  for (int i = 0; i < 30; ++i) {
    truth.push_back(Pose2(0.5 * i, 0.0, 0.0));
    if (i > 0) pose = pose * Pose2(0.5, 0.0, 0.1 * kDeg);
    local.push_back(pose);
  }
  SubmapGraph graph{SubmapGraphOptions()};
  AddRun(0, local, &graph);
  // Node 25 in submap 2 (nodes 20-29), measured at its truth there: the drift before node 20 does
  // not count; within the submap's ten scans it does, a little.
  const Pose2 true_in_2 = truth[20].inverse() * truth[25];
  ASSERT_TRUE(graph.AddConstraint(Constraint({0, 2}, {0, 25}, true_in_2)));
  const std::vector<ConstraintTruthError> errors = ConstraintTruthErrors(graph, {{0, Stamped(truth)}});
  ASSERT_EQ(1u, errors.size());
  EXPECT_LT(std::abs(errors[0].error.theta()), 0.6 * kDeg) << "not the 2.5 degrees of drift since the start";
  EXPECT_GT(errors[0].submap_fit_rmse_meters, 0.0) << "the submap is bent inside itself";
  EXPECT_LT(errors[0].error.translation().norm(), 0.02);
}

// A humanoid turning on the spot: its submap's positions cannot fix a rotation, its headings do.
TEST(ConstraintTruthTest, ASubmapOfATurnOnTheSpotIsPlacedByItsHeadings) {
  std::vector<Pose2> truth, local;
  const Pose2 frame_T_world(Eigen::Vector2d(-1.0, 0.5), -20 * kDeg);
  for (int i = 0; i < 20; ++i) {
    truth.push_back(Pose2(2.0, 2.0, 3 * kDeg * i));
    local.push_back(frame_T_world * truth.back());
  }
  SubmapGraph graph{SubmapGraphOptions()};
  AddRun(0, local, &graph);
  ASSERT_TRUE(graph.AddConstraint(Constraint({0, 0}, {0, 15}, truth[0].inverse() * truth[15])));
  const std::vector<ConstraintTruthError> errors = ConstraintTruthErrors(graph, {{0, Stamped(truth)}});
  ASSERT_EQ(1u, errors.size());
  EXPECT_NEAR(0.0, errors[0].error.theta(), 1e-9);
  EXPECT_NEAR(0.0, errors[0].error.translation().norm(), 1e-9);
}

// A degenerate constraint claims nothing along its weak direction.
TEST(ConstraintTruthTest, ADegenerateConstraintIsScoredAcrossItsWeakDirection) {
  std::vector<Pose2> truth;
  for (int i = 0; i < 30; ++i) truth.push_back(Pose2(0.5 * i, 0.0, 0.0));
  SubmapGraph graph{SubmapGraphOptions()};
  AddRun(0, truth, &graph);
  // 0.6 m off along the corridor (x), 2 cm across it.
  const Pose2 measured = Pose2(12.5 + 0.6, 0.02, 0.0);
  ASSERT_TRUE(graph.AddConstraint(Constraint({0, 0}, {0, 25}, measured, Eigen::Vector2d::UnitX())));
  const std::vector<ConstraintTruthError> errors = ConstraintTruthErrors(graph, {{0, Stamped(truth)}});
  ASSERT_EQ(1u, errors.size());
  EXPECT_NEAR(0.6, errors[0].error.x(), 1e-9);
  EXPECT_NEAR(0.02, errors[0].claimed_translation_meters, 1e-9);
  const ConstraintTruthSummary summary = SummarizeConstraintTruth(errors);
  EXPECT_EQ(1, summary.count);
  EXPECT_NEAR(0.02, summary.max_translation_meters, 1e-9);
}

// Nodes and submaps without a truth pose near their stamps are left out, not guessed.
TEST(ConstraintTruthTest, ConstraintsWithoutTruthAreLeftOut) {
  std::vector<Pose2> truth;
  for (int i = 0; i < 30; ++i) truth.push_back(Pose2(0.5 * i, 0.0, 0.0));
  SubmapGraph graph{SubmapGraphOptions()};
  AddRun(0, truth, &graph);
  ASSERT_TRUE(graph.AddConstraint(Constraint({0, 0}, {0, 25}, Pose2(12.5, 0.0, 0.0))));
  std::vector<StampedPose2> late = Stamped(truth);
  for (StampedPose2& p : late) p.stamp_seconds += 0.5;  // no truth within 1 ms of any node
  EXPECT_TRUE(ConstraintTruthErrors(graph, {{0, late}}).empty());
  EXPECT_TRUE(ConstraintTruthErrors(graph, {{1, Stamped(truth)}}).empty()) << "another robot's truth";
  EXPECT_EQ(1u, ConstraintTruthErrors(graph, {{0, late}}, 0.6).size());
}

TEST(ConstraintTruthTest, SummaryHasTheMedianLargestAndSignedMean) {
  std::vector<ConstraintTruthError> errors(3);
  errors[0].error = Pose2(0.01, 0.0, 0.1 * kDeg);
  errors[1].error = Pose2(0.0, 0.03, 0.3 * kDeg);
  errors[2].error = Pose2(0.02, 0.0, -0.5 * kDeg);
  for (ConstraintTruthError& e : errors) e.claimed_translation_meters = e.error.translation().norm();
  const ConstraintTruthSummary s = SummarizeConstraintTruth(errors);
  EXPECT_EQ(3, s.count);
  EXPECT_NEAR(0.02, s.median_translation_meters, 1e-12);
  EXPECT_NEAR(0.03, s.max_translation_meters, 1e-12);
  EXPECT_NEAR(0.3, s.median_rotation_degrees, 1e-9);
  EXPECT_NEAR(0.5, s.max_rotation_degrees, 1e-9);
  EXPECT_NEAR(-0.1 / 3, s.mean_signed_rotation_degrees, 1e-9);
  EXPECT_EQ(0, SummarizeConstraintTruth({}).count);
}

TEST(ConstraintTruthTest, WritesOneLineAConstraintWithTheRobotsNames) {
  std::vector<ConstraintTruthError> errors(2);
  errors[0].submap = {0, 3};
  errors[0].node = {1, 7};
  errors[0].kind = EdgeKind::kInterRobot;
  errors[1].submap = {2, 1};
  errors[1].node = {2, 40};
  const std::string path = ::testing::TempDir() + "/constraints_truth.txt";
  ASSERT_TRUE(WriteConstraintTruthErrors(path, errors, {"rover", "drone"}).ok());
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> rows;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') rows.push_back(line);
  }
  ASSERT_EQ(2u, rows.size());
  EXPECT_EQ(0u, rows[0].rfind("rover drone inter-robot 3 7 ", 0)) << rows[0];
  EXPECT_EQ(0u, rows[1].rfind("2 2 loop_closure 1 40 ", 0)) << rows[1] << " (a robot without a name: its id)";
  const Status status = WriteConstraintTruthErrors("/nonexistent/dir/x.txt", errors, {});
  EXPECT_FALSE(status.ok());
  EXPECT_NE(std::string::npos, status.message().find("/nonexistent/dir/x.txt")) << status.message();
}

}  // namespace
}  // namespace hetslam
