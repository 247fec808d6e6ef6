// Tests of the compressed cost (factors/compressed_cost.h): at seeded random points the k + 1
// residuals and their Jacobian give the tall cost's r^T r, J^T r and J^T J; a singular J^T J
// (a parameter the residuals do not depend on) stays finite; a solve over the compressed cost
// takes the tall one's steps (same iterations, same minimum), also through a manifold and with
// a scan cost; a non-finite residual is handed on for Ceres to reject.
#include "factors/compressed_cost.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "Eigen/Core"
#include "ceres/ceres.h"
#include "core/laser_map.h"
#include "factors/scan_cost.h"
#include "factors/se2_manifold.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

// N residuals over one block of K parameters:
//   r_i = y_i - sum_k sin((k + 1) p_k t_i + k) - (p_0 t_i)^2 / 10,
// nonlinear in every parameter (and in p_0 twice). With `ignore_last`, p_{K-1} does not enter
// (nor, for K = 1, the square): its Jacobian column is zero and J^T J is singular.
template <int K>
struct SinesResidual {
  SinesResidual(std::vector<double> t, std::vector<double> y, bool ignore_last)
      : t_(std::move(t)), y_(std::move(y)), ignore_last_(ignore_last) {}
  template <typename T>
  bool operator()(const T* p, T* residuals) const {
    for (size_t i = 0; i < t_.size(); ++i) {
      T sum = T(0.0);
      for (int k = 0; k < K; ++k) {
        if (ignore_last_ && k == K - 1) continue;
        sum += sin(double(k + 1) * p[k] * t_[i] + double(k));
      }
      if (!(ignore_last_ && K == 1)) sum += (p[0] * t_[i]) * (p[0] * t_[i]) / 10.0;
      residuals[i] = y_[i] - sum;
    }
    return true;
  }
  const std::vector<double> t_;  // abscissae
  const std::vector<double> y_;  // observations
  const bool ignore_last_;
};

// A tall cost of `n` residuals from seeded data (observations of the model at parameters 0.3 k
// plus noise).
template <int K>
ceres::CostFunction* MakeSines(int n, uint32_t seed, bool ignore_last = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> t_dist(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<double> t(n), y(n);
  for (int i = 0; i < n; ++i) {
    t[i] = t_dist(rng);
    double sum = 0.0;
    for (int k = 0; k < K; ++k) {
      if (ignore_last && k == K - 1) continue;
      sum += std::sin((k + 1) * 0.3 * k * t[i] + k);
    }
    y[i] = sum + noise(rng);  // (p_0 t)^2 / 10 is 0 at p_0 = 0
  }
  return new ceres::AutoDiffCostFunction<SinesResidual<K>, ceres::DYNAMIC, K>(
      new SinesResidual<K>(t, y, ignore_last), n);
}

// r^T r, J^T r and J^T J of `cost` at `x` (one block of k parameters).
struct NormalEquations {
  double rtr = 0.0;
  Eigen::VectorXd g;
  Eigen::MatrixXd h;
};
NormalEquations Evaluate(const ceres::CostFunction& cost, const std::vector<double>& x) {
  const int n = cost.num_residuals();
  const int k = cost.parameter_block_sizes()[0];
  std::vector<double> r(n), j(static_cast<size_t>(n) * k);
  const double* parameters[1] = {x.data()};
  double* jacobians[1] = {j.data()};
  EXPECT_TRUE(cost.Evaluate(parameters, r.data(), jacobians));
  const Eigen::Map<const Eigen::VectorXd> rv(r.data(), n);
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jm(j.data(), n, k);
  return {rv.squaredNorm(), jm.transpose() * rv, jm.transpose() * jm};
}

template <int K>
void ExpectSameNormalEquations(uint32_t seed, bool ignore_last) {
  std::unique_ptr<ceres::CostFunction> tall(MakeSines<K>(200, seed, ignore_last));
  std::unique_ptr<ceres::CostFunction> compressed(CreateCompressedCost(MakeSines<K>(200, seed, ignore_last)));
  ASSERT_EQ(compressed->num_residuals(), K + 1);
  ASSERT_EQ(compressed->parameter_block_sizes().size(), 1u);
  ASSERT_EQ(compressed->parameter_block_sizes()[0], K);
  std::mt19937 rng(seed + 1000);
  std::uniform_real_distribution<double> x_dist(-2.0, 2.0);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> x(K);
    for (double& v : x) v = x_dist(rng);
    const NormalEquations a = Evaluate(*tall, x);
    const NormalEquations b = Evaluate(*compressed, x);
    const double scale = 1.0 + a.h.norm();
    EXPECT_NEAR(b.rtr, a.rtr, 1e-12 * (1.0 + a.rtr)) << "K " << K << " trial " << trial;
    EXPECT_LE((b.g - a.g).norm(), 1e-11 * (1.0 + a.g.norm()) * scale) << "K " << K << " trial " << trial;
    EXPECT_LE((b.h - a.h).norm(), 1e-12 * scale) << "K " << K << " trial " << trial;
    // Without a Jacobian only the cost is given: the same r^T r.
    std::vector<double> r(K + 1);
    const double* parameters[1] = {x.data()};
    ASSERT_TRUE(compressed->Evaluate(parameters, r.data(), nullptr));
    EXPECT_NEAR(Eigen::Map<const Eigen::VectorXd>(r.data(), K + 1).squaredNorm(), a.rtr, 1e-12 * (1.0 + a.rtr));
  }
}

