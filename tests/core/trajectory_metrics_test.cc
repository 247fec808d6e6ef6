#include "core/trajectory_metrics.h"

#include <cmath>
#include <vector>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

constexpr double kDegrees = 180.0 / M_PI;

// A truth path: a straight 10 m leg along x at 1 m/s, poses every 0.5 s, starting at `start`.
std::vector<StampedPose2> StraightTruth(const Pose2& start) {
  std::vector<StampedPose2> truth;
  for (int k = 0; k <= 20; ++k) truth.push_back({0.5 * k, start * Pose2(0.5 * k, 0.0, 0.0)});
  return truth;
}

TEST(StartFrameDriftTest, AnEstimateInAnotherFrameWithoutErrorHasNoDrift) {
  // The estimate starts at the origin, the truth somewhere else: the frames differ, the paths
  // do not.
  const std::vector<StampedPose2> truth = StraightTruth(Pose2(3.0, -2.0, 0.7));
  const std::vector<StampedPose2> estimate = StraightTruth(Pose2::Identity());
  const StartFrameDrift drift = ComputeStartFrameDrift(estimate, truth);
  EXPECT_EQ(drift.matched, 21);
  EXPECT_NEAR(drift.final_translation_meters, 0.0, 1e-12);
  EXPECT_NEAR(drift.final_rotation_degrees, 0.0, 1e-12);
  EXPECT_NEAR(drift.max_translation_meters, 0.0, 1e-12);
  EXPECT_NEAR(drift.max_rotation_degrees, 0.0, 1e-12);
}

TEST(StartFrameDriftTest, AHeadingErrorAtTheStartTurnsTheWholePathAndTheAteHidesIt) {
  // The estimate turned 1 degree on its first step and kept that heading: after 10 m it is
  // 10 sin(1 deg) = 0.1745 m off its start frame's truth, 1 degree throughout.
  const double error = 1.0 / kDegrees;
  const std::vector<StampedPose2> truth = StraightTruth(Pose2::Identity());
  std::vector<StampedPose2> estimate = StraightTruth(Pose2(0.0, 0.0, error));
  estimate.front().pose = Pose2::Identity();  // the start pose itself is the frame
  const StartFrameDrift drift = ComputeStartFrameDrift(estimate, truth);
  EXPECT_NEAR(drift.final_rotation_degrees, 1.0, 1e-9);
  EXPECT_NEAR(drift.max_rotation_degrees, 1.0, 1e-9);
  // The error grows with the distance: largest at the end (t = 10 s), 2 * 10 * sin(0.5 deg).
  EXPECT_NEAR(drift.final_translation_meters, 2.0 * 10.0 * std::sin(0.5 * error), 1e-9);
  EXPECT_DOUBLE_EQ(drift.max_translation_meters, drift.final_translation_meters);
  EXPECT_DOUBLE_EQ(drift.max_translation_stamp_seconds, 10.0);
  // The aligned error is a small fraction of it: a turned straight line aligns onto the truth.
  const AbsoluteTrajectoryError ate = ComputeAbsoluteTrajectoryError(estimate, truth);
  EXPECT_LT(ate.translation_rmse_meters, 0.1 * drift.final_translation_meters);
}

TEST(StartFrameDriftTest, ReportsTheLargestErrorAndWhenEvenWhenItShrinksAgain) {
  // A heading error that grows to -2 degrees at t = 5 s and is corrected by the end (a loop
  // closure), given out of time order: the start is the earliest matched pose.
  const std::vector<StampedPose2> truth = StraightTruth(Pose2(1.0, 1.0, 0.0));
  std::vector<StampedPose2> estimate;
  for (const StampedPose2& t : truth) {
    const double yaw = -2.0 / kDegrees * std::max(0.0, 1.0 - std::abs(t.stamp_seconds - 5.0) / 5.0);
    estimate.push_back({t.stamp_seconds, Pose2(t.pose.x() - 1.0, t.pose.y() - 1.0, yaw)});
  }
  std::swap(estimate.front(), estimate.back());
  const StartFrameDrift drift = ComputeStartFrameDrift(estimate, truth);
  EXPECT_EQ(drift.matched, 21);
  EXPECT_NEAR(drift.max_rotation_degrees, 2.0, 1e-9);
  EXPECT_DOUBLE_EQ(drift.max_rotation_stamp_seconds, 5.0);
  EXPECT_NEAR(drift.final_rotation_degrees, 0.0, 1e-9);  // signed, at t = 10 s
  EXPECT_NEAR(drift.final_translation_meters, 0.0, 1e-9);
}

TEST(StartFrameDriftTest, OnlyPosesWithATruthPoseAtTheirStampCount) {
  const std::vector<StampedPose2> truth = StraightTruth(Pose2::Identity());
  // Stamps between the truth's (0.25 s off): none matched within the default 1 ms.
  std::vector<StampedPose2> estimate;
  for (const StampedPose2& t : truth) estimate.push_back({t.stamp_seconds + 0.25, t.pose});
  EXPECT_EQ(ComputeStartFrameDrift(estimate, truth).matched, 0);
  EXPECT_EQ(ComputeStartFrameDrift(estimate, truth, 0.25).matched, 21);
  EXPECT_EQ(ComputeStartFrameDrift({}, truth).matched, 0);
}

}  // namespace
}  // namespace hetslam
