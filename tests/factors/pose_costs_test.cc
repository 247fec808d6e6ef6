// Gradient checks of every pose factor and small problems with answers worked out by hand.
#include <memory>
#include <random>
#include <vector>

#include "ceres/ceres.h"
#include "ceres/gradient_checker.h"
#include "core/se2.h"
#include "factors/landmark_observation_cost.h"
#include "factors/prior_costs.h"
#include "factors/relative_pose_cost.h"
#include "factors/se2_manifold.h"
#include "factors/sqrt_information.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

using Block = std::array<double, 3>;

Block ToBlock(const Pose2& p) { return {p.x(), p.y(), p.theta()}; }
Pose2 ToPose(const Block& b) { return Pose2(b[0], b[1], b[2]); }

void ExpectPoseNear(const Pose2& expected, const Block& actual, double translation_tol_meters,
                    double rotation_tol_radians) {
  EXPECT_NEAR(expected.x(), actual[0], translation_tol_meters);
  EXPECT_NEAR(expected.y(), actual[1], translation_tol_meters);
  EXPECT_NEAR(0.0, WrapAngle(expected.theta() - actual[2]), rotation_tol_radians)
      << "expected " << expected << " actual " << ToPose(actual);
}

Pose2 RandomPose(std::mt19937* rng) {
  std::uniform_real_distribution<double> xy(-20.0, 20.0), th(-M_PI, M_PI);
  return Pose2(xy(*rng), xy(*rng), th(*rng));
}

Pose2 Perturb(const Pose2& p, double sigma_xy, double sigma_yaw, std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Pose2(p.x() + sigma_xy * n(*rng), p.y() + sigma_xy * n(*rng),
               p.theta() + sigma_yaw * n(*rng));
}

// A random full (not diagonal) sqrt information from a random SPD covariance.
Eigen::Matrix3d RandomSqrtInformation(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3d a;
  for (int i = 0; i < 9; ++i) a(i) = u(*rng);
  const Eigen::Matrix3d covariance = 0.01 * (a * a.transpose() + 0.5 * Eigen::Matrix3d::Identity());
  return SqrtInformationFromCovariance(covariance);
}

// Probes `cost` at `blocks` with the Se2Manifold on every block.
void ExpectGradientsCorrect(const ceres::CostFunction& cost, std::vector<Block> blocks) {
  const Se2Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds(blocks.size(), &manifold);
  const ceres::NumericDiffOptions numeric_options;
  const ceres::GradientChecker checker(&cost, &manifolds, numeric_options);
  std::vector<double*> parameters;
  for (Block& b : blocks) parameters.push_back(b.data());
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(parameters.data(), 1e-6, &results)) << results.error_log;
}

// Poses used by the gradient checks: seeded random ones, and pairs straddling +-pi.
std::vector<std::pair<Pose2, Pose2>> TestPosePairs() {
  std::mt19937 rng(2024);
  std::vector<std::pair<Pose2, Pose2>> pairs;
  for (int i = 0; i < 20; ++i) pairs.emplace_back(RandomPose(&rng), RandomPose(&rng));
  pairs.emplace_back(Pose2(1.0, 2.0, M_PI - 1e-3), Pose2(3.0, -1.0, -M_PI + 1e-3));
  pairs.emplace_back(Pose2(-1.0, 0.5, -M_PI + 1e-4), Pose2(0.0, 0.0, M_PI - 1e-4));
  pairs.emplace_back(Pose2::Identity(), Pose2::Identity());
  return pairs;
}

TEST(SqrtInformationTest, SquaresToInverseCovarianceAndIsUpperTriangular) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3d a;
  for (int i = 0; i < 9; ++i) a(i) = u(rng);
  const Eigen::Matrix3d covariance = a * a.transpose() + 0.1 * Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d s = SqrtInformationFromCovariance(covariance);
  EXPECT_TRUE((s.transpose() * s * covariance).isApprox(Eigen::Matrix3d::Identity(), 1e-10));
  EXPECT_EQ(0.0, s(1, 0));
  EXPECT_EQ(0.0, s(2, 0));
  EXPECT_EQ(0.0, s(2, 1));
  EXPECT_GT(s.diagonal().minCoeff(), 0.0);
  // Diagonal case by hand: sigma 0.1 m, 0.2 m, 0.05 rad -> 10, 5, 20.
  const Eigen::Matrix3d d =
      SqrtInformationFromCovariance(Eigen::Vector3d(0.01, 0.04, 0.0025).asDiagonal());
  EXPECT_TRUE(d.isApprox(Eigen::Vector3d(10.0, 5.0, 20.0).asDiagonal().toDenseMatrix(), 1e-12));
  EXPECT_TRUE(SqrtInformationFromStddev(0.1, 0.2, 0.05).isApprox(d, 1e-12));
}

