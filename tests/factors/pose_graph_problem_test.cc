// PoseGraphProblem on graphs whose answers are known by construction: a square loop, a wrong
// loop closure with and without a Huber loss, two robots joined through their anchors.
#include "factors/pose_graph_problem.h"

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/se2.h"
#include "factors/sqrt_information.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

// Every edge here: 5 cm per axis, 0.01 rad.
Eigen::Matrix3d EdgeSqrtInformation() { return SqrtInformationFromStddev(0.05, 0.05, 0.01); }

// Tight enough that exact graphs are solved to far below the test tolerances.
PoseGraphSolveOptions TightOptions() {
  PoseGraphSolveOptions options;
  options.max_num_iterations = 100;
  options.function_tolerance = 1e-14;
  return options;
}

void ExpectPoseNear(const Pose2& expected, const Pose2& actual, double translation_tol_meters,
                    double rotation_tol_radians, const std::string& full_report) {
  EXPECT_NEAR(0.0, (expected.translation() - actual.translation()).norm(), translation_tol_meters)
      << "expected " << expected << " actual " << actual << "\n" << full_report;
  EXPECT_NEAR(0.0, WrapAngle(expected.theta() - actual.theta()), rotation_tol_radians)
      << "expected " << expected << " actual " << actual << "\n" << full_report;
}

double MaxTranslationError(const PoseGraphProblem& problem, const std::vector<Pose2>& truth) {
  double max_error = 0.0;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    max_error = std::max(max_error, (problem.pose(k).translation() - truth[k].translation()).norm());
  }
  return max_error;
}

// Unit square walked counter-clockwise, each corner facing along its next side (corner 2 faces
// -x: its yaw sits on the +-pi seam). Every side, including the closing one 3 -> 0, measures
// "1 m ahead, then a +90 deg turn".
const std::vector<Pose2>& Square() {
  static const std::vector<Pose2> square = {Pose2(0, 0, 0), Pose2(1, 0, M_PI / 2),
                                            Pose2(1, 1, M_PI), Pose2(0, 1, -M_PI / 2)};
  return square;
}

// Poses 0..3 start at the square's corners perturbed by seeded noise (pose 0 is exact and held
// constant: the gauge, the square's origin). Sequential edges 0->1->2->3; returns the loop
// closure 3->0, which has a Huber loss of `loop_closure_loss_scale` sigmas (0: none).
int AddSquare(double loop_closure_loss_scale, PoseGraphProblem* problem) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int k = 0; k < 4; ++k) {
    const Pose2& corner = Square()[k];
    const double s = k == 0 ? 0.0 : 1.0;
    problem->AddPose(Pose2(corner.x() + 0.2 * s * noise(rng), corner.y() + 0.2 * s * noise(rng),
                           corner.theta() + 0.2 * s * noise(rng)));
  }
  problem->SetConstant(0, true);
  const Pose2 side(1.0, 0.0, M_PI / 2);
  for (int k = 0; k < 3; ++k) problem->AddEdge(EdgeKind::kSequential, k, k + 1, side, EdgeSqrtInformation());
  return problem->AddEdge(EdgeKind::kLoopClosure, 3, 0, side, EdgeSqrtInformation(),
                          loop_closure_loss_scale);
}

// A wrong loop closure 0 -> 2 that puts corner 2 `error_meters` too far along x.
int AddWrongClosure(double error_meters, double loss_scale, PoseGraphProblem* problem) {
  const Pose2 wrong = Between(Square()[0], Square()[2]) * Pose2(-error_meters, 0.0, 0.0);
  return problem->AddEdge(EdgeKind::kLoopClosure, 0, 2, wrong, EdgeSqrtInformation(), loss_scale);
}

TEST(PoseGraphProblemTest, SquareClosesFromPerturbedStart) {
  PoseGraphProblem problem;
  AddSquare(1.0, &problem);
  PoseGraphSolveSummary summary;
  const Status status = problem.Solve(TightOptions(), &summary);
  ASSERT_TRUE(status.ok()) << status.message() << "\n" << summary.full_report;
  EXPECT_TRUE(summary.converged) << summary.full_report;
  // Every edge is exact: the optimum is the square itself, at zero cost.
  EXPECT_LT(summary.final_cost, 1e-12) << summary.full_report;
  for (int k = 0; k < 4; ++k) ExpectPoseNear(Square()[k], problem.pose(k), 1e-6, 1e-6, summary.full_report);
}