TEST(CompressedCostTest, SameCostGradientAndHessianAtRandomPoints) {
  ExpectSameNormalEquations<1>(1, false);
  ExpectSameNormalEquations<2>(2, false);
  ExpectSameNormalEquations<3>(3, false);
  ExpectSameNormalEquations<4>(4, false);
  ExpectSameNormalEquations<5>(5, false);
  ExpectSameNormalEquations<6>(6, false);
}

TEST(CompressedCostTest, SingularHessianStaysFiniteAndExact) {
  ExpectSameNormalEquations<3>(7, true);
  ExpectSameNormalEquations<6>(8, true);
  // Every column zero: H = 0, g = 0, the whole cost in the last residual.
  std::unique_ptr<ceres::CostFunction> compressed(CreateCompressedCost(MakeSines<1>(50, 9, true)));
  const std::vector<double> x = {0.7};
  std::vector<double> r(2), j(2);
  const double* parameters[1] = {x.data()};
  double* jacobians[1] = {j.data()};
  ASSERT_TRUE(compressed->Evaluate(parameters, r.data(), jacobians));
  EXPECT_EQ(r[0], 0.0);
  EXPECT_GT(r[1], 0.0);
  EXPECT_EQ(j[0], 0.0);
  EXPECT_EQ(j[1], 0.0);
}

// Solves `cost` from `start` and returns the summary; `x` holds the minimum.
ceres::Solver::Summary Solve(ceres::CostFunction* cost, std::vector<double>* x, ceres::Manifold* manifold = nullptr) {
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, x->data());
  if (manifold != nullptr) problem.SetManifold(x->data(), manifold);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 50;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return summary;
}