TEST(SqrtInformationDeathTest, RejectsIndefiniteCovariance) {
  const Eigen::Matrix3d bad = Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal();
  EXPECT_DEATH(SqrtInformationFromCovariance(bad), "not positive definite");
}

TEST(GradientCheckTest, RelativePose2Cost) {
  std::mt19937 rng(11);
  for (const auto& [a, b] : TestPosePairs()) {
    const Pose2 measured = Perturb(Between(a, b), 0.1, 0.05, &rng);
    std::unique_ptr<ceres::CostFunction> cost(
        CreateRelativePose2Cost(measured, RandomSqrtInformation(&rng)));
    ExpectGradientsCorrect(*cost, {ToBlock(a), ToBlock(b)});
  }
}

// The hand-written Jacobian of CreateRelativePose2Cost equals the autodiff of
// RelativePose2Residual (and the residuals agree) at identity, near identity, across +-pi and
// at seeded random poses, for both blocks and with either Jacobian requested alone.
TEST(RelativePose2CostTest, AnalyticJacobianMatchesAutoDiff) {
  std::mt19937 rng(15);
  std::vector<std::pair<Pose2, Pose2>> pairs = TestPosePairs();
  pairs.emplace_back(Pose2::Identity(), Pose2(1e-7, -1e-7, 1e-7));  // near identity
  for (const auto& [a, b] : pairs) {
    for (const Pose2& measured : {Perturb(Between(a, b), 0.1, 0.05, &rng), Between(a, b), Pose2::Identity()}) {
      const Eigen::Matrix3d sqrt_information = RandomSqrtInformation(&rng);
      std::unique_ptr<ceres::CostFunction> analytic(CreateRelativePose2Cost(measured, sqrt_information));
      ceres::AutoDiffCostFunction<RelativePose2Residual, 3, 3, 3> autodiff(
          new RelativePose2Residual(measured, sqrt_information));
      Block block_a = ToBlock(a), block_b = ToBlock(b);
      const double* parameters[2] = {block_a.data(), block_b.data()};
      double r_analytic[3], r_autodiff[3];
      double ja_analytic[9], jb_analytic[9], ja_autodiff[9], jb_autodiff[9];
      double* j_analytic[2] = {ja_analytic, jb_analytic};
      double* j_autodiff[2] = {ja_autodiff, jb_autodiff};
      ASSERT_TRUE(analytic->Evaluate(parameters, r_analytic, j_analytic));
      ASSERT_TRUE(autodiff.Evaluate(parameters, r_autodiff, j_autodiff));
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(r_autodiff[i], r_analytic[i], 1e-9) << "residual " << i;
      for (int i = 0; i < 9; ++i) {
        EXPECT_NEAR(ja_autodiff[i], ja_analytic[i], 1e-9) << "d/d world_T_a entry " << i << " at " << a << ", " << b;
        EXPECT_NEAR(jb_autodiff[i], jb_analytic[i], 1e-9) << "d/d world_T_b entry " << i << " at " << a << ", " << b;
      }
      // One Jacobian at a time (the other pointer null, as Ceres passes for constant blocks).
      double only[9];
      double* only_b[2] = {nullptr, only};
      ASSERT_TRUE(analytic->Evaluate(parameters, r_analytic, only_b));
      for (int i = 0; i < 9; ++i) EXPECT_NEAR(jb_autodiff[i], only[i], 1e-9);
      double* only_a[2] = {only, nullptr};
      ASSERT_TRUE(analytic->Evaluate(parameters, r_analytic, only_a));
      for (int i = 0; i < 9; ++i) EXPECT_NEAR(ja_autodiff[i], only[i], 1e-9);
    }
  }
}