// Largest corner error after solving the square with a wrong closure of `error_meters`.
double ErrorWithWrongClosure(double error_meters, double loss_scale) {
  PoseGraphProblem problem;
  AddSquare(loss_scale, &problem);
  AddWrongClosure(error_meters, loss_scale, &problem);
  PoseGraphSolveSummary summary;
  const Status status = problem.Solve(TightOptions(), &summary);
  EXPECT_TRUE(status.ok()) << status.message() << "\n" << summary.full_report;
  EXPECT_TRUE(summary.converged) << summary.full_report;
  return MaxTranslationError(problem, Square());
}

TEST(PoseGraphProblemTest, HuberBoundsTheInfluenceOfAWrongLoopClosure) {
  // A squared loss pulls in proportion to the error: corner 2 hangs on two equally stiff chains
  // (0-1-2 and 0-3-2) and the closure, so it gives way by about half the error, and a 10x larger
  // error bends the square about 10x more. A Huber loss caps the pull at `scale` (1) sigma
  // whatever the error, against the ~10 sigmas the squared loss keeps at its optimum (half of a
  // 1 m = 20 sigma error): about a tenth of the bend, the same for a 1 m and a 10 m error.
  const double plain_1m = ErrorWithWrongClosure(1.0, 0.0);
  const double plain_10m = ErrorWithWrongClosure(10.0, 0.0);
  const double huber_1m = ErrorWithWrongClosure(1.0, 1.0);
  const double huber_10m = ErrorWithWrongClosure(10.0, 1.0);
  EXPECT_NEAR(0.5, plain_1m, 0.1);
  EXPECT_GT(plain_10m, 5.0 * plain_1m);
  EXPECT_NEAR(0.1 * plain_1m, huber_1m, 0.2 * 0.1 * plain_1m);
  EXPECT_NEAR(huber_1m, huber_10m, 0.1 * huber_1m);
}

TEST(PoseGraphProblemTest, RemoveEdgeTakesItOutOfTheSolve) {
  PoseGraphProblem problem;
  AddSquare(0.0, &problem);
  const int wrong = AddWrongClosure(1.0, 0.0, &problem);
  PoseGraphSolveSummary summary;
  ASSERT_TRUE(problem.Solve(TightOptions(), &summary).ok()) << summary.full_report;
  ASSERT_GT(MaxTranslationError(problem, Square()), 0.1) << "the wrong closure should bend the square";

  problem.RemoveEdge(wrong);
  EXPECT_TRUE(problem.edge_removed(wrong));
  EXPECT_FALSE(problem.edge_removed(0));
  EXPECT_EQ(5, problem.num_edges());  // still listed
  const Status status = problem.Solve(TightOptions(), &summary);
  ASSERT_TRUE(status.ok()) << status.message() << "\n" << summary.full_report;
  for (int k = 0; k < 4; ++k) ExpectPoseNear(Square()[k], problem.pose(k), 1e-6, 1e-6, summary.full_report);
}

TEST(PoseGraphProblemTest, ReleasedEdgesLendTheirSlotsAndFreeTheirPoses) {
  PoseGraphProblem problem;
  AddSquare(0.0, &problem);  // edges 0-3 around the square, pose 0 constant
  const int wrong = AddWrongClosure(1.0, 0.0, &problem);
  EXPECT_EQ(3, problem.pose_edges(2));  // two sides and the closure
  problem.ReleaseEdge(wrong);
  EXPECT_TRUE(problem.edge_removed(wrong));
  EXPECT_EQ(2, problem.pose_edges(2));
  // The next edge takes the released slot: the list does not grow.
  const int again = AddWrongClosure(1.0, 0.0, &problem);
  EXPECT_EQ(wrong, again);
  EXPECT_EQ(5, problem.num_edges());
  EXPECT_FALSE(problem.edge_removed(again));
  problem.ReleaseEdge(again);
  // Pose 2 without its two sides: out of the problem; the rest still closes exactly.
  const Pose2 before = problem.pose(2);
  problem.ReleaseEdge(1);  // 1 -> 2
  problem.ReleaseEdge(2);  // 2 -> 3
  EXPECT_EQ(0, problem.pose_edges(2));
  problem.RemovePose(2);
  EXPECT_TRUE(problem.pose_removed(2));
  EXPECT_FALSE(problem.pose_removed(1));
  problem.set_pose(1, Square()[1] * Pose2(0.3, -0.2, 0.1));
  PoseGraphSolveSummary summary;
  const Status status = problem.Solve(TightOptions(), &summary);
  ASSERT_TRUE(status.ok()) << status.message() << "\n" << summary.full_report;
  for (int k : {0, 1, 3}) ExpectPoseNear(Square()[k], problem.pose(k), 1e-6, 1e-6, summary.full_report);
  ExpectPoseNear(before, problem.pose(2), 0.0, 0.0, "a removed pose keeps its last value");
}