TEST(CompressedCostTest, SolveTakesTheTallCostsSteps) {
  std::vector<double> tall_x = {0.2, -0.1, 0.5}, compressed_x = tall_x;
  const ceres::Solver::Summary tall = Solve(MakeSines<3>(300, 11), &tall_x);
  const ceres::Solver::Summary compressed = Solve(CreateCompressedCost(MakeSines<3>(300, 11)), &compressed_x);
  ASSERT_TRUE(tall.IsSolutionUsable()) << tall.FullReport();
  ASSERT_TRUE(compressed.IsSolutionUsable()) << compressed.FullReport();
  EXPECT_EQ(compressed.iterations.size(), tall.iterations.size()) << compressed.FullReport() << tall.FullReport();
  EXPECT_NEAR(compressed.final_cost, tall.final_cost, 1e-10 * (1.0 + tall.final_cost));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(compressed_x[k], tall_x[k], 1e-7) << "parameter " << k;
  for (size_t i = 0; i < std::min(tall.iterations.size(), compressed.iterations.size()); ++i) {
    EXPECT_NEAR(compressed.iterations[i].cost, tall.iterations[i].cost, 1e-10 * (1.0 + tall.iterations[i].cost))
        << "iteration " << i;
    EXPECT_EQ(compressed.iterations[i].step_is_successful, tall.iterations[i].step_is_successful) << "iteration " << i;
  }
}

// A scan of a square room matched from a displaced pose, on the SE(2) manifold: the pose the
// scan cost's refinement reaches, and its steps, are the same through the compressed cost.
TEST(CompressedCostTest, ScanRefinementOnTheManifoldIsTheSame) {
  OccupancyGridOptions grid_options;
  grid_options.resolution_meters = 0.05;
  LikelihoodFieldOptions field_options;
  LaserMap map(grid_options, field_options);
  std::vector<Eigen::Vector2f> hits;
  for (int i = -40; i < 40; ++i) {
    const float s = 0.05f * static_cast<float>(i) + 0.0125f;
    hits.push_back({2.0f, s});
    hits.push_back({-2.0f, s});
    hits.push_back({s, 1.5f});
    hits.push_back({s, -1.5f});
  }
  hits.push_back({1.0f, 1.0f});  // a post: the room's symmetry broken
  map.InsertScan(Pose2::Identity(), Eigen::Vector2d::Zero(), hits);
  for (const ScanCostInterpolation interpolation : {ScanCostInterpolation::kValues, ScanCostInterpolation::kDistances}) {
    std::vector<double> tall_x = {0.04, -0.03, 0.03}, compressed_x = tall_x;
    const ceres::Solver::Summary tall =
        Solve(CreateScanToLikelihoodFieldCost(map.field(), hits, {}, interpolation), &tall_x, new Se2Manifold);
    const ceres::Solver::Summary compressed =
        Solve(CreateCompressedCost(CreateScanToLikelihoodFieldCost(map.field(), hits, {}, interpolation)),
              &compressed_x, new Se2Manifold);
    ASSERT_TRUE(compressed.IsSolutionUsable()) << compressed.FullReport();
    EXPECT_EQ(compressed.iterations.size(), tall.iterations.size()) << compressed.FullReport() << tall.FullReport();
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(compressed_x[k], tall_x[k], 1e-7) << "parameter " << k;
    EXPECT_LT(std::hypot(compressed_x[0], compressed_x[1]), 0.01);
    EXPECT_LT(std::abs(compressed_x[2]), 0.005);
  }
}

TEST(CompressedCostTest, NonFiniteResidualIsHandedOn) {
  struct NanResidual {
    bool operator()(const double* p, double* r) const {
      r[0] = p[0];
      r[1] = std::numeric_limits<double>::quiet_NaN();
      r[2] = 1.0;
      return true;
    }
  };
  std::unique_ptr<ceres::CostFunction> compressed(
      CreateCompressedCost(new ceres::NumericDiffCostFunction<NanResidual, ceres::CENTRAL, 3, 2>(new NanResidual)));
  const std::vector<double> x = {0.5, 0.5};
  std::vector<double> r(3), j(6);
  const double* parameters[1] = {x.data()};
  double* jacobians[1] = {j.data()};
  ASSERT_TRUE(compressed->Evaluate(parameters, r.data(), jacobians));
  EXPECT_FALSE(std::isfinite(r[0] + r[1] + r[2]));
  ASSERT_TRUE(compressed->Evaluate(parameters, r.data(), nullptr));
  EXPECT_FALSE(std::isfinite(r[0]));
}

}  // namespace
}  // namespace hetslam
