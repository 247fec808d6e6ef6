#include "core/robot_log.h"

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/robot_log_writer.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/core/robot_log_test_util.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

Status Read(const std::string& path, RobotLog* log, bool lenient = false) {
  RobotLogReadOptions options;
  options.lenient = lenient;
  return ReadRobotLog(path, options, log);
}

double Uniform(std::mt19937_64* rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>((*rng)() >> 11) * (1.0 / 9007199254740992.0);
}

// ---------------------------------------------------------------------------------------------
// Robot log: round trip.

LaserScan MakeScan(double stamp, int n, const Eigen::Isometry3d& mount, std::mt19937_64* rng) {
  LaserScan scan;
  scan.stamp_seconds = stamp;
  scan.angles_radians = EvenlySpacedAngles(n, -2.35619449019234492885, 0.0043633231299858239);
  scan.range_min_meters = 0.1;
  scan.range_max_meters = 29.7;
  scan.robot_T_sensor = mount;
  for (int i = 0; i < n; ++i) scan.ranges_meters.push_back(Uniform(rng, 0.2, 25.0));
  return scan;
}

// A log with every message type, random values, a MOUNT change between scans and stamps
// shared by several types.
RobotLog MakeFullLog() {
  std::mt19937_64 rng(3);
  RobotLog log;
  log.params["robot_name"] = "ugv1";
  log.params["robot_kind"] = "wheeled";
  log.params["camera_fx"] = "525";
  log.params["camera_fy"] = "525.5";
  log.params["camera_cx"] = "319.5";
  log.params["camera_cy"] = "239.5";
  log.params["camera_width"] = "640";
  log.params["camera_height"] = "480";
  log.params["laser_T_camera"] = "0.05 0 -0.1 -1.5707963267948966 0 -1.5707963267948966";
  const Eigen::Isometry3d mount0 = MakePose(0.2, 0.0, 0.3, 0.0, 0.0, 0.0);
  const Eigen::Isometry3d mount1 = MakePose(0.1, 0.01, 1.5, 0.01, -0.2, 0.3);
  log.mounts.push_back({0.0, mount0, 0});
  log.mounts.push_back({0.25, mount1, 0});
  for (int k = 0; k < 4; ++k) {
    const double t = 0.1 * (k + 1) + 1.0 / 3.0;
    LaserReading laser;
    laser.scan = MakeScan(t, 1081, t < 0.25 ? mount0 : mount1, &rng);
    if (k == 1) {
      laser.scan.ranges_meters[5] = std::numeric_limits<double>::quiet_NaN();
      laser.scan.ranges_meters[6] = 29.7;  // >= max: no return, kept as read
    }
    log.lasers.push_back(laser);
    StampedPose3 truth;
    truth.stamp_seconds = t;
    truth.pose = MakePose(Uniform(&rng, -10, 10), Uniform(&rng, -10, 10), Uniform(&rng, 0, 2),
                          Uniform(&rng, -0.3, 0.3), Uniform(&rng, -0.3, 0.3),
                          Uniform(&rng, -3, 3));
    log.truth.push_back(truth);
    CameraImage image;
    image.stamp_seconds = t;
    image.path = "images/" + std::to_string(k) + ".png";
    log.images.push_back(image);
  }
  for (int k = 0; k < 20; ++k) {
    const double t = 0.025 * k;
    MargSample marg;
    marg.stamp_seconds = t;
    marg.gyro_radps = Eigen::Vector3d(Uniform(&rng, -1, 1), Uniform(&rng, -1, 1), 1e-300);
    marg.accel_mps2 = Eigen::Vector3d(Uniform(&rng, -1, 1), -0.0, 9.80665);
    marg.magnetometer = Eigen::Vector3d(22.5, Uniform(&rng, -5, 5), -43.1);
    log.marg.push_back(marg);
    AttitudeReading attitude;
    attitude.stamp_seconds = t;
    attitude.roll_radians = Uniform(&rng, -0.1, 0.1);
    attitude.pitch_radians = Uniform(&rng, -0.1, 0.1);
    attitude.yaw_radians = Uniform(&rng, -M_PI, M_PI);
    log.attitudes.push_back(attitude);
    AltitudeReading altitude;
    altitude.stamp_seconds = t;
    altitude.height_meters = Uniform(&rng, 0.5, 2.0);
    log.altitudes.push_back(altitude);
    OdometryReading odom;
    odom.stamp_seconds = t;
    odom.pose = Pose2(Uniform(&rng, -5, 5), Uniform(&rng, -5, 5), Uniform(&rng, -3, 3));
    log.odometry.push_back(odom);
    VelocityCommand command;
    command.stamp_seconds = t;
    command.forward_mps = Uniform(&rng, 0, 1);
    command.left_mps = 0.0;
    command.yaw_rate_radps = Uniform(&rng, -1, 1);
    log.commands.push_back(command);
  }
  return log;
}

