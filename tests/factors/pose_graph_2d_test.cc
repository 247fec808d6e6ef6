#include "factors/pose_graph_2d.h"

#include <string>

#include "core/synthetic_pose_graph.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

// Largest translation (m) and rotation (rad) error of the graph's vertices against the truth.
void MaxErrors(const PoseGraph2d& graph, const std::vector<Pose2>& truth,
               double* max_translation_meters, double* max_rotation_radians) {
  *max_translation_meters = 0.0;
  *max_rotation_radians = 0.0;
  for (const PoseGraph2dVertex& v : graph.vertices) {
    const Pose2& t = truth[v.id];
    *max_translation_meters = std::max(*max_translation_meters,
                                       (v.world_T_vertex.translation() - t.translation()).norm());
    *max_rotation_radians = std::max(*max_rotation_radians,
                                     std::abs(WrapAngle(v.world_T_vertex.theta() - t.theta())));
  }
}

TEST(PoseGraph2dTest, ExactManhattanGraphConvergesToTruth) {
  ManhattanGraphOptions generator;
  generator.num_poses = 300;
  generator.add_measurement_noise = false;  // known optimum: the truth, cost 0
  SyntheticPoseGraph2d synthetic = GenerateManhattanPoseGraph2d(generator, 1);
  ASSERT_GT(synthetic.graph.edges.size(), synthetic.graph.vertices.size() + 20)
      << "the generated graph should have loop closures";
  double initial_translation_error = 0.0, initial_rotation_error = 0.0;
  MaxErrors(synthetic.graph, synthetic.world_T_vertex_true, &initial_translation_error,
            &initial_rotation_error);
  ASSERT_GT(initial_translation_error, 1.0) << "dead reckoning should have drifted";

  PoseGraph2dSummary summary;
  const Status status = OptimizePoseGraph2d(PoseGraph2dOptions(), &synthetic.graph, &summary);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(summary.converged) << summary.full_report;
  EXPECT_EQ(300, summary.num_vertices);
  EXPECT_EQ(1, summary.num_fixed_vertices);
  EXPECT_GT(summary.initial_cost, 1e3);
  EXPECT_LT(summary.final_cost, 1e-8) << summary.full_report;
  EXPECT_GT(summary.num_iterations, 0);
  double translation_error = 0.0, rotation_error = 0.0;
  MaxErrors(synthetic.graph, synthetic.world_T_vertex_true, &translation_error, &rotation_error);
  EXPECT_LT(translation_error, 1e-5) << summary.full_report;
  EXPECT_LT(rotation_error, 1e-6) << summary.full_report;
}

TEST(PoseGraph2dTest, NoisyGraphReachesChiSquaredLevelCost) {
  // With Gaussian edge noise, the optimum's cost is about 1/2 (3 * edges - 3 * (vertices - 1))
  // (chi-squared with that many degrees of freedom, halved by Ceres' convention).
  ManhattanGraphOptions generator;
  generator.num_poses = 400;
  generator.half_extent_blocks = 2;  // a small town: many revisits, many loop closures
  SyntheticPoseGraph2d synthetic = GenerateManhattanPoseGraph2d(generator, 2);
  PoseGraph2dOptions options;
  options.loop_closure_loss = RobustLossType::kHuber;
  options.loop_closure_loss_scale = 3.0;  // inliers stay in the quadratic zone
  PoseGraph2dSummary summary;
  const Status status = OptimizePoseGraph2d(options, &synthetic.graph, &summary);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(summary.converged) << summary.full_report;
  const double dof = 3.0 * (summary.num_edges - (summary.num_vertices - 1));
  ASSERT_GT(dof, 100.0);
  EXPECT_GT(summary.final_cost, 0.5 * 0.5 * dof) << summary.full_report;
  EXPECT_LT(summary.final_cost, 0.5 * 1.5 * dof) << summary.full_report;
  double translation_error = 0.0, rotation_error = 0.0;
  MaxErrors(synthetic.graph, synthetic.world_T_vertex_true, &translation_error, &rotation_error);
  EXPECT_LT(translation_error, 1.0);
  EXPECT_LT(rotation_error, 0.1);
}

TEST(PoseGraph2dTest, FixLinesChooseTheGauge) {
  ManhattanGraphOptions generator;
  generator.num_poses = 100;
  generator.add_measurement_noise = false;
  SyntheticPoseGraph2d synthetic = GenerateManhattanPoseGraph2d(generator, 3);
  // Hold vertex 50 at its true pose instead of vertex 0 at its (equal) start.
  synthetic.graph.vertices[50].world_T_vertex = synthetic.world_T_vertex_true[50];
  synthetic.graph.fixed_vertex_ids = {50};
  synthetic.graph.vertices[0].world_T_vertex = Pose2(3.0, -2.0, 1.0);
  PoseGraph2dSummary summary;
  ASSERT_TRUE(OptimizePoseGraph2d(PoseGraph2dOptions(), &synthetic.graph, &summary).ok());
  EXPECT_EQ(1, summary.num_fixed_vertices);
  double translation_error = 0.0, rotation_error = 0.0;
  MaxErrors(synthetic.graph, synthetic.world_T_vertex_true, &translation_error, &rotation_error);
  EXPECT_LT(translation_error, 1e-5) << summary.full_report;
  EXPECT_LT(rotation_error, 1e-6) << summary.full_report;
}