TEST(GradientCheckTest, AnchoredRelativePose2Cost) {
  std::mt19937 rng(12);
  for (const auto& [a, b] : TestPosePairs()) {
    const Pose2 world_T_a_origin = RandomPose(&rng);
    const Pose2 world_T_b_origin(0.5, -2.0, M_PI - 2e-3);  // anchor yaw next to the cut
    const Pose2 a_origin_T_ai = world_T_a_origin.inverse() * a;
    const Pose2 b_origin_T_bj = world_T_b_origin.inverse() * b;
    const Pose2 measured = Perturb(Between(a, b), 0.1, 0.05, &rng);
    std::unique_ptr<ceres::CostFunction> cost(
        CreateAnchoredRelativePose2Cost(measured, RandomSqrtInformation(&rng)));
    ExpectGradientsCorrect(*cost, {ToBlock(world_T_a_origin), ToBlock(a_origin_T_ai),
                                   ToBlock(world_T_b_origin), ToBlock(b_origin_T_bj)});
  }
}

TEST(GradientCheckTest, LandmarkObservationCost) {
  std::mt19937 rng(13);
  for (const auto& [robot, landmark] : TestPosePairs()) {
    const Pose2 measured = Perturb(Between(robot, landmark), 0.1, 0.05, &rng);
    std::unique_ptr<ceres::CostFunction> cost(
        CreateLandmarkObservationCost(measured, RandomSqrtInformation(&rng)));
    ExpectGradientsCorrect(*cost, {ToBlock(robot), ToBlock(landmark)});
  }
}

TEST(GradientCheckTest, PosePriorAndHeadingPriorCosts) {
  std::mt19937 rng(14);
  for (const auto& [pose, unused] : TestPosePairs()) {
    const Pose2 prior = Perturb(pose, 0.2, 0.1, &rng);
    std::unique_ptr<ceres::CostFunction> pose_prior(
        CreatePose2PriorCost(prior, RandomSqrtInformation(&rng)));
    ExpectGradientsCorrect(*pose_prior, {ToBlock(pose)});
    std::unique_ptr<ceres::CostFunction> heading(CreateHeadingPriorCost(prior.theta(), 0.05));
    ExpectGradientsCorrect(*heading, {ToBlock(pose)});
  }
}

TEST(RelativePose2CostTest, MeasurementIsReadBackFromEitherCost) {
  const Pose2 measured(1.5, -0.25, 0.3);
  Eigen::Matrix3d s;
  s << 10.0, 1.0, 0.5, 0.0, 20.0, 2.0, 0.0, 0.0, 30.0;
  Pose2 read;
  Eigen::Matrix3d read_s;
  std::unique_ptr<ceres::CostFunction> between(CreateRelativePose2Cost(measured, s));
  ASSERT_TRUE(RelativePose2CostMeasurement(*between, &read, &read_s));
  EXPECT_EQ(measured.ToVector(), read.ToVector());
  EXPECT_EQ(s, read_s);
  const Pose2 anchored_measured(-3.0, 4.0, -2.5);
  std::unique_ptr<ceres::CostFunction> anchored(CreateAnchoredRelativePose2Cost(anchored_measured, 2.0 * s));
  ASSERT_TRUE(RelativePose2CostMeasurement(*anchored, &read, &read_s));
  EXPECT_EQ(anchored_measured.ToVector(), read.ToVector());
  EXPECT_EQ(2.0 * s, read_s);
  // Any other cost: false, outputs untouched.
  std::unique_ptr<ceres::CostFunction> other(
      new ceres::AutoDiffCostFunction<RelativePose2Residual, 3, 3, 3>(new RelativePose2Residual(measured, s)));
  EXPECT_FALSE(RelativePose2CostMeasurement(*other, &read, &read_s));
  EXPECT_EQ(anchored_measured.ToVector(), read.ToVector());
}

TEST(RelativePose2CostTest, ResidualIsWhitenedG2oErrorByHand) {
  // a at the origin facing +y; b 2 m ahead of a, facing -x. Measured: 1.9 m ahead, +0.1 rad.
  const Pose2 world_T_a(0.0, 0.0, M_PI / 2), world_T_b(0.0, 2.0, M_PI);
  const Pose2 measured(1.9, 0.0, M_PI / 2 + 0.1);
  std::unique_ptr<ceres::CostFunction> cost(
      CreateRelativePose2Cost(measured, SqrtInformationFromStddev(0.1, 0.2, 0.05)));
  Block a = ToBlock(world_T_a), b = ToBlock(world_T_b);
  const double* parameters[2] = {a.data(), b.data()};
  double residual[3];
  ASSERT_TRUE(cost->Evaluate(parameters, residual, nullptr));
  // E = measured^-1 * (2, 0, pi/2): translation (0.1, 0) rotated by -(pi/2 + 0.1); yaw -0.1.
  const double c = std::cos(M_PI / 2 + 0.1), s = std::sin(M_PI / 2 + 0.1);
  EXPECT_NEAR(10.0 * (c * 0.1), residual[0], 1e-12);
  EXPECT_NEAR(5.0 * (-s * 0.1), residual[1], 1e-12);
  EXPECT_NEAR(20.0 * -0.1, residual[2], 1e-12);
}