TEST(RobotLogTest, WriteThenReadGivesTheSameValues) {
  const RobotLog original = MakeFullLog();
  const std::string path = TempPath("roundtrip.txt");
  const Status write = WriteRobotLog(path, original, {"simulated", "two\nlines"});
  ASSERT_TRUE(write.ok()) << write.message();
  RobotLog log;
  const Status read = Read(path, &log);
  ASSERT_TRUE(read.ok()) << read.message();
  EXPECT_EQ(1, log.version);
  EXPECT_EQ(path, log.path);
  EXPECT_EQ(original.params, log.params);
  EXPECT_EQ(3, log.stats.comment_lines);
  EXPECT_EQ(0, log.stats.malformed_lines_skipped);
  EXPECT_EQ(1, log.stats.non_finite_ranges);
  EXPECT_TRUE(log.warnings.empty()) << log.warnings[0];
  EXPECT_EQ(4, log.stats.message_counts["LASER"]);
  EXPECT_EQ(20, log.stats.message_counts["MARG"]);
  EXPECT_EQ(9, log.stats.message_counts["PARAM"]);

  ASSERT_EQ(original.lasers.size(), log.lasers.size());
  for (size_t k = 0; k < log.lasers.size(); ++k) {
    const LaserScan& a = original.lasers[k].scan;
    const LaserScan& b = log.lasers[k].scan;
    EXPECT_EQ(a.stamp_seconds, b.stamp_seconds);
    EXPECT_EQ(a.angles_radians, b.angles_radians);  // exact: same first angle and increment
    EXPECT_EQ(a.range_min_meters, b.range_min_meters);
    EXPECT_EQ(a.range_max_meters, b.range_max_meters);
    ASSERT_EQ(a.ranges_meters.size(), b.ranges_meters.size());
    for (size_t i = 0; i < a.ranges_meters.size(); ++i) {
      if (std::isnan(a.ranges_meters[i])) {
        EXPECT_TRUE(std::isnan(b.ranges_meters[i]));
      } else {
        EXPECT_EQ(a.ranges_meters[i], b.ranges_meters[i]) << k << " " << i;
      }
    }
    // The mount in force, rebuilt from the MOUNT lines.
    ExpectSamePose(a.robot_T_sensor, b.robot_T_sensor);
  }
  EXPECT_EQ(log.lasers[1].scan.NumValidBeams(), 1081 - 2);
  ASSERT_EQ(2u, log.mounts.size());
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(original.mounts[k].stamp_seconds, log.mounts[k].stamp_seconds);
    ExpectSamePose(original.mounts[k].pose, log.mounts[k].pose);
  }
  ASSERT_EQ(original.truth.size(), log.truth.size());
  for (size_t k = 0; k < log.truth.size(); ++k) {
    EXPECT_EQ(original.truth[k].stamp_seconds, log.truth[k].stamp_seconds);
    ExpectSamePose(original.truth[k].pose, log.truth[k].pose);
    EXPECT_EQ(original.images[k].stamp_seconds, log.images[k].stamp_seconds);
    EXPECT_EQ(original.images[k].path, log.images[k].path);
  }
  ASSERT_EQ(20u, log.marg.size());
  ASSERT_EQ(20u, log.attitudes.size());
  ASSERT_EQ(20u, log.altitudes.size());
  ASSERT_EQ(20u, log.odometry.size());
  ASSERT_EQ(20u, log.commands.size());
  for (size_t k = 0; k < 20; ++k) {
    EXPECT_EQ(original.marg[k].stamp_seconds, log.marg[k].stamp_seconds);
    EXPECT_EQ(original.marg[k].gyro_radps, log.marg[k].gyro_radps);
    EXPECT_EQ(original.marg[k].accel_mps2, log.marg[k].accel_mps2);
    EXPECT_EQ(original.marg[k].magnetometer, log.marg[k].magnetometer);
    EXPECT_EQ(original.attitudes[k].roll_radians, log.attitudes[k].roll_radians);
    EXPECT_EQ(original.attitudes[k].pitch_radians, log.attitudes[k].pitch_radians);
    EXPECT_EQ(original.attitudes[k].yaw_radians, log.attitudes[k].yaw_radians);
    EXPECT_EQ(original.altitudes[k].height_meters, log.altitudes[k].height_meters);
    EXPECT_EQ(original.odometry[k].pose.x(), log.odometry[k].pose.x());
    EXPECT_EQ(original.odometry[k].pose.y(), log.odometry[k].pose.y());
    // Pose2 wraps theta again on construction, which may move the last bit.
    EXPECT_NEAR(original.odometry[k].pose.theta(), log.odometry[k].pose.theta(), 1e-15);
    EXPECT_EQ(original.commands[k].forward_mps, log.commands[k].forward_mps);
    EXPECT_EQ(original.commands[k].left_mps, log.commands[k].left_mps);
    EXPECT_EQ(original.commands[k].yaw_rate_radps, log.commands[k].yaw_rate_radps);
  }
  // Line numbers point into the written file.
  EXPECT_GT(log.lasers[0].line_number, 1);

  // The same log gives the same bytes.
  const std::string again = TempPath("roundtrip_again.txt");
  ASSERT_TRUE(WriteRobotLog(again, original, {"simulated", "two\nlines"}).ok());
  EXPECT_EQ(ReadText(path), ReadText(again));
  // Writing what was read gives a log that reads back to the same scans and stamps.
  const std::string rewritten = TempPath("roundtrip_rewritten.txt");
  ASSERT_TRUE(WriteRobotLog(rewritten, log, {}).ok());
  RobotLog log2;
  ASSERT_TRUE(Read(rewritten, &log2).ok());
  ASSERT_EQ(log.lasers.size(), log2.lasers.size());
  EXPECT_EQ(log.lasers[3].scan.angles_radians, log2.lasers[3].scan.angles_radians);
  EXPECT_EQ(log.lasers[3].scan.ranges_meters, log2.lasers[3].scan.ranges_meters);
}