TEST(PoseGraph2dTest, IterationLimitIsReportedNotAnError) {
  ManhattanGraphOptions generator;
  generator.num_poses = 200;
  SyntheticPoseGraph2d synthetic = GenerateManhattanPoseGraph2d(generator, 4);
  PoseGraph2dOptions options;
  options.max_num_iterations = 1;
  PoseGraph2dSummary summary;
  ASSERT_TRUE(OptimizePoseGraph2d(options, &synthetic.graph, &summary).ok());
  EXPECT_FALSE(summary.converged);
  EXPECT_EQ(1, summary.num_iterations);
  EXPECT_LT(summary.final_cost, summary.initial_cost);
}

TEST(PoseGraph2dTest, BadInputsAreErrors) {
  PoseGraph2dSummary summary;
  PoseGraph2d empty;
  Status status = OptimizePoseGraph2d(PoseGraph2dOptions(), &empty, &summary);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("no vertices"));

  PoseGraph2d dangling;
  dangling.vertices.push_back({0, Pose2()});
  dangling.edges.push_back({0, 4, Pose2(1, 0, 0), Eigen::Matrix3d::Identity()});
  status = OptimizePoseGraph2d(PoseGraph2dOptions(), &dangling, &summary);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("edge 0 -> 4"));

  PoseGraph2dOptions bad_options;
  bad_options.loop_closure_loss_scale = 0.0;
  std::string error;
  EXPECT_FALSE(bad_options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("loop_closure_loss_scale"));
}

// Vertex 0 at the origin (the gauge); two edges 0 -> 1 between consecutive ids: a good one (kind
// kSequential, 1 m ahead) and one 5 sigmas off in y (1 m ahead, 5 m left; sigma 1 m, 1 rad)
// of kind `second_kind`. Returns the solved y of vertex 1.
double SolvedYWithSecondEdgeOfKind(EdgeKind second_kind, RobustLossType loss = RobustLossType::kHuber) {
  PoseGraph2d graph;
  graph.vertices = {{0, Pose2()}, {1, Pose2(0.5, 0.5, 0.1)}};
  graph.edges.push_back({0, 1, Pose2(1, 0, 0), Eigen::Matrix3d::Identity(), EdgeKind::kSequential});
  graph.edges.push_back({0, 1, Pose2(1, 5, 0), Eigen::Matrix3d::Identity(), second_kind});
  PoseGraph2dOptions options;
  options.loop_closure_loss = loss;
  options.loop_closure_loss_scale = 1.0;
  options.function_tolerance = 1e-14;  // the default 1e-8 of a cost of a few units stops ~1e-4 m short
  PoseGraph2dSummary summary;
  const Status status = OptimizePoseGraph2d(options, &graph, &summary);
  EXPECT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(summary.converged) << summary.full_report;
  return graph.vertices[1].world_T_vertex.y();
}

TEST(PoseGraph2dTest, EdgeKindNotIdsDecidesTheLoss) {
  // Sequential: no loss, min 1/2 y^2 + 1/2 (y - 5)^2 gives y = 2.5. Loop closure or inter-robot:
  // Huber(1) on the second edge, min 1/2 y^2 + (|y - 5| - 1/2) gives y = 1 (and |1 - 5| > 1,
  // so the second edge is indeed in Huber's linear zone).
  EXPECT_NEAR(2.5, SolvedYWithSecondEdgeOfKind(EdgeKind::kSequential), 1e-6);
  EXPECT_NEAR(1.0, SolvedYWithSecondEdgeOfKind(EdgeKind::kLoopClosure), 1e-6);
  EXPECT_NEAR(1.0, SolvedYWithSecondEdgeOfKind(EdgeKind::kInterRobot), 1e-6);
}

TEST(PoseGraph2dTest, CauchyLossOnLoopClosures) {
  // Cauchy(1) on the second edge: min 1/2 y^2 + 1/2 log(1 + (y - 5)^2), stationary where
  // y + (y - 5) / (1 + (y - 5)^2) = 0, at y ~ 0.2: far less pull than Huber's y = 1.
  const double y = SolvedYWithSecondEdgeOfKind(EdgeKind::kLoopClosure, RobustLossType::kCauchy);
  EXPECT_NEAR(0.0, y + (y - 5) / (1 + (y - 5) * (y - 5)), 1e-6);
  EXPECT_LT(y, 0.3);
  EXPECT_NEAR(2.5, SolvedYWithSecondEdgeOfKind(EdgeKind::kSequential, RobustLossType::kCauchy), 1e-6);
}

TEST(RobustLossTypeTest, NamesRoundTrip) {
  for (const RobustLossType type :
       {RobustLossType::kNone, RobustLossType::kHuber, RobustLossType::kCauchy}) {
    RobustLossType parsed = RobustLossType::kNone;
    ASSERT_TRUE(ParseRobustLossType(RobustLossTypeName(type), &parsed));
    EXPECT_EQ(type, parsed);
  }
  RobustLossType parsed;
  EXPECT_FALSE(ParseRobustLossType("tukey", &parsed));
}

}  // namespace
}  // namespace hetslam
