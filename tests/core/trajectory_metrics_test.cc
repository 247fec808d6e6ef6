#include "core/trajectory_metrics.h"

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "gmock/gmock.h"
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

// The straight truth with every pose from `from` on shifted `shift` metres back along x (one
// step from from - 1 to from `shift` short), given in reverse time order.
std::vector<StampedPose2> OneShortStep(const std::vector<StampedPose2>& truth, int from, double shift) {
  std::vector<StampedPose2> estimate;
  for (int k = static_cast<int>(truth.size()) - 1; k >= 0; --k) {
    const double x = truth[k].pose.x() - (k >= from ? shift : 0.0);
    estimate.push_back({truth[k].stamp_seconds, Pose2(x, truth[k].pose.y(), truth[k].pose.theta())});
  }
  return estimate;
}

TEST(PoseErrorsTest, AShortStepIsFoundWhereItHappensAndTheAlignmentSharesItsShift) {
  const std::vector<StampedPose2> truth = StraightTruth(Pose2::Identity());
  const std::vector<PoseError> errors = ComputePoseErrors(OneShortStep(truth, 10, 0.3), truth);
  ASSERT_EQ(errors.size(), 21u);
  for (size_t i = 0; i < errors.size(); ++i) {
    EXPECT_DOUBLE_EQ(errors[i].stamp_seconds, 0.5 * i);  // in time order
    EXPECT_EQ(errors[i].has_step, i > 0);
    if (i == 0) continue;
    EXPECT_NEAR(errors[i].step_reference_meters, 0.5, 1e-12);
    EXPECT_NEAR(errors[i].step_rotation_degrees, 0.0, 1e-12);
    EXPECT_NEAR(errors[i].step_translation_meters, i == 10 ? 0.3 : 0.0, 1e-12) << i;
    EXPECT_NEAR(errors[i].step_along_meters, i == 10 ? -0.3 : 0.0, 1e-12) << i;
  }
  // All on one line: the alignment is a shift along x of 0.3 * 11 / 21 m (the mean offset),
  // leaving 0.3 * 11 / 21 before the short step and 0.3 * 10 / 21 from it on.
  EXPECT_NEAR(errors[0].translation_meters, 0.3 * 11 / 21, 1e-9);
  EXPECT_NEAR(errors[9].translation_meters, 0.3 * 11 / 21, 1e-9);
  EXPECT_NEAR(errors[10].translation_meters, 0.3 * 10 / 21, 1e-9);
  EXPECT_NEAR(errors[20].translation_meters, 0.3 * 10 / 21, 1e-9);
  EXPECT_THAT(LargestStepErrors(errors, 1), ::testing::ElementsAre(10u));
  EXPECT_EQ(LargestStepErrors(errors, 100).size(), 20u);  // every step, none for the first pose
  EXPECT_TRUE(LargestStepErrors(errors, 0).empty());
}

TEST(PoseErrorsTest, AStepIsBetweenMatchedPosesAndItsHeadingErrorIsSigned) {
  const std::vector<StampedPose2> truth = StraightTruth(Pose2(2.0, -1.0, 0.4));
  std::vector<StampedPose2> estimate;
  for (size_t k = 0; k < truth.size(); ++k) {
    // The heading 1 degree up from pose 4 on (a turn on the step to pose 4); pose 7 has no
    // truth within the tolerance (the step to pose 8 is from pose 6).
    const double yaw = k >= 4 ? 1.0 / kDegrees : 0.0;
    const double stamp = truth[k].stamp_seconds + (k == 7 ? 0.1 : 0.0);
    estimate.push_back({stamp, Pose2(0.5 * k, 0.0, yaw)});
  }
  const std::vector<PoseError> errors = ComputePoseErrors(estimate, truth);
  ASSERT_EQ(errors.size(), 20u);
  EXPECT_NEAR(errors[4].step_rotation_degrees, 1.0, 1e-9);
  EXPECT_NEAR(errors[5].step_rotation_degrees, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(errors[7].stamp_seconds, 4.0);  // pose 8
  EXPECT_NEAR(errors[7].step_reference_meters, 1.0, 1e-9);
  EXPECT_TRUE(ComputePoseErrors({}, truth).empty());
}

TEST(PoseErrorsTest, WrittenOneLineAPoseAfterAHeaderAndAnUnwritablePathIsAnErrorNamingIt) {
  const std::vector<StampedPose2> truth = StraightTruth(Pose2::Identity());
  const std::vector<PoseError> errors = ComputePoseErrors(OneShortStep(truth, 10, 0.3), truth);
  const std::string path = ::testing::TempDir() + "/trajectory_metrics_test_errors.txt";
  ASSERT_TRUE(WritePoseErrors(path, errors).ok());
  std::ifstream in(path);
  std::string line;
  int comments = 0, rows = 0;
  std::string row10;  // the short step's line
  while (std::getline(in, line)) {
    if (line.rfind("#", 0) == 0) {
      ++comments;
      continue;
    }
    if (rows == 10) row10 = line;
    ++rows;
  }
  EXPECT_GE(comments, 1);
  EXPECT_EQ(rows, 21);
  EXPECT_THAT(row10, ::testing::StartsWith("5.000000 "));
  EXPECT_THAT(row10, ::testing::HasSubstr(" 0.500000 0.300000 -0.300000 "));
  EXPECT_THAT(row10, ::testing::EndsWith(" 1"));
  const Status status = WritePoseErrors("/nonexistent-dir/errors.txt", errors);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), ::testing::HasSubstr("/nonexistent-dir/errors.txt"));
}

}  // namespace
}  // namespace hetslam
