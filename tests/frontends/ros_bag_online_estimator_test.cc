// A ROS 1 bag, read by the core reader, maps through the online estimator: the synthetic bag
// of tests/core/ros_bag_test_util.h (known motion, an IMU mounted tilted on a level robot) and,
// when the shared datasets are present, the real ccny demo recording.
#include <algorithm>
#include <string>
#include <vector>

#include "core/measurement_log.h"
#include "frontends/online_estimator.h"
#include "gtest/gtest.h"
#include "tests/core/ros_bag_test_util.h"
#include "tests/test_data.h"

namespace hetslam {
namespace {

using namespace testing_bag;  // NOLINT: the synthetic bag's constants

struct Mapped {
  std::vector<StampedPose2> trajectory;
  OnlineEstimatorStats stats;
  std::vector<double> scores;
};

Mapped MapLog(const MeasurementLog& log, const OnlineEstimatorOptions& options) {
  OnlineEstimator estimator(options);
  for (const Measurement& m : log.measurements) {
    const Status status = estimator.Add(m);
    EXPECT_TRUE(status.ok()) << status.message();
  }
  estimator.Finish();
  return {estimator.Trajectory(), estimator.stats(), estimator.match_scores()};
}

// Every scan's pose relative to the first against the synthetic bag's true arc: within one grid
// cell (5 cm) and `yaw_tolerance` radians.
void ExpectOnTheTrueArc(const Mapped& mapped, int num_scans, double yaw_tolerance) {
  ASSERT_EQ(num_scans, static_cast<int>(mapped.trajectory.size()));
  const Pose2 first = mapped.trajectory.front().pose;
  for (int k = 0; k < num_scans; ++k) {
    const Pose2 estimated = Between(first, mapped.trajectory[k].pose);
    const Pose2 truth = TrueBodyPose(k * kScanPeriod);
    EXPECT_NEAR(0.0, (estimated.translation() - truth.translation()).norm(), 0.05) << "scan " << k;
    EXPECT_NEAR(0.0, WrapAngle(estimated.theta() - truth.theta()), yaw_tolerance) << "scan " << k;
  }
}

// The IMU's samples reach the MARG filter rotated into base_link, so the level robot is seen
// level: no scan point is taken for the floor, every scan has an attitude, and the trajectory
// (predicted from the bag's Twist commands through the EKF) follows the true arc.
TEST(RosBagOnlineEstimatorTest, SyntheticBagWithTiltedImuMapsAlongTheTrueArc) {
  const std::string path = ::testing::TempDir() + "/ros_bag_online_estimator_test.bag";
  SyntheticBagOptions bag_options;
  bag_options.num_scans = 30;
  WriteSyntheticBag(path, bag_options);
  MeasurementLog log;
  const Status read = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_TRUE(read.ok()) << read.message();

  const Mapped mapped = MapLog(log, OnlineEstimatorOptions());
  EXPECT_EQ(bag_options.num_scans, mapped.stats.scans);
  EXPECT_EQ(0, mapped.stats.match_failures);
  EXPECT_EQ(0, mapped.stats.scans_without_attitude);
  EXPECT_EQ(0, mapped.stats.floor_points);
  EXPECT_EQ(0, mapped.stats.marg_errors);
  EXPECT_GT(mapped.stats.marg_samples, 200);
  ASSERT_EQ(bag_options.num_scans, static_cast<int>(mapped.trajectory.size()));
  // The estimate starts at the origin: compare motion relative to the first pose. Tolerance:
  // one grid cell (5 cm) and 0.01 rad; the second scan, matched against a map of one scan of a
  // bare room, lands 1.7 cm off and later scans carry that offset (measured: 3.3 cm at the end).
  ExpectOnTheTrueArc(mapped, bag_options.num_scans, 0.01);
}

// A tilting platform: the body rolled 0.08 rad and pitched -0.1 rad, so its level-mounted laser
// sees the walls farther away and the floor behind. The bag's IMU gives the MARG filter that
// attitude: every scan is projected with it, the floor hits behind the robot are dropped (read
// without the IMU, the same scans keep them as structure) and the arc is recovered.
TEST(RosBagOnlineEstimatorTest, TiltedPlatformIsProjectedWithTheImuAttitude) {
  const std::string path = ::testing::TempDir() + "/ros_bag_online_estimator_test_tilted.bag";
  SyntheticBagOptions bag_options;
  bag_options.num_scans = 30;
  bag_options.body_roll_radians = 0.08;
  bag_options.body_pitch_radians = -0.1;
  WriteSyntheticBag(path, bag_options);
  MeasurementLog log;
  const Status read = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_TRUE(read.ok()) << read.message();

  const Mapped mapped = MapLog(log, OnlineEstimatorOptions());
  EXPECT_EQ(bag_options.num_scans, mapped.stats.scans);
  EXPECT_EQ(0, mapped.stats.match_failures);
  EXPECT_EQ(0, mapped.stats.scans_without_attitude);
  EXPECT_GT(mapped.stats.floor_points, 0);
  ASSERT_EQ(bag_options.num_scans, static_cast<int>(mapped.trajectory.size()));
  // Tolerance: one grid cell and 0.015 rad. Measured: 3.0 cm and 0.0106 rad at worst, reached
  // over the first 1.2 s while the MARG filter's roll and pitch settle, then carried. (In this
  // box room the tilted scans also match without any attitude, 1.4 cm / 0.0074 rad: a tilted
  // cut through vertical walls is still a consistent rectangle. What the IMU changes here is
  // the projection: floor hits dropped, walls at their true distance.)
  ExpectOnTheTrueArc(mapped, bag_options.num_scans, 0.015);

  MeasurementLogOptions without_imu;
  without_imu.ros_bag.imu_topic = "none";
  MeasurementLog level;
  ASSERT_TRUE(ReadMeasurementLog(path, without_imu, &level).ok());
  const Mapped unprojected = MapLog(level, OnlineEstimatorOptions());
  EXPECT_EQ(0, unprojected.stats.floor_points);
}

// The real Hokuyo recording (no odometry, no IMU) maps with every scan matched well.
TEST(RosBagOnlineEstimatorTest, CcnyDemoBagMapsOdometryFree) {
  const std::string path = SharedDatasetPath("ccny-scan-tools-demo/laser_scan_matcher_demo.bag");
  if (path.empty()) GTEST_SKIP() << "shared datasets not found at " << SharedDatasetDir();
  MeasurementLog log;
  const Status read = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_TRUE(read.ok()) << read.message();
  const Mapped mapped = MapLog(log, OnlineEstimatorOptions());
  EXPECT_EQ(360, mapped.stats.scans);
  EXPECT_EQ(0, mapped.stats.match_failures);
  ASSERT_FALSE(mapped.scores.empty());
  std::vector<double> scores = mapped.scores;
  std::sort(scores.begin(), scores.end());
  // Mean likelihood at the matched pose (1 = every point on a mapped wall); a scan-to-map
  // misalignment of a few cm in the 5 cm / sigma 10 cm field shows as scores well below this.
  EXPECT_GT(scores[scores.size() / 10], 0.7);
}

}  // namespace
}  // namespace hetslam