TEST(RobotLogTest, MountAppliesToTheScansAfterIt) {
  const std::string path = WriteText(
      "mount.txt",
      "HSLOG 1\n"
      "LASER 0.0 1 0 0.1 0 10 1\n"
      "MOUNT 0.1 0.2 0 0.5 0 0 1.5707963267948966\n"
      "LASER 0.1 1 0 0.1 0 10 1\n"
      "LASER 0.2 1 0 0.1 0 10 1\n"
      "MOUNT 0.3 0 0 1.2 0 0.4 0\n"
      "LASER 0.3 1 0 0.1 0 10 1\n");
  RobotLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(4u, log.lasers.size());
  EXPECT_TRUE(log.lasers[0].scan.robot_T_sensor.isApprox(Eigen::Isometry3d::Identity()));
  for (int k : {1, 2}) {
    const Eigen::Isometry3d& m = log.lasers[k].scan.robot_T_sensor;
    EXPECT_EQ(Eigen::Vector3d(0.2, 0, 0.5), m.translation());
    // Yaw 90°: the laser's x axis is the body's y axis.
    EXPECT_LT((m.linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 1e-15);
  }
  const Eigen::Isometry3d& m3 = log.lasers[3].scan.robot_T_sensor;
  EXPECT_EQ(Eigen::Vector3d(0, 0, 1.2), m3.translation());
  EXPECT_NEAR(-std::sin(0.4), (m3.linear() * Eigen::Vector3d::UnitX()).z(), 1e-15);
  ASSERT_EQ(2u, log.mounts.size());
  EXPECT_EQ(3, log.mounts[0].line_number);
  EXPECT_EQ(6, log.mounts[1].line_number);
  EXPECT_EQ(7, log.lasers[3].line_number);
}

TEST(RobotLogTest, LaserLineFields) {
  const std::string path = WriteText(
      "laser.txt", "# c\nHSLOG 1\n\nLASER 12.5 4 -1 0.5 0.2 8 1.5 nan 9 -inf\n");
  RobotLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(1u, log.lasers.size());
  const LaserScan& scan = log.lasers[0].scan;
  EXPECT_EQ(4, log.lasers[0].line_number);
  EXPECT_EQ(12.5, scan.stamp_seconds);
  EXPECT_EQ((std::vector<double>{-1.0, -0.5, 0.0, 0.5}), scan.angles_radians);
  EXPECT_EQ(0.2, scan.range_min_meters);
  EXPECT_EQ(8.0, scan.range_max_meters);
  EXPECT_EQ(1.5, scan.ranges_meters[0]);
  EXPECT_TRUE(std::isnan(scan.ranges_meters[1]));
  EXPECT_EQ(9.0, scan.ranges_meters[2]);  // kept as read, invalid by range_max
  EXPECT_TRUE(std::isnan(scan.ranges_meters[3]));
  EXPECT_EQ(1, scan.NumValidBeams());
  EXPECT_EQ(2, log.stats.non_finite_ranges);
  EXPECT_EQ(4, log.stats.lines);
  EXPECT_EQ(2, log.stats.comment_lines);
}

// ---------------------------------------------------------------------------------------------
// Robot log: errors.

struct MalformedCase {
  std::string line;
  std::string message;  // expected after "file:3: "
};

TEST(RobotLogTest, MalformedLinesNameFileAndLineOrAreSkippedWhenLenient) {
  const std::vector<MalformedCase> cases = {
      {"FOO 1 2 3", "unknown message 'FOO'"},
      {"MARG 1 0 0 0 0 0 9.8 20 0",
       "MARG needs 9 numbers after the stamp (gx gy gz ax ay az mx my mz), found 8"},
      {"MARG", "MARG has no stamp"},
      {"MARG x 0 0 0 0 0 9.8 20 0 1", "MARG stamp ('x') is not a finite number"},
      {"MARG nan 0 0 0 0 0 9.8 20 0 1", "MARG stamp ('nan') is not a finite number"},
      {"ATTITUDE 1 0 inf 0", "ATTITUDE pitch ('inf') is not a finite number"},
      {"ALTITUDE 1", "ALTITUDE needs 1 numbers after the stamp (z), found 0"},
      {"ODOM 1 0 0 0 0", "ODOM needs 3 numbers after the stamp (x y theta), found 4"},
      {"COMMAND 1 0 0 abc", "COMMAND yaw_rate ('abc') is not a finite number"},
      {"MOUNT 1 0 0 0 0 0", "MOUNT needs 6 numbers after the stamp"},
      {"TRUTH 1 0 0 0 0 0 1e999", "TRUTH yaw ('1e999') is not a finite number"},
      {"IMAGE 1", "IMAGE needs a stamp and one path, found 1 fields"},
      {"IMAGE 1 a.png b.png", "IMAGE needs a stamp and one path, found 3 fields"},
      {"PARAM robot_name", "PARAM needs a name and a value"},
      {"LASER 1 2 0 0.1 0", "LASER is truncated"},
      {"LASER 1 2 0 0.1 0 10", "LASER declares 2 ranges but 0 follow range_max"},
      {"LASER 1 3 0 0.1 0 10 1 2", "LASER declares 3 ranges but 2 follow range_max"},
      {"LASER 1 1 0 0.1 0 10 1 2", "LASER declares 1 ranges but 2 follow range_max"},
      {"LASER 1 -1 0 0.1 0 10 1", "LASER beam count -1 is out of range [0, 100000]"},
      {"LASER 1 100001 0 0.1 0 10 1", "LASER beam count 100001 is out of range"},
      {"LASER 1 2.5 0 0.1 0 10 1 2", "LASER beam count ('2.5') is not an integer"},
      {"LASER 1 1 nan 0.1 0 10 1", "LASER angle_min ('nan') is not a finite number"},
      {"LASER 1 1 0 0.1 0 x 1", "LASER range_max ('x') is not a finite number"},
      {"LASER 1 1 0 0.1 5 2 1", "LASER needs 0 <= range_min < range_max (got 5, 2)"},
      {"LASER 1 2 0 0.1 0 10 1 two", "LASER range 1 ('two') is not a number"},
      {"HSLOG 1", "HSLOG header repeated"},
      // Issue #16: ranges of every number (core/robot_log_text.h, CheckBeamAngles).
      {"LASER 1 3 0 0 0 10 1 2 3", "LASER angle_increment is 0 with 3 beams"},
      {"LASER 1 3 0 1e300 0 10 1 2 3", "LASER angle_increment 1e+300 rad with 3 beams spans"},
      {"LASER 1 3 100 0.1 0 10 1 2 3", "LASER angle_min 100 rad is not a finite angle in [-2 pi, 2 pi]"},
      {"LASER 1e20 1 0 0.1 0 10 1", "LASER stamp 1e+20 is beyond +-"},
      {"LASER 1 1 0 0.1 0 1e300 1", "LASER range_max 1e+300 is beyond +-"},
      {"COMMAND 1 1e12 0 0", "COMMAND vx 1e+12 is beyond +-"},
      {"COMMAND 1 0 0 -5000", "COMMAND yaw_rate -5000 is beyond +-"},
      {"ODOM 1 0 -1e8 0", "ODOM y -1e+08 is beyond +-"},
      {"TRUTH 1 1e9 0 0 0 0 0", "TRUTH x 1e+09 is beyond +-"},
      {"MARG 1 1e6 0 0 0 0 9.8 20 0 -40", "MARG gyro rate 1e+06 is beyond +-"},
      {"IMAGE 1 ../../../../etc/passwd", "IMAGE path '../../../../etc/passwd' leaves the log's folder"},
      {"IMAGE 1 /etc/passwd", "IMAGE path '/etc/passwd' leaves the log's folder"},
  };
  for (size_t c = 0; c < cases.size(); ++c) {
    const std::string text = "HSLOG 1\nMARG 0 0 0 0 0 0 9.8 20 0 -40\n" + cases[c].line +
                             "\nALTITUDE 2 1.0\n";
    const std::string path = WriteText("malformed_" + std::to_string(c) + ".txt", text);
    RobotLog log;
    const Status strict = Read(path, &log);
    ASSERT_FALSE(strict.ok()) << cases[c].line;
    EXPECT_THAT(strict.message(), StartsWith(path + ":3: " + cases[c].message)) << cases[c].line;

    const Status lenient = Read(path, &log, /*lenient=*/true);
    ASSERT_TRUE(lenient.ok()) << cases[c].line << ": " << lenient.message();
    EXPECT_EQ(1, log.stats.malformed_lines_skipped) << cases[c].line;
    EXPECT_EQ(1u, log.marg.size());
    EXPECT_EQ(1u, log.altitudes.size()) << "the line after a skipped one is read";
    EXPECT_TRUE(log.lasers.empty());
    ASSERT_EQ(1u, log.warnings.size());
    EXPECT_THAT(log.warnings[0], StartsWith(path + ":3: " + cases[c].message));
    EXPECT_THAT(log.warnings[0], HasSubstr("(line skipped)"));
  }
}

TEST(RobotLogTest, LenientModeKeepsOnlyTheFirstWarnings) {
  std::string text = "HSLOG 1\n";
  for (int i = 0; i < 25; ++i) text += "MARG 1 2\n";
  const std::string path = WriteText("many_bad.txt", text);
  RobotLogReadOptions options;
  options.lenient = true;
  options.max_warnings_kept = 3;
  RobotLog log;
  ASSERT_TRUE(ReadRobotLog(path, options, &log).ok());
  EXPECT_EQ(25, log.stats.malformed_lines_skipped);
  ASSERT_EQ(3u, log.warnings.size());
  EXPECT_THAT(log.warnings[2], StartsWith(path + ":4: "));
}

TEST(RobotLogTest, MissingOrWrongHeaderIsAnErrorEvenWhenLenient) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", ":1: missing 'HSLOG 1' header"},
      {"# only a comment\n\n", ":2: missing 'HSLOG 1' header"},
      {"# c\nMARG 0 0 0 0 0 0 9.8 20 0 -40\n",
       ":2: expected the header 'HSLOG 1' as the first message, found 'MARG'"},
      {"HSLOG 2\n", ":1: unsupported HSLOG version 2 (this reader knows version 1)"},
      {"HSLOG\n", ":1: HSLOG header needs one integer version"},
      {"HSLOG one\n", ":1: HSLOG header needs one integer version"},
      {"HSTEAM 1\n", ":1: expected the header 'HSLOG 1' as the first message, found 'HSTEAM'"},
  };
  for (size_t c = 0; c < cases.size(); ++c) {
    const std::string path = WriteText("header_" + std::to_string(c) + ".txt", cases[c].first);
    for (bool lenient : {false, true}) {
      RobotLog log;
      const Status status = Read(path, &log, lenient);
      ASSERT_FALSE(status.ok()) << cases[c].first;
      EXPECT_THAT(status.message(), StartsWith(path + cases[c].second));
    }
  }
}