TEST(PoseGraphProblemTest, RemovingAPoseThatEdgesStillHoldIsAProgrammerError) {
  PoseGraphProblem problem;
  AddSquare(0.0, &problem);
  EXPECT_DEATH(problem.RemovePose(2), "pose 2 still has edges");
  EXPECT_DEATH(problem.RemovePose(0), "still has edges|held constant");
}

// Two robots, two poses each in its own frame (the first at its origin, held constant), robot
// 0's anchor is the world (constant), robot 1's anchor starts at the identity. One inter-robot
// edge, measured between the true world poses of the robots' second poses, makes the graph
// exactly determined: the anchor of robot 1 must come out as world_T_robot1.
struct TwoRobots {
  int anchor0, anchor1, inter_robot_edge;
  std::vector<int> robot0, robot1;
};

TwoRobots AddTwoRobots(const Pose2& world_T_robot1, PoseGraphProblem* problem) {
  const std::vector<Pose2> robot0_true = {Pose2(0, 0, 0), Pose2(2.0, 0.5, 0.4)};
  const std::vector<Pose2> robot1_true = {Pose2(0, 0, 0), Pose2(1.0, -1.0, -0.7)};
  TwoRobots r;
  r.anchor0 = problem->AddPose(Pose2::Identity());
  r.anchor1 = problem->AddPose(Pose2::Identity());
  r.robot0 = {problem->AddPose(robot0_true[0]), problem->AddPose(Pose2(1.5, 0.0, 0.0))};
  r.robot1 = {problem->AddPose(robot1_true[0]), problem->AddPose(Pose2(0.5, -0.5, 0.0))};
  for (const int gauge : {r.anchor0, r.robot0[0], r.robot1[0]}) problem->SetConstant(gauge, true);
  problem->AddEdge(EdgeKind::kSequential, r.robot0[0], r.robot0[1], Between(robot0_true[0], robot0_true[1]),
                   EdgeSqrtInformation());
  problem->AddEdge(EdgeKind::kSequential, r.robot1[0], r.robot1[1], Between(robot1_true[0], robot1_true[1]),
                   EdgeSqrtInformation());
  const Pose2 measured = Between(robot0_true[1], world_T_robot1 * robot1_true[1]);
  r.inter_robot_edge = problem->AddAnchoredEdge(r.anchor0, r.robot0[1], r.anchor1, r.robot1[1], measured,
                                                EdgeSqrtInformation(), 1.0);
  return r;
}

TEST(PoseGraphProblemTest, AnchoredInterRobotEdgeRecoversTheOtherRobotsAnchor) {
  for (const Pose2& world_T_robot1 : {Pose2(3.0, -2.0, M_PI / 2), Pose2(-4.0, 1.0, M_PI - 0.05)}) {
    SCOPED_TRACE(::testing::Message() << "world_T_robot1 " << world_T_robot1);
    PoseGraphProblem problem;
    const TwoRobots r = AddTwoRobots(world_T_robot1, &problem);
    EXPECT_EQ(EdgeKind::kInterRobot, problem.edge_kind(r.inter_robot_edge));
    PoseGraphSolveSummary summary;
    const Status status = problem.Solve(TightOptions(), &summary);
    ASSERT_TRUE(status.ok()) << status.message() << "\n" << summary.full_report;
    ExpectPoseNear(world_T_robot1, problem.pose(r.anchor1), 1e-6, 1e-6, summary.full_report);
    ExpectPoseNear(Pose2::Identity(), problem.pose(r.anchor0), 0.0, 0.0, summary.full_report);
  }
}

