#include "core/robot_log_writer.h"

#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/robot_log_test_util.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

// The round trip through the reader is tested in robot_log_test.cc.

TEST(RobotLogWriterTest, MergesByStampWithTheDocumentedTieOrder) {
  RobotLog log;
  const double t = 1.5;
  LaserReading laser;
  laser.scan.stamp_seconds = t;
  laser.scan.angles_radians = EvenlySpacedAngles(2, 0.0, 0.5);
  laser.scan.ranges_meters = {1.0, 2.0};
  log.lasers.push_back(laser);
  log.images.push_back({t, "a.png", 0});
  log.truth.push_back({t, Eigen::Isometry3d::Identity(), 0});
  log.commands.push_back({t, 0.1, 0.0, 0.0, 0});
  log.altitudes.push_back({t, 1.0, 0});
  log.attitudes.push_back({t, 0.0, 0.0, 0.0, 0});
  log.marg.push_back(MargSample{t});
  log.odometry.push_back({t, Pose2(), 0});
  log.mounts.push_back({t, Eigen::Isometry3d::Identity(), 0});
  // An earlier ODOM and a later MARG, to see the merge across types.
  log.odometry.insert(log.odometry.begin(), OdometryReading{0.5, Pose2(1, 0, 0), 0});
  log.marg.push_back(MargSample{2.0});
  log.params["robot_name"] = "r";
  log.params["a_first"] = "x";
  const std::string path = TempPath("order.txt");
  const Status status = WriteRobotLog(path, log, {"comment"});
  ASSERT_TRUE(status.ok()) << status.message();
  std::vector<std::string> types;
  std::istringstream lines(ReadText(path));
  std::string line;
  while (std::getline(lines, line)) types.push_back(line.substr(0, line.find(' ')));
  const std::vector<std::string> expected = {
      "HSLOG", "#",        "PARAM",    "PARAM",   "ODOM",  "MOUNT", "ODOM",
      "MARG",  "ATTITUDE", "ALTITUDE", "COMMAND", "TRUTH", "LASER", "IMAGE", "MARG"};
  EXPECT_EQ(expected, types);
  // PARAMs sorted by name.
  EXPECT_THAT(ReadText(path), HasSubstr("PARAM a_first x\nPARAM robot_name r\n"));
}

TEST(RobotLogWriterTest, RejectsWhatTheFormatCannotStore) {
  const std::string path = TempPath("rejected.txt");
  {
    RobotLog log;
    LaserReading laser;
    laser.scan.angles_radians = {0.0, 0.1, 0.3};
    laser.scan.ranges_meters = {1, 2, 3};
    log.lasers.push_back(laser);
    EXPECT_THAT(WriteRobotLog(path, log, {}).message(), HasSubstr("evenly spaced"));
  }
  {
    RobotLog log;
    LaserReading laser;
    laser.scan.angles_radians = {0.0, 0.1};
    laser.scan.ranges_meters = {1};
    log.lasers.push_back(laser);
    EXPECT_THAT(WriteRobotLog(path, log, {}).message(), HasSubstr("2 angles but 1 ranges"));
  }
  {
    // A scan whose mount is not in a MOUNT message would lose it.
    RobotLog log;
    LaserReading laser;
    laser.scan.stamp_seconds = 1.0;
    laser.scan.robot_T_sensor.translation().z() = 0.3;
    log.lasers.push_back(laser);
    EXPECT_THAT(WriteRobotLog(path, log, {}).message(), HasSubstr("MOUNT in force"));
    log.mounts.push_back({1.0, laser.scan.robot_T_sensor, 0});  // same stamp: comes first
    EXPECT_TRUE(WriteRobotLog(path, log, {}).ok());
  }
  {
    RobotLog log;
    log.marg.push_back(MargSample{std::numeric_limits<double>::quiet_NaN()});
    EXPECT_THAT(WriteRobotLog(path, log, {}).message(), HasSubstr("MARG 0"));
  }
  {
    RobotLog log;
    log.images.push_back({0.0, "has space.png", 0});
    EXPECT_THAT(WriteRobotLog(path, log, {}).message(), HasSubstr("IMAGE 0"));
  }
  {
    RobotLog log;
    log.params["name"] = "two  spaces";
    EXPECT_THAT(WriteRobotLog(path, log, {}).message(), HasSubstr("PARAM 'name'"));
  }
  {
    RobotLog log;
    StampedPose3 bad;
    bad.pose.linear() *= 2.0;
    log.truth.push_back(bad);
    EXPECT_THAT(WriteRobotLog(path, log, {}).message(), HasSubstr("not a rigid pose"));
  }
  EXPECT_THAT(WriteRobotLog(::testing::TempDir() + "/no_such_dir/log.txt", RobotLog(), {})
                  .message(),
              HasSubstr("cannot open"));
}

}  // namespace
}  // namespace hetslam
