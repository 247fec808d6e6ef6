#include "factors/se2_manifold.h"

#include <cmath>
#include <random>

#include "ceres/jet.h"
#include "ceres/manifold_test_utils.h"
#include "core/se2.h"
#include "factors/angle.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace {

// The matchers of EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD live in namespace ceres.
using ceres::HasCorrectMinusJacobianAt;
using ceres::HasCorrectPlusJacobianAt;
using ceres::HasCorrectRightMultiplyByPlusJacobianAt;
using ceres::MinusPlusIsIdentityAt;
using ceres::MinusPlusJacobianIsIdentityAt;
using ceres::PlusMinusIsIdentityAt;
using ceres::Vector;
using ceres::XMinusXIsZeroAt;
using ceres::XPlusZeroIsXAt;

constexpr double kTolerance = 1e-9;

TEST(WrapAngleJetTest, MatchesDoubleVersionAndPassesDerivativeThrough) {
  using Jet = ceres::Jet<double, 1>;
  for (const double a : {0.0, 0.5, -0.5, M_PI - 1e-9, M_PI, -M_PI, M_PI + 1e-9, 3.0 * M_PI + 0.2,
                         -7.0 * M_PI - 0.3, 100.0}) {
    const Jet wrapped = WrapAngle(Jet(a, 0));
    EXPECT_NEAR(WrapAngle(a), wrapped.a, 1e-12) << "angle " << a;
    EXPECT_GE(wrapped.a, -M_PI) << "angle " << a;
    EXPECT_LT(wrapped.a, M_PI) << "angle " << a;
    EXPECT_DOUBLE_EQ(1.0, wrapped.v[0]) << "angle " << a;
  }
  // Both ends of the half-open interval, as core/se2.h.
  EXPECT_DOUBLE_EQ(-M_PI, WrapAngle<double>(M_PI));
  EXPECT_DOUBLE_EQ(-M_PI, WrapAngle<double>(-M_PI));
}

TEST(WrapAngleJetTest, AgreesWithCoreAtSeededRandomAngles) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-50.0, 50.0);
  for (int i = 0; i < 1000; ++i) {
    const double a = angle(rng);
    const double w = WrapAngle<double>(a);
    EXPECT_GE(w, -M_PI);
    EXPECT_LT(w, M_PI);
    // Same angle modulo 2 pi, and the same value as the core helper.
    EXPECT_NEAR(0.0, std::remainder(w - a, 2.0 * M_PI), 1e-9);
    EXPECT_NEAR(WrapAngle(a), w, 1e-12);
  }
}

TEST(Se2ManifoldTest, PlusWrapsYawAcrossPi) {
  const Se2Manifold manifold;
  const double x[3] = {1.0, 2.0, 3.1};
  const double delta[3] = {0.5, -0.5, 0.1};
  double y[3];
  ASSERT_TRUE(manifold.Plus(x, delta, y));
  EXPECT_DOUBLE_EQ(1.5, y[0]);
  EXPECT_DOUBLE_EQ(1.5, y[1]);
  EXPECT_NEAR(3.2 - 2.0 * M_PI, y[2], 1e-12);
  // Minus returns the short way round: from yaw 3.1 to -3.1 is +0.0832 rad, not -6.2.
  const double a[3] = {0.0, 0.0, -3.1};
  double d[3];
  ASSERT_TRUE(manifold.Minus(a, x, d));
  EXPECT_NEAR(2.0 * M_PI - 6.2, d[2], 1e-12);
}

TEST(Se2ManifoldTest, InvariantsHoldAtSeededRandomPoints) {
  const Se2Manifold manifold;
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> xy(-100.0, 100.0);
  // Keep x's yaw 0.01 rad off the branch cut: the numerical Plus Jacobian of the matcher steps
  // up to 1e-4 rad and would straddle the 2 pi jump of the ambient yaw.
  std::uniform_real_distribution<double> yaw(-M_PI + 0.01, M_PI - 0.01);
  std::uniform_real_distribution<double> small(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Vector x(3), delta(3), y(3);
    x << xy(rng), xy(rng), yaw(rng);
    delta << small(rng), small(rng), small(rng);
    y << xy(rng), xy(rng), yaw(rng);
    EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD(manifold, x, delta, y, kTolerance);
  }
}

TEST(Se2ManifoldTest, InvariantsHoldNearPlusMinusPi) {
  const Se2Manifold manifold;
  for (const double yaw_x : {M_PI - 0.01, -M_PI + 0.01}) {
    for (const double yaw_y : {M_PI - 1e-6, -M_PI + 1e-6}) {
      Vector x(3), delta(3), y(3);
      x << 1.0, -2.0, yaw_x;
      // delta crosses the cut from x's side.
      delta << 0.1, 0.2, yaw_x > 0 ? 0.5 : -0.5;
      y << -3.0, 4.0, yaw_y;
      EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD(manifold, x, delta, y, kTolerance);
    }
  }
}

// Held along (1, 1)/sqrt(2): Plus moves along (-1, 1)/sqrt(2) and the yaw only, and Minus drops
// what lies along the held direction.
TEST(Se2HeldDirectionManifoldTest, MovesAcrossTheHeldDirectionOnly) {
  const Se2HeldDirectionManifold manifold(Eigen::Vector2d(2.0, 2.0));  // normalised inside
  EXPECT_EQ(3, manifold.AmbientSize());
  EXPECT_EQ(2, manifold.TangentSize());
  const double x[3] = {1.0, 2.0, 0.5};
  const double delta[2] = {std::sqrt(2.0), 0.25};
  double y[3];
  ASSERT_TRUE(manifold.Plus(x, delta, y));
  EXPECT_NEAR(0.0, y[0], 1e-12);
  EXPECT_NEAR(3.0, y[1], 1e-12);
  EXPECT_NEAR(0.75, y[2], 1e-12);
  // (1, 1) along the held direction is dropped, (-1, 1) across it is kept.
  const double z[3] = {1.0 + 1.0 - 1.0, 2.0 + 1.0 + 1.0, 0.4};
  double d[2];
  ASSERT_TRUE(manifold.Minus(z, x, d));
  EXPECT_NEAR(std::sqrt(2.0), d[0], 1e-12);
  EXPECT_NEAR(-0.1, d[1], 1e-12);
}

TEST(Se2HeldDirectionManifoldTest, InvariantsHoldAtSeededRandomPoints) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-100.0, 100.0);
  std::uniform_real_distribution<double> yaw(-M_PI + 0.01, M_PI - 0.01);
  std::uniform_real_distribution<double> small(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Se2HeldDirectionManifold manifold(Eigen::Vector2d(small(rng), small(rng)) + Eigen::Vector2d(0.0, 1.5));
    Vector x(3), delta(2), y(3);
    x << xy(rng), xy(rng), yaw(rng);
    delta << small(rng), small(rng);
    // y on x's manifold leaf (along the held direction nothing moves): Plus(x, Minus(y, x)) == y.
    const Eigen::Vector2d free = manifold.free_direction();
    const double across = xy(rng);
    y << x(0) + across * free.x(), x(1) + across * free.y(), yaw(rng);
    EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD(manifold, x, delta, y, 1e-8);
  }
}

}  // namespace
}  // namespace hetslam