TEST(PoseGraphProblemTest, AnEdgeReportsWhatItWasAddedWith) {
  PoseGraphProblem problem;
  const int a = problem.AddPose(Pose2(0.0, 0.0, 0.0));
  const int b = problem.AddPose(Pose2(1.0, 0.0, 0.0));
  const int c = problem.AddPose(Pose2(2.0, 0.0, 0.0));
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  s(0, 1) = 0.5;
  const int ab = problem.AddEdge(EdgeKind::kSequential, a, b, Pose2(1.0, 0.1, 0.2), 10.0 * s);
  const int bc = problem.AddEdge(EdgeKind::kLoopClosure, b, c, Pose2(0.9, -0.1, -0.3), 20.0 * s, 1.0);
  EXPECT_EQ(Pose2(1.0, 0.1, 0.2).ToVector(), problem.edge_measurement(ab).ToVector());
  EXPECT_EQ(10.0 * s, problem.edge_sqrt_information(ab));
  EXPECT_EQ(Pose2(0.9, -0.1, -0.3).ToVector(), problem.edge_measurement(bc).ToVector());
  EXPECT_EQ(20.0 * s, problem.edge_sqrt_information(bc));
  // A released slot handed out again reports its new edge.
  problem.ReleaseEdge(ab);
  const int ca = problem.AddEdge(EdgeKind::kLoopClosure, c, a, Pose2(-2.0, 0.0, 0.0), 5.0 * s, 1.0);
  EXPECT_EQ(ab, ca);
  EXPECT_EQ(Pose2(-2.0, 0.0, 0.0).ToVector(), problem.edge_measurement(ca).ToVector());
  EXPECT_EQ(5.0 * s, problem.edge_sqrt_information(ca));
}

TEST(PoseGraphProblemDeathTest, ARemovedEdgeHasNoMeasurement) {
  PoseGraphProblem problem;
  const int a = problem.AddPose(Pose2(0.0, 0.0, 0.0));
  const int b = problem.AddPose(Pose2(1.0, 0.0, 0.0));
  const int ab = problem.AddEdge(EdgeKind::kSequential, a, b, Pose2(1.0, 0.0, 0.0), Eigen::Matrix3d::Identity());
  problem.RemoveEdge(ab);
  EXPECT_DEATH(problem.edge_measurement(ab), "edge 0 is removed");
}

TEST(PoseGraphProblemTest, InterRobotEdgeEstimateEqualsItsMeasurementAfterSolving) {
  PoseGraphProblem problem;
  const TwoRobots r = AddTwoRobots(Pose2(3.0, -2.0, M_PI / 2), &problem);
  PoseGraphSolveSummary summary;
  ASSERT_TRUE(problem.Solve(TightOptions(), &summary).ok()) << summary.full_report;
  // The estimate composes both anchors (world_T_robot0 * robot0_T_a)^-1 (world_T_robot1 *
  // robot1_T_b); the exactly determined graph meets the measurement.
  ExpectPoseNear(problem.edge_measurement(r.inter_robot_edge), problem.EdgeEstimate(r.inter_robot_edge), 1e-6,
                 1e-6, summary.full_report);
  // Before solving it did not: robot 1's anchor started at the identity.
  PoseGraphProblem unsolved;
  const TwoRobots u = AddTwoRobots(Pose2(3.0, -2.0, M_PI / 2), &unsolved);
  EXPECT_GT((unsolved.EdgeEstimate(u.inter_robot_edge).translation() -
             unsolved.edge_measurement(u.inter_robot_edge).translation())
                .norm(),
            1.0);
}

TEST(PoseGraphProblemTest, InvalidOptionsAreAnErrorAndLeaveThePoses) {
  PoseGraphProblem problem;
  AddSquare(1.0, &problem);
  std::vector<Pose2> before;
  for (int k = 0; k < problem.num_poses(); ++k) before.push_back(problem.pose(k));
  PoseGraphSolveOptions options;
  options.max_num_iterations = -1;
  const Status status = problem.Solve(options);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("max_num_iterations"));
  for (int k = 0; k < problem.num_poses(); ++k) {
    EXPECT_EQ(before[k].ToVector(), problem.pose(k).ToVector()) << "pose " << k;
  }
}