// Solves and prints the full report on failure.
void SolveOrDie(ceres::Problem* problem) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.function_tolerance = 1e-12;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-12;
  options.max_num_iterations = 100;
  ceres::Solver::Summary summary;
  ceres::Solve(options, problem, &summary);
  ASSERT_EQ(ceres::CONVERGENCE, summary.termination_type) << summary.FullReport();
}

// Problems own their manifold once: every block shares this one.
ceres::Problem::Options SharedManifoldProblemOptions() {
  ceres::Problem::Options options;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

// Unit square walked counter-clockwise: poses at the corners, each facing along its next side.
std::vector<Pose2> SquareOfSide(double side) {
  return {Pose2(0, 0, 0), Pose2(side, 0, M_PI / 2), Pose2(side, side, M_PI),
          Pose2(0, side, -M_PI / 2)};
}

// Square loop: odometry 0->1->2->3 and the loop closure 3->0, each measuring `side` ahead and a
// +90 deg turn. Pose 0 fixed at the origin; the others start from noisy dead reckoning.
void SolveSquare(double measured_side, std::vector<Block>* blocks) {
  Se2Manifold manifold;  // outlives the problem below (declared first)
  ceres::Problem problem(SharedManifoldProblemOptions());
  std::mt19937 rng(5);
  const Pose2 step(measured_side, 0.0, M_PI / 2);
  const Eigen::Matrix3d sqrt_information = SqrtInformationFromStddev(0.05, 0.05, 0.01);
  Pose2 dead_reckoned;
  blocks->assign(4, Block{});
  for (int k = 0; k < 4; ++k) {
    (*blocks)[k] = ToBlock(k == 0 ? Pose2::Identity() : dead_reckoned);
    dead_reckoned = dead_reckoned * Perturb(step, 0.2, 0.2, &rng);
    problem.AddParameterBlock((*blocks)[k].data(), 3, &manifold);
  }
  for (int k = 0; k < 4; ++k) {
    // Robust loss on the loop closure only (header guidance); it changes nothing at a zero-cost
    // optimum, but the square must still close with it.
    ceres::LossFunction* loss = k == 3 ? new ceres::CauchyLoss(1.0) : nullptr;
    problem.AddResidualBlock(CreateRelativePose2Cost(step, sqrt_information), loss,
                             (*blocks)[k].data(), (*blocks)[(k + 1) % 4].data());
  }
  // Gauge: the first pose is the origin of the map.
  problem.SetParameterBlockConstant((*blocks)[0].data());
  SolveOrDie(&problem);
}

TEST(HandSolvedProblemTest, SquareLoopClosesFromNoisyStart) {
  std::vector<Block> blocks;
  SolveSquare(1.0, &blocks);
  const std::vector<Pose2> truth = SquareOfSide(1.0);
  for (int k = 0; k < 4; ++k) ExpectPoseNear(truth[k], blocks[k], 1e-6, 1e-6);
}

TEST(HandSolvedProblemTest, SquareWithScaledOdometryIsScaledSquare) {
  // Every edge (odometry and closure) says 1.2 m: consistent, so the optimum is the square of
  // side 1.2 with zero cost.
  std::vector<Block> blocks;
  SolveSquare(1.2, &blocks);
  const std::vector<Pose2> truth = SquareOfSide(1.2);
  for (int k = 0; k < 4; ++k) ExpectPoseNear(truth[k], blocks[k], 1e-6, 1e-6);
}

TEST(HandSolvedProblemTest, InconsistentLoopSplitsErrorEvenly) {
  // x0 = 0 fixed; odometry 0->1 and 1->2 say 1.0 m; closure 0->2 says 2.3 m; equal weights.
  // min (x1 - 1)^2 + (x2 - x1 - 1)^2 + (x2 - 2.3)^2  =>  x1 = 1.1, x2 = 2.2.
  Se2Manifold manifold;  // outlives the problem below (declared first)
  ceres::Problem problem(SharedManifoldProblemOptions());
  std::vector<Block> x = {Block{0, 0, 0}, Block{0.7, 0.3, 0.2}, Block{2.5, -0.4, -0.1}};
  for (Block& b : x) problem.AddParameterBlock(b.data(), 3, &manifold);
  const Eigen::Matrix3d s = SqrtInformationFromStddev(0.1, 0.1, 0.01);
  problem.AddResidualBlock(CreateRelativePose2Cost(Pose2(1.0, 0, 0), s), nullptr, x[0].data(),
                           x[1].data());
  problem.AddResidualBlock(CreateRelativePose2Cost(Pose2(1.0, 0, 0), s), nullptr, x[1].data(),
                           x[2].data());
  problem.AddResidualBlock(CreateRelativePose2Cost(Pose2(2.3, 0, 0), s), nullptr, x[0].data(),
                           x[2].data());
  problem.SetParameterBlockConstant(x[0].data());  // gauge: the first pose
  SolveOrDie(&problem);
  ExpectPoseNear(Pose2(1.1, 0, 0), x[1], 1e-6, 1e-6);
  ExpectPoseNear(Pose2(2.2, 0, 0), x[2], 1e-6, 1e-6);
}

// Two robots, each with two poses in its own frame and its own anchor. Robot a's anchor is the
// world (fixed); robot b's anchor starts at the identity and must come out as the true offset.
void ExpectAnchorRecovered(const Pose2& world_T_b_origin_true) {
  Se2Manifold manifold;  // outlives the problem below (declared first)
  ceres::Problem problem(SharedManifoldProblemOptions());
  const Pose2 world_T_a_origin_true = Pose2::Identity();
  // Poses in their own robot frames (first pose of each robot at its origin).
  const std::vector<Pose2> a_true = {Pose2(0, 0, 0), Pose2(2.0, 0.5, 0.4)};
  const std::vector<Pose2> b_true = {Pose2(0, 0, 0), Pose2(1.0, -1.0, -0.7)};
  Block anchor_a = ToBlock(world_T_a_origin_true), anchor_b = ToBlock(Pose2::Identity());
  std::vector<Block> a = {ToBlock(a_true[0]), ToBlock(Pose2(1.5, 0.0, 0.0))};
  std::vector<Block> b = {ToBlock(b_true[0]), ToBlock(Pose2(0.5, -0.5, 0.0))};
  for (Block* block : {&anchor_a, &anchor_b, &a[0], &a[1], &b[0], &b[1]}) {
    problem.AddParameterBlock(block->data(), 3, &manifold);
  }
  const Eigen::Matrix3d s = SqrtInformationFromStddev(0.05, 0.05, 0.02);
  // Odometry inside each robot's own frame.
  problem.AddResidualBlock(CreateRelativePose2Cost(Between(a_true[0], a_true[1]), s), nullptr,
                           a[0].data(), a[1].data());
  problem.AddResidualBlock(CreateRelativePose2Cost(Between(b_true[0], b_true[1]), s), nullptr,
                           b[0].data(), b[1].data());
  // Two inter-robot constraints, true world poses a_i and b_j composed through the anchors.
  for (const auto& [i, j] : {std::pair<int, int>{0, 1}, std::pair<int, int>{1, 0}}) {
    const Pose2 world_T_ai = world_T_a_origin_true * a_true[i];
    const Pose2 world_T_bj = world_T_b_origin_true * b_true[j];
    problem.AddResidualBlock(CreateAnchoredRelativePose2Cost(Between(world_T_ai, world_T_bj), s),
                             new ceres::CauchyLoss(1.0), anchor_a.data(), a[i].data(),
                             anchor_b.data(), b[j].data());
  }
  // Gauge: robot a's anchor is the world; each robot's first pose is its own origin.
  problem.SetParameterBlockConstant(anchor_a.data());
  problem.SetParameterBlockConstant(a[0].data());
  problem.SetParameterBlockConstant(b[0].data());
  SolveOrDie(&problem);
  ExpectPoseNear(world_T_b_origin_true, anchor_b, 1e-6, 1e-6);
  ExpectPoseNear(a_true[1], a[1], 1e-6, 1e-6);
  ExpectPoseNear(b_true[1], b[1], 1e-6, 1e-6);
}

TEST(HandSolvedProblemTest, TwoRobotsKnownFrameOffsetRecoveredThroughAnchors) {
  ExpectAnchorRecovered(Pose2(3.0, -2.0, M_PI / 2));
}

TEST(HandSolvedProblemTest, TwoRobotsFrameOffsetAcrossPi) {
  ExpectAnchorRecovered(Pose2(-4.0, 1.0, M_PI - 0.05));
}

TEST(HandSolvedProblemTest, LandmarkSeenFromTwoPoses) {
  // Pose 0 at the origin (fixed) sees the tag 2 m ahead and 1 m left, facing back (yaw pi).
  // Pose 1 sees the same tag 1 m straight ahead, facing it. By hand: landmark = (2, 1, pi);
  // pose 1 = landmark * (1, 0, pi)^-1 = (2, 1, pi) * (1, 0, -pi) = (1, 1, 0).
  Se2Manifold manifold;  // outlives the problem below (declared first)
  ceres::Problem problem(SharedManifoldProblemOptions());
  Block pose0 = {0, 0, 0}, pose1 = {0.5, 0.2, 0.3}, landmark = {1.0, 0.0, 2.0};
  for (Block* block : {&pose0, &pose1, &landmark}) {
    problem.AddParameterBlock(block->data(), 3, &manifold);
  }
  const Eigen::Matrix3d s = SqrtInformationFromStddev(0.02, 0.02, 0.05);
  problem.AddResidualBlock(CreateLandmarkObservationCost(Pose2(2.0, 1.0, M_PI), s),
                           new ceres::HuberLoss(1.0), pose0.data(), landmark.data());
  problem.AddResidualBlock(CreateLandmarkObservationCost(Pose2(1.0, 0.0, M_PI), s),
                           new ceres::HuberLoss(1.0), pose1.data(), landmark.data());
  problem.SetParameterBlockConstant(pose0.data());  // gauge: the first pose
  SolveOrDie(&problem);
  ExpectPoseNear(Pose2(2.0, 1.0, M_PI), landmark, 1e-6, 1e-6);
  ExpectPoseNear(Pose2(1.0, 1.0, 0.0), pose1, 1e-6, 1e-6);
}

TEST(HandSolvedProblemTest, HeadingPriorAveragesWithOdometryAcrossPi) {
  // A fixed pose at the origin; odometry says pose 1 has yaw pi - 0.1, the MARG says
  // -pi + 0.1 (= pi + 0.1), both with sigma 0.1 rad: the average is yaw pi, not 0.
  Se2Manifold manifold;  // outlives the problem below (declared first)
  ceres::Problem problem(SharedManifoldProblemOptions());
  Block pose0 = {0, 0, 0}, pose1 = {1.0, 0.0, 2.0};
  problem.AddParameterBlock(pose0.data(), 3, &manifold);
  problem.AddParameterBlock(pose1.data(), 3, &manifold);
  problem.AddResidualBlock(
      CreateRelativePose2Cost(Pose2(1.0, 0.0, M_PI - 0.1), SqrtInformationFromStddev(0.1, 0.1, 0.1)),
      nullptr, pose0.data(), pose1.data());
  problem.AddResidualBlock(CreateHeadingPriorCost(-M_PI + 0.1, 0.1), nullptr, pose1.data());
  problem.SetParameterBlockConstant(pose0.data());
  SolveOrDie(&problem);
  ExpectPoseNear(Pose2(1.0, 0.0, M_PI), pose1, 1e-6, 1e-6);
}

TEST(HandSolvedProblemTest, PosePriorAveragesWithOdometry) {
  // Odometry from the fixed origin says x = 1.2, a world prior says x = 1.0, yaw 0.2 vs 0.0,
  // equal sigmas: x = 1.1, y = 0, yaw = 0.1 (yaw of the fixed pose is 0, so both errors are
  // world-aligned and the solution is the plain average).
  Se2Manifold manifold;  // outlives the problem below (declared first)
  ceres::Problem problem(SharedManifoldProblemOptions());
  Block pose0 = {0, 0, 0}, pose1 = {0.0, 0.5, -0.5};
  problem.AddParameterBlock(pose0.data(), 3, &manifold);
  problem.AddParameterBlock(pose1.data(), 3, &manifold);
  const Eigen::Matrix3d s = SqrtInformationFromStddev(0.1, 0.1, 0.1);
  problem.AddResidualBlock(CreateRelativePose2Cost(Pose2(1.2, 0.0, 0.2), s), nullptr,
                           pose0.data(), pose1.data());
  problem.AddResidualBlock(CreatePose2PriorCost(Pose2(1.0, 0.0, 0.0), s), nullptr, pose1.data());
  problem.SetParameterBlockConstant(pose0.data());
  SolveOrDie(&problem);
  ExpectPoseNear(Pose2(1.1, 0.0, 0.1), pose1, 1e-6, 1e-6);
}

}  // namespace
}  // namespace hetslam