TEST(RobotLogTest, MissingFileAndDirectoryAreErrors) {
  RobotLog log;
  EXPECT_THAT(Read(TempPath("does_not_exist.txt"), &log).message(), HasSubstr("cannot open"));
  EXPECT_THAT(Read(::testing::TempDir(), &log).message(), HasSubstr("Is a directory"));
}

TEST(RobotLogTest, BackwardsStampsAreCountedPerTypeAndKeptInFileOrder) {
  const std::string path = WriteText("backwards.txt",
                                     "HSLOG 1\n"
                                     "ALTITUDE 2 1\n"
                                     "ALTITUDE 1 1\n"       // backwards
                                     "MARG 5 0 0 0 0 0 9.8 20 0 -40\n"
                                     "ALTITUDE 1.5 1\n"     // not backwards (1 -> 1.5)
                                     "MARG 3 0 0 0 0 0 9.8 20 0 -40\n"  // backwards
                                     "ALTITUDE 0 1\n"       // backwards
                                     "ODOM 9 0 0 0\n"       // other types never compared
                                     "ALTITUDE 0 1\n");     // equal: fine
  RobotLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(2, log.stats.timestamps_backwards["ALTITUDE"]);
  EXPECT_EQ(1, log.stats.timestamps_backwards["MARG"]);
  EXPECT_EQ(0, log.stats.timestamps_backwards.count("ODOM"));
  ASSERT_EQ(5u, log.altitudes.size());
  EXPECT_EQ(2.0, log.altitudes[0].stamp_seconds);
  EXPECT_EQ(1.0, log.altitudes[1].stamp_seconds);
  ASSERT_EQ(3u, log.warnings.size());
  EXPECT_EQ(path + ":3: ALTITUDE stamp 1 is earlier than the previous ALTITUDE stamp 2 (kept "
                   "in file order)",
            log.warnings[0]);
  EXPECT_THAT(log.warnings[1], StartsWith(path + ":6: MARG stamp 3"));
  EXPECT_THAT(log.warnings[2], StartsWith(path + ":7: ALTITUDE stamp 0"));
}