TEST(PoseGraphProblemTest, UnusableSolveIsAnErrorAndRestoresThePoses) {
  PoseGraphProblem problem;
  AddSquare(1.0, &problem);
  problem.set_pose(2, Pose2(std::nan(""), 1.0, M_PI));  // Ceres cannot evaluate from here
  std::vector<Eigen::Vector3d> before;
  for (int k = 0; k < problem.num_poses(); ++k) before.push_back(problem.pose(k).ToVector());
  PoseGraphSolveSummary summary;
  const Status status = problem.Solve(TightOptions(), &summary);
  EXPECT_FALSE(status.ok()) << summary.full_report;
  EXPECT_THAT(status.message(), HasSubstr("unusable"));
  for (int k = 0; k < problem.num_poses(); ++k) {
    const Eigen::Vector3d after = problem.pose(k).ToVector();
    for (int i = 0; i < 3; ++i) {
      // Bit for bit, NaN included.
      EXPECT_TRUE(after[i] == before[k][i] || (std::isnan(after[i]) && std::isnan(before[k][i])))
          << "pose " << k << " component " << i;
    }
  }
}

TEST(PoseGraphProblemTest, ProblemWithoutEdgesIsConvergedAndUntouched) {
  PoseGraphProblem problem;
  problem.AddPose(Pose2(1.0, 2.0, 0.5));
  const int edge = problem.AddEdge(EdgeKind::kLoopClosure, 0, problem.AddPose(Pose2(3.0, 2.0, 0.5)),
                                   Pose2(1.0, 0.0, 0.0), EdgeSqrtInformation(), 1.0);
  problem.RemoveEdge(edge);  // the last edge: the problem has none left
  PoseGraphSolveSummary summary;
  ASSERT_TRUE(problem.Solve(TightOptions(), &summary).ok());
  EXPECT_TRUE(summary.converged);
  EXPECT_THAT(summary.message, HasSubstr("nothing to solve"));
  EXPECT_EQ(0, summary.num_iterations);
  EXPECT_EQ(Pose2(3.0, 2.0, 0.5).ToVector(), problem.pose(1).ToVector());
}

// A noisy ring of `num_poses` poses with a loop closure from every 10th pose back to pose 0,
// Huber on the closures, dead-reckoned start; all randomness from `seed`.
void AddNoisyRing(uint32_t seed, int num_poses, PoseGraphProblem* problem) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double turn = 2.0 * M_PI / num_poses;
  std::vector<Pose2> truth = {Pose2::Identity()};
  for (int k = 1; k < num_poses; ++k) truth.push_back(truth.back() * Pose2(1.0, 0.0, turn));
  auto measure = [&](int a, int b) {
    const Pose2 exact = Between(truth[a], truth[b]);
    return Pose2(exact.x() + 0.05 * noise(rng), exact.y() + 0.05 * noise(rng), exact.theta() + 0.01 * noise(rng));
  };
  Pose2 dead_reckoned;
  problem->AddPose(dead_reckoned);
  problem->SetConstant(0, true);
  for (int k = 1; k < num_poses; ++k) {
    const Pose2 step = measure(k - 1, k);
    dead_reckoned = dead_reckoned * step;
    problem->AddPose(dead_reckoned);
    problem->AddEdge(EdgeKind::kSequential, k - 1, k, step, EdgeSqrtInformation());
    if (k % 10 == 0) problem->AddEdge(EdgeKind::kLoopClosure, k, 0, measure(k, 0), EdgeSqrtInformation(), 1.0);
  }
}

TEST(PoseGraphProblemTest, IdenticalProblemsGiveBitIdenticalPoses) {
  PoseGraphProblem first, second;
  AddNoisyRing(11, 200, &first);
  AddNoisyRing(11, 200, &second);
  PoseGraphSolveSummary first_summary, second_summary;
  ASSERT_TRUE(first.Solve(PoseGraphSolveOptions(), &first_summary).ok()) << first_summary.full_report;
  ASSERT_TRUE(second.Solve(PoseGraphSolveOptions(), &second_summary).ok()) << second_summary.full_report;
  ASSERT_GT(first_summary.num_iterations, 1) << "a solve with work to do: " << first_summary.full_report;
  EXPECT_EQ(first_summary.final_cost, second_summary.final_cost);
  EXPECT_EQ(first_summary.num_iterations, second_summary.num_iterations);
  ASSERT_EQ(first.num_poses(), second.num_poses());
  for (int k = 0; k < first.num_poses(); ++k) {
    EXPECT_EQ(first.pose(k).ToVector(), second.pose(k).ToVector()) << "pose " << k;
  }
}

}  // namespace
}  // namespace hetslam