// ---------------------------------------------------------------------------------------------
// Camera model and paths.

TEST(RobotLogTest, CameraModelFromParams) {
  RobotLog log = MakeFullLog();
  log.path = "dir/log.txt";
  CameraIntrinsics k;
  Eigen::Isometry3d laser_T_camera;
  const Status status = log.CameraModel(&k, &laser_T_camera);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(525.0, k.fx);
  EXPECT_EQ(525.5, k.fy);
  EXPECT_EQ(319.5, k.cx);
  EXPECT_EQ(239.5, k.cy);
  EXPECT_EQ(640, k.width);
  EXPECT_EQ(480, k.height);
  EXPECT_EQ(Eigen::Vector3d(0.05, 0, -0.1), laser_T_camera.translation());
  // roll -90°, yaw -90°: the camera's optical axis (z) looks along the laser's x axis, its
  // x axis along the laser's -y (right), its y axis down.
  EXPECT_LT((laser_T_camera.linear() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitX())
                .norm(), 1e-15);
  EXPECT_LT((laser_T_camera.linear() * Eigen::Vector3d::UnitX() + Eigen::Vector3d::UnitY())
                .norm(), 1e-15);
  EXPECT_LT((laser_T_camera.linear() * Eigen::Vector3d::UnitY() + Eigen::Vector3d::UnitZ())
                .norm(), 1e-15);

  RobotLog missing = log;
  missing.params.erase("camera_cy");
  EXPECT_EQ("dir/log.txt: PARAM camera_cy is missing (no camera model)",
            missing.CameraModel(&k, &laser_T_camera).message());
  RobotLog bad_size = log;
  bad_size.params["camera_width"] = "640.5";
  EXPECT_THAT(bad_size.CameraModel(&k, &laser_T_camera).message(),
              HasSubstr("PARAM camera_width ('640.5') is not an integer"));
  RobotLog bad_focal = log;
  bad_focal.params["camera_fx"] = "-1";
  EXPECT_THAT(bad_focal.CameraModel(&k, &laser_T_camera).message(),
              HasSubstr("PARAM camera_fx ('-1') is not a positive number"));
  RobotLog bad_mount = log;
  bad_mount.params["laser_T_camera"] = "0 0 0 0 0";
  EXPECT_THAT(bad_mount.CameraModel(&k, &laser_T_camera).message(),
              HasSubstr("PARAM laser_T_camera ('0 0 0 0 0') is not 6 finite numbers"));
}

TEST(RobotLogTest, ImagePathsAreRelativeToTheLog) {
  const std::string path = WriteText("paths.txt", "HSLOG 1\nIMAGE 1 images/000001.png\n");
  RobotLog log;
  ASSERT_TRUE(Read(path, &log).ok());
  std::string expected_directory = path.substr(0, path.rfind('/'));
  while (expected_directory.size() > 1 && expected_directory.back() == '/') {
    expected_directory.pop_back();
  }
  EXPECT_EQ(expected_directory, log.directory);
  EXPECT_THAT(log.ImagePath(log.images[0]), StartsWith(log.directory));
  EXPECT_THAT(log.ImagePath(log.images[0]), ::testing::EndsWith("/images/000001.png"));
  RobotLog in_dir;
  in_dir.directory = "data/ugv1";
  EXPECT_EQ("data/ugv1/images/000001.png", in_dir.ImagePath(log.images[0]));
  RobotLog bare;
  bare.directory = ".";
  EXPECT_EQ("./a.png", bare.ImagePath({0.0, "a.png", 0}));
  EXPECT_EQ("/abs/a.png", bare.ImagePath({0.0, "/abs/a.png", 0}));
}

}  // namespace
}  // namespace hetslam
