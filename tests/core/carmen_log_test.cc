#include "core/carmen_log.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/test_data.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

constexpr double kDeg = M_PI / 180.0;

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/carmen_log_test_" + name;
}

std::string WriteText(const std::string& name, const std::string& text) {
  const std::string path = TempPath(name);
  std::ofstream(path) << text;
  return path;
}

// "FLASER n r r r ... x y th ox oy oth t host t" with ranges 1, 2, 3, ...
std::string FlaserLine(int n, double stamp, const std::string& pose = "1 2 0.5 3 4 0.25") {
  std::string line = "FLASER " + std::to_string(n);
  for (int i = 0; i < n; ++i) line += " " + std::to_string(i + 1);
  return line + " " + pose + " " + std::to_string(stamp) + " nohost " + std::to_string(stamp) +
         "\n";
}

Status Read(const std::string& path, CarmenLog* log, bool lenient = false) {
  CarmenReadOptions options;
  options.lenient = lenient;
  return ReadCarmenLog(path, options, log);
}

TEST(CarmenLogTest, ReadsFlaserWithDefaultGeometry) {
  const std::string path = WriteText("flaser.clf", "# header\n\n" + FlaserLine(180, 12.5));
  CarmenLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(1u, log.lasers.size());
  const LaserReading& reading = log.lasers[0];
  const LaserScan& scan = reading.scan;
  EXPECT_EQ(3, reading.line_number);
  EXPECT_DOUBLE_EQ(12.5, scan.stamp_seconds);
  ASSERT_EQ(180u, scan.ranges_meters.size());
  ASSERT_EQ(180u, scan.angles_radians.size());
  EXPECT_DOUBLE_EQ(1.0, scan.ranges_meters[0]);
  EXPECT_DOUBLE_EQ(180.0, scan.ranges_meters[179]);
  // SICK 1 degree mode: -90 .. +89 degrees.
  EXPECT_NEAR(-90 * kDeg, scan.angles_radians.front(), 1e-12);
  EXPECT_NEAR(89 * kDeg, scan.angles_radians.back(), 1e-12);
  EXPECT_DOUBLE_EQ(81.0, scan.range_max_meters);
  EXPECT_DOUBLE_EQ(0.0, scan.range_min_meters);
  EXPECT_TRUE(scan.robot_T_sensor.isApprox(Eigen::Isometry3d::Identity()));
  // The odometry pose is the second triple (odom_x odom_y odom_theta).
  EXPECT_TRUE(reading.has_odometry_pose);
  EXPECT_DOUBLE_EQ(3.0, reading.odometry_pose.x());
  EXPECT_DOUBLE_EQ(4.0, reading.odometry_pose.y());
  EXPECT_DOUBLE_EQ(0.25, reading.odometry_pose.theta());
  EXPECT_EQ(3, log.stats.lines);
  EXPECT_EQ(2, log.stats.comment_lines);
  EXPECT_TRUE(log.warnings.empty());
}

TEST(CarmenLogTest, BeamGeometryForEvenAndOddCounts) {
  const std::string path = WriteText(
      "geometry.clf", FlaserLine(360, 1.0) + FlaserLine(361, 2.0) + FlaserLine(181, 3.0) +
                          FlaserLine(1, 4.0) + FlaserLine(0, 5.0));
  CarmenLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(5u, log.lasers.size());
  // 360 beams: 0.5 degree steps, -90 .. +89.5.
  const std::vector<double>& a360 = log.lasers[0].scan.angles_radians;
  EXPECT_NEAR(-90 * kDeg, a360.front(), 1e-12);
  EXPECT_NEAR(0.5 * kDeg, a360[1] - a360[0], 1e-12);
  EXPECT_NEAR(89.5 * kDeg, a360.back(), 1e-12);
  // 361 beams (odd): -90 .. +90 inclusive, beam 180 straight ahead.
  const std::vector<double>& a361 = log.lasers[1].scan.angles_radians;
  EXPECT_NEAR(-90 * kDeg, a361.front(), 1e-12);
  EXPECT_NEAR(0.0, a361[180], 1e-12);
  EXPECT_NEAR(90 * kDeg, a361.back(), 1e-12);
  // 181 beams: 1 degree steps, -90 .. +90.
  const std::vector<double>& a181 = log.lasers[2].scan.angles_radians;
  EXPECT_NEAR(1 * kDeg, a181[1] - a181[0], 1e-12);
  EXPECT_NEAR(90 * kDeg, a181.back(), 1e-12);
  // One beam looks straight ahead; zero beams is an empty scan.
  ASSERT_EQ(1u, log.lasers[3].scan.angles_radians.size());
  EXPECT_DOUBLE_EQ(0.0, log.lasers[3].scan.angles_radians[0]);
  EXPECT_TRUE(log.lasers[4].scan.ranges_meters.empty());
  EXPECT_TRUE(log.lasers[4].scan.angles_radians.empty());
}

TEST(CarmenLogTest, OptionsAndParamsSetFlaserGeometry) {
  {
    const std::string path = WriteText("fov_option.clf", FlaserLine(100, 1.0));
    CarmenReadOptions options;
    options.flaser_fov_radians = 100 * kDeg;
    options.flaser_max_range_meters = 30.0;
    options.range_min_meters = 0.1;
    CarmenLog log;
    ASSERT_TRUE(ReadCarmenLog(path, options, &log).ok());
    const LaserScan& scan = log.lasers[0].scan;
    EXPECT_NEAR(-50 * kDeg, scan.angles_radians.front(), 1e-12);
    EXPECT_NEAR(1 * kDeg, scan.angles_radians[1] - scan.angles_radians[0], 1e-12);
    EXPECT_DOUBLE_EQ(30.0, scan.range_max_meters);
    EXPECT_DOUBLE_EQ(0.1, scan.range_min_meters);
  }
  {
    // fov in degrees (> 2 pi) and resolution in degrees, as in CARMEN ini files; max range.
    const std::string path = WriteText(
        "params.clf",
        "PARAM laser_front_laser_fov 100 0 nohost 0\n"
        "PARAM laser_front_laser_resolution 0.25 0 nohost 0\n"
        "PARAM laser_front_laser_max_range 20 0 nohost 0\n"
        "PARAM robot_name pioneer 0 nohost 0\n" +
            FlaserLine(401, 1.0));
    CarmenLog log;
    const Status status = Read(path, &log);
    ASSERT_TRUE(status.ok()) << status.message();
    const LaserScan& scan = log.lasers[0].scan;
    EXPECT_NEAR(-50 * kDeg, scan.angles_radians.front(), 1e-12);
    EXPECT_NEAR(0.25 * kDeg, scan.angles_radians[1] - scan.angles_radians[0], 1e-12);
    EXPECT_NEAR(50 * kDeg, scan.angles_radians.back(), 1e-9);
    EXPECT_DOUBLE_EQ(20.0, scan.range_max_meters);
    EXPECT_EQ("pioneer", log.params.at("robot_name"));
    EXPECT_EQ("0.25", log.params.at("laser_front_laser_resolution"));
  }
  {
    // fov in radians (mit-csail's 3.14159).
    const std::string path =
        WriteText("fov_radians.clf", "PARAM laser_front_laser_fov 3.14159\n" + FlaserLine(361, 1.0));
    CarmenLog log;
    ASSERT_TRUE(Read(path, &log).ok());
    EXPECT_NEAR(-3.14159 / 2, log.lasers[0].scan.angles_radians.front(), 1e-12);
  }
  {
    const std::string path =
        WriteText("bad_param.clf", "PARAM laser_front_laser_fov wide 0 nohost 0\n");
    CarmenLog log;
    const Status status = Read(path, &log);
    ASSERT_FALSE(status.ok());
    EXPECT_THAT(status.message(), HasSubstr("bad_param.clf:1: PARAM laser_front_laser_fov"));
  }
}

TEST(CarmenLogTest, RejectsInvalidOptions) {
  const std::string path = WriteText("options.clf", FlaserLine(3, 1.0));
  CarmenReadOptions options;
  options.flaser_fov_radians = -1.0;
  CarmenLog log;
  EXPECT_THAT(ReadCarmenLog(path, options, &log).message(), HasSubstr("flaser_fov_radians"));
  options = CarmenReadOptions();
  options.flaser_max_range_meters = 0.0;
  options.range_min_meters = 1.0;
  EXPECT_THAT(ReadCarmenLog(path, options, &log).message(), HasSubstr("range_min_meters"));
}

TEST(CarmenLogTest, ReadsOdom) {
  const std::string path = WriteText("odom.clf",
                                     "ODOM 1.5 -2 3.0 0.1 0.2 0 100.25 nohost 100.3\n"
                                     "ODOM 1.6 -2 3.5 0.1 0.2 0 100.5 nohost 100.6\n");
  CarmenLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(2u, log.odometry.size());
  EXPECT_DOUBLE_EQ(100.25, log.odometry[0].stamp_seconds);  // ipc_timestamp
  EXPECT_DOUBLE_EQ(1.5, log.odometry[0].pose.x());
  EXPECT_DOUBLE_EQ(-2.0, log.odometry[0].pose.y());
  EXPECT_NEAR(3.0, log.odometry[0].pose.theta(), 1e-15);
  EXPECT_EQ(2, log.odometry[1].line_number);
  EXPECT_NEAR(3.5 - 2 * M_PI, log.odometry[1].pose.theta(), 1e-12);  // wrapped
}

TEST(CarmenLogTest, ReadsRobotLaserWithMountAndRemissions) {
  // 3 beams from -0.1 rad in 0.1 rad steps, max range 8; 2 remissions; laser 0.2 m ahead of
  // the robot at (1, 2) facing +y, so the laser is at (1, 2.2) facing +y.
  const std::string path = WriteText(
      "robotlaser.clf",
      "ROBOTLASER1 0 -0.1 0.2 0.1 8.0 0.01 0 3 1.0 2.0 nan 2 0.5 0.6 "
      "1.0 2.2 1.5707963267948966 1.0 2.0 1.5707963267948966 0.3 0.1 0.5 0.5 0 "
      "7.0 nohost 7.1\n");
  CarmenLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(1u, log.lasers.size());
  const LaserReading& reading = log.lasers[0];
  const LaserScan& scan = reading.scan;
  EXPECT_DOUBLE_EQ(7.0, scan.stamp_seconds);
  ASSERT_EQ(3u, scan.ranges_meters.size());
  EXPECT_NEAR(-0.1, scan.angles_radians[0], 1e-12);
  EXPECT_NEAR(0.1, scan.angles_radians[2], 1e-12);
  EXPECT_TRUE(std::isnan(scan.ranges_meters[2]));  // invalid beam, kept as NaN
  EXPECT_EQ(2, scan.NumValidBeams());
  EXPECT_DOUBLE_EQ(8.0, scan.range_max_meters);
  EXPECT_TRUE(reading.has_odometry_pose);
  EXPECT_DOUBLE_EQ(1.0, reading.odometry_pose.x());
  EXPECT_DOUBLE_EQ(2.0, reading.odometry_pose.y());
  EXPECT_NEAR(0.2, scan.robot_T_sensor.translation().x(), 1e-12);
  EXPECT_NEAR(0.0, scan.robot_T_sensor.translation().y(), 1e-12);
  EXPECT_TRUE(scan.robot_T_sensor.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-12));
}

TEST(CarmenLogTest, ReadsRawLaserWithoutPose) {
  const std::string path =
      WriteText("rawlaser.clf", "RAWLASER1 0 -1.5 3.0 1.5 30 0.01 0 3 1 2 3 0 55.5 nohost 55.6\n");
  CarmenLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(1u, log.lasers.size());
  const LaserReading& reading = log.lasers[0];
  EXPECT_FALSE(reading.has_odometry_pose);
  EXPECT_DOUBLE_EQ(55.5, reading.scan.stamp_seconds);
  EXPECT_NEAR(1.5, reading.scan.angles_radians[2], 1e-12);
  EXPECT_DOUBLE_EQ(30.0, reading.scan.range_max_meters);
}

TEST(CarmenLogTest, NanAndInfRangesAreInvalidBeams) {
  std::string line = "FLASER 4 1.0 nan inf -inf 0 0 0 0 0 0 1.0 nohost 1.0\n";
  CarmenLog log;
  const Status status = Read(WriteText("nan_ranges.clf", line), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  const LaserScan& scan = log.lasers[0].scan;
  EXPECT_DOUBLE_EQ(1.0, scan.ranges_meters[0]);
  EXPECT_TRUE(std::isnan(scan.ranges_meters[1]));
  EXPECT_TRUE(std::isnan(scan.ranges_meters[2]));
  EXPECT_TRUE(std::isnan(scan.ranges_meters[3]));
  EXPECT_EQ(1, scan.NumValidBeams());
}

TEST(CarmenLogTest, UnknownMessagesAreCountedAndSkipped) {
  const std::string path = WriteText("unknown.clf",
                                     "NEFF 1 2 3\n"
                                     "SONAR 1 2\n"
                                     "NEFF 4\n" +
                                         FlaserLine(2, 1.0));
  CarmenLog log;
  ASSERT_TRUE(Read(path, &log).ok());
  EXPECT_EQ(3, log.stats.unknown_messages_skipped);
  EXPECT_EQ(2, log.stats.unknown_message_counts.at("NEFF"));
  EXPECT_EQ(1, log.stats.unknown_message_counts.at("SONAR"));
  EXPECT_EQ(1u, log.lasers.size());
}

// Each hostile line must give an error naming file and line 2 (and the expected reason),
// and in lenient mode be skipped and counted while the good lines around it are kept.
struct BadLine {
  std::string line;
  std::string reason;
};

TEST(CarmenLogTest, MalformedLinesAreErrorsNamingFileAndLine) {
  // The 14 fields after a ROBOTLASER1's remissions.
  const std::string kRobotLaserTail = "1 2 3 4 5 6 7 8 9 10 11 1 nohost 1";
  const std::vector<BadLine> cases = {
      {"FLASER 180 1 2 3 4 5 6 7 8 9 10 11 12", "FLASER declares 180 ranges but only 12 fields follow"},
      {"FLASER 999999999 1 2 3", "count of ranges 999999999 is out of range [0, 100000]"},
      {"FLASER -3 1 2 3 0 0 0 0 0 0 1 nohost 1", "count of ranges -3 is out of range"},
      {"FLASER 99999999999999999999999 1", "not an integer"},
      {"FLASER abc 1 2 3", "count of ranges ('abc') is not an integer"},
      {"FLASER 2.5 1 2 3 0 0 0 0 0 0 1 nohost 1", "('2.5') is not an integer"},
      {"FLASER", "FLASER is truncated"},
      {"FLASER 3 1 2 x 0 0 0 0 0 0 1 nohost 1", "FLASER range 2 ('x') is not a number"},
      {"FLASER 3 1 2 3 nan 0 0 0 0 0 1 nohost 1", "FLASER field x ('nan') is not a finite number"},
      {"FLASER 3 1 2 3 0 0 inf 0 0 0 1 nohost 1", "field theta ('inf')"},
      {"FLASER 3 1 2 3 0 0 0 0 0 0 1e999 nohost 1", "field ipc_timestamp ('1e999')"},
      {"FLASER 3 1 2 3 0 0 0 0 0 0 1 nohost 1 extra", "unexpected extra field"},
      {"FLASER 3 1 2 3 0 0 0 0 0 0 1 nohost", "FLASER declares 3 ranges but only 11 fields follow"},
      {"FLASER 0 0 0 0 0 0 0 1 nohost", "FLASER declares 0 ranges but only 8 fields follow"},
      {"ODOM 1 2", "ODOM is truncated: field theta"},
      {"ODOM 1 2 3 0 0 0 5.0x nohost 5", "field ipc_timestamp ('5.0x')"},
      {"ODOM 1 nan 3 0 0 0 5 nohost 5", "ODOM field y ('nan')"},
      {"ROBOTLASER1 0 -0.1 0.2 0.1 8.0 0.01 0 3 1 2 3 500000 " + kRobotLaserTail,
       "count of remissions 500000 is out of range"},
      {"ROBOTLASER1 0 -0.1 0.2 0.1 8.0 0.01 0 3 1 2 3 2 " + kRobotLaserTail,
       "ROBOTLASER1 declares 2 remissions but only 14 fields follow"},
      {"ROBOTLASER1 0 -0.1 0.2 0.1 8.0 0.01 0 3 1 2 3 0 1 2 3 4 5 6 7 8 9 10 11 1 nohost", "ROBOTLASER1 declares 3 ranges but only 17 fields follow"},
      {"ROBOTLASER1 0 -0.1 0.2 0.1 8.0 0.01 0 3 1 2 3 0 1 2 3 4 5 x 7 8 9 10 11 1 nohost 1", "ROBOTLASER1 field robot_theta ('x')"},
      {"ROBOTLASER1 0 nan 0.2 0.1 8.0 0.01 0 3 1 2 3 0 " + kRobotLaserTail, "ROBOTLASER1 field start_angle ('nan')"},
      {"RAWLASER1 0 -1.5 3.0 1.5 30 0.01 0 50 1 2 3", "RAWLASER1 declares 50 ranges"},
      {"PARAM onlyname", "PARAM is truncated"},
  };
  for (const BadLine& c : cases) {
    const std::string path = WriteText("bad.clf", FlaserLine(3, 1.0) + c.line + "\n" +
                                                      "ODOM 1 2 3 0 0 0 5 nohost 5\n");
    CarmenLog log;
    const Status status = Read(path, &log);
    ASSERT_FALSE(status.ok()) << c.line;
    EXPECT_THAT(status.message(), HasSubstr("bad.clf:2: ")) << c.line;
    EXPECT_THAT(status.message(), HasSubstr(c.reason)) << c.line;

    CarmenLog lenient_log;
    const Status lenient_status = Read(path, &lenient_log, /*lenient=*/true);
    ASSERT_TRUE(lenient_status.ok()) << c.line << ": " << lenient_status.message();
    EXPECT_EQ(1, lenient_log.stats.malformed_lines_skipped) << c.line;
    EXPECT_EQ(1u, lenient_log.lasers.size()) << c.line;
    EXPECT_EQ(1u, lenient_log.odometry.size()) << c.line;
    ASSERT_EQ(1u, lenient_log.warnings.size()) << c.line;
    EXPECT_THAT(lenient_log.warnings[0], HasSubstr("bad.clf:2: ")) << c.line;
    EXPECT_THAT(lenient_log.warnings[0], HasSubstr(c.reason)) << c.line;
  }
}

// Seeded random mutations of valid lines (tokens dropped, duplicated or replaced by hostile
// values): reading never crashes; a strict read either succeeds or names file and line 1;
// a lenient read always succeeds and accounts for the line.
TEST(CarmenLogTest, RandomlyMutatedLinesNeverCrash) {
  const std::vector<std::string> good = {
      "FLASER 4 1 2 3 4 0 0 0 0 0 0 1 nohost 1",
      "ODOM 1 2 3 0 0 0 5 nohost 5",
      "ROBOTLASER1 0 -0.1 0.2 0.1 8.0 0.01 0 3 1 2 3 1 7 1 2 3 4 5 6 7 8 9 10 11 1 nohost 1",
      "RAWLASER1 0 -1.5 3.0 1.5 30 0.01 0 3 1 2 3 0 55.5 nohost 55.6",
      "PARAM laser_front_laser_fov 180 0 nohost 0"};
  const std::vector<std::string> hostile = {"nan", "-inf", "1e999", "-1", "999999999", "abc",
                                            "", "0x10", "3.5", "-2147483649", "FLASER", "#"};
  std::mt19937 rng(12345);
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<std::string> fields;
    std::istringstream in(good[trial % good.size()]);
    for (std::string f; in >> f;) fields.push_back(f);
    const int edits = 1 + static_cast<int>(rng() % 3);
    for (int e = 0; e < edits && !fields.empty(); ++e) {
      const size_t at = 1 + rng() % std::max<size_t>(1, fields.size() - 1);
      const size_t i = std::min(at, fields.size() - 1);
      switch (rng() % 3) {
        case 0:
          fields.erase(fields.begin() + i);
          break;
        case 1:
          fields.insert(fields.begin() + i, fields[i]);
          break;
        default:
          fields[i] = hostile[rng() % hostile.size()];
      }
    }
    std::string line;
    for (const std::string& f : fields) line += f + " ";
    const std::string path = WriteText("fuzz.clf", line + "\n");
    CarmenLog log;
    const Status status = Read(path, &log);
    if (!status.ok()) {
      EXPECT_THAT(status.message(), HasSubstr("fuzz.clf:1: ")) << line;
    }
    CarmenLog lenient_log;
    ASSERT_TRUE(Read(path, &lenient_log, /*lenient=*/true).ok()) << line;
    const int accounted = static_cast<int>(lenient_log.lasers.size() + lenient_log.odometry.size() +
                                           lenient_log.params.size()) +
                          lenient_log.stats.malformed_lines_skipped +
                          lenient_log.stats.unknown_messages_skipped +
                          lenient_log.stats.comment_lines;
    EXPECT_EQ(1, accounted) << line;
    EXPECT_EQ(status.ok(), lenient_log.stats.malformed_lines_skipped == 0) << line;
  }
}

TEST(CarmenLogTest, LenientModeCountsEverySkippedLineAndKeepsFewWarnings) {
  std::string text;
  for (int i = 0; i < 25; ++i) text += "FLASER 5 1 2\n" + FlaserLine(2, i);
  CarmenReadOptions options;
  options.lenient = true;
  options.max_warnings_kept = 4;
  CarmenLog log;
  const Status status = ReadCarmenLog(WriteText("lenient.clf", text), options, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(25, log.stats.malformed_lines_skipped);
  EXPECT_EQ(25u, log.lasers.size());
  EXPECT_EQ(50, log.stats.lines);
  EXPECT_EQ(4u, log.warnings.size());
  EXPECT_THAT(log.warnings[0], HasSubstr("lenient.clf:1: "));
  EXPECT_THAT(log.warnings[3], HasSubstr("lenient.clf:7: "));
}

TEST(CarmenLogTest, BackwardsTimestampsAreCountedAndKeptInFileOrder) {
  const std::string path = WriteText("backwards.clf",
                                     FlaserLine(2, 10.0) + FlaserLine(2, 9.5) +
                                         FlaserLine(2, 11.0) + FlaserLine(2, 10.9) +
                                         "ODOM 0 0 0 0 0 0 5 nohost 5\n"
                                         "ODOM 0 0 0 0 0 0 4 nohost 4\n"
                                         "ODOM 0 0 0 0 0 0 4 nohost 4\n");  // equal: not backwards
  CarmenLog log;
  const Status status = Read(path, &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(2, log.stats.laser_timestamps_backwards);
  EXPECT_EQ(1, log.stats.odometry_timestamps_backwards);
  ASSERT_EQ(4u, log.lasers.size());
  EXPECT_DOUBLE_EQ(9.5, log.lasers[1].scan.stamp_seconds);  // not reordered
  ASSERT_EQ(3u, log.warnings.size());
  EXPECT_THAT(log.warnings[0], HasSubstr("backwards.clf:2: FLASER timestamp 9.5"));
  EXPECT_THAT(log.warnings[2], HasSubstr("backwards.clf:6: ODOM timestamp 4"));
}

TEST(CarmenLogTest, EmptyFileGivesEmptyLog) {
  CarmenLog log;
  const Status status = Read(WriteText("empty.clf", ""), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(log.lasers.empty());
  EXPECT_TRUE(log.odometry.empty());
  EXPECT_EQ(0, log.stats.lines);
}

TEST(CarmenLogTest, MissingFileAndDirectoryAreErrors) {
  CarmenLog log;
  Status status = Read(TempPath("x.clf"), &log);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ("cannot open '" + TempPath("x.clf") + "': No such file or directory", status.message());
  status = Read(::testing::TempDir(), &log);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("Is a directory"));
}

TEST(CarmenLogTest, WriteThenReadRoundTrips) {
  CarmenLog log;
  const int n = 361;
  for (int k = 0; k < 3; ++k) {
    LaserReading reading;
    reading.scan.stamp_seconds = 1000.0 + k;
    reading.scan.angles_radians = EvenlySpacedAngles(n, -M_PI / 2, M_PI / (n - 1));
    reading.scan.range_max_meters = 30.0;
    for (int i = 0; i < n; ++i) reading.scan.ranges_meters.push_back(1.0 + 0.001 * i + k);
    reading.scan.ranges_meters[5] = NAN;   // invalid: written as max range
    reading.scan.ranges_meters[6] = 45.0;  // beyond max range: invalid
    reading.odometry_pose = Pose2(k * 0.5, -k * 0.25, 0.1 * k);
    reading.has_odometry_pose = true;
    log.lasers.push_back(reading);
  }
  for (int k = 0; k < 5; ++k) {
    OdometryReading odom;
    odom.stamp_seconds = 999.5 + 0.5 * k;  // interleaves with the scans
    odom.pose = Pose2(0.1 * k, 0.2 * k, -0.3 * k);
    log.odometry.push_back(odom);
  }
  log.params["robot_name"] = "sim_robot";
  const std::string path = TempPath("roundtrip.clf");
  Status status = WriteCarmenLog(path, log, {"written by carmen_log_test", "two\nlines"});
  ASSERT_TRUE(status.ok()) << status.message();

  CarmenLog read;
  status = Read(path, &read);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(3, read.stats.comment_lines);
  EXPECT_EQ(0, read.stats.laser_timestamps_backwards);
  EXPECT_EQ(0, read.stats.odometry_timestamps_backwards);
  EXPECT_EQ("sim_robot", read.params.at("robot_name"));
  ASSERT_EQ(3u, read.lasers.size());
  ASSERT_EQ(5u, read.odometry.size());
  // Merged in timestamp order: ODOM 999.5, 1000 (before the scan at 1000), FLASER 1000, ...
  EXPECT_LT(read.odometry[1].line_number, read.lasers[0].line_number);
  EXPECT_GT(read.odometry[2].line_number, read.lasers[0].line_number);
  for (int k = 0; k < 3; ++k) {
    const LaserScan& a = log.lasers[k].scan;
    const LaserScan& b = read.lasers[k].scan;
    EXPECT_NEAR(a.stamp_seconds, b.stamp_seconds, 1e-6);
    EXPECT_DOUBLE_EQ(30.0, b.range_max_meters);
    ASSERT_EQ(a.angles_radians.size(), b.angles_radians.size());
    for (int i = 0; i < n; ++i) {
      EXPECT_NEAR(a.angles_radians[i], b.angles_radians[i], 1e-9) << i;
      if (a.IsValidRange(a.ranges_meters[i])) {
        EXPECT_NEAR(a.ranges_meters[i], b.ranges_meters[i], 1e-6) << i;
      } else {
        EXPECT_FALSE(b.IsValidRange(b.ranges_meters[i])) << i;
      }
    }
    EXPECT_EQ(a.NumValidBeams(), b.NumValidBeams());
    EXPECT_NEAR(log.lasers[k].odometry_pose.x(), read.lasers[k].odometry_pose.x(), 1e-9);
    EXPECT_NEAR(log.lasers[k].odometry_pose.y(), read.lasers[k].odometry_pose.y(), 1e-9);
    EXPECT_NEAR(log.lasers[k].odometry_pose.theta(), read.lasers[k].odometry_pose.theta(), 1e-9);
  }
  for (int k = 0; k < 5; ++k) {
    EXPECT_NEAR(log.odometry[k].stamp_seconds, read.odometry[k].stamp_seconds, 1e-6);
    EXPECT_NEAR(log.odometry[k].pose.x(), read.odometry[k].pose.x(), 1e-9);
    EXPECT_NEAR(log.odometry[k].pose.theta(), read.odometry[k].pose.theta(), 1e-9);
  }
}

TEST(CarmenLogTest, WriteRejectsScansFlaserCannotStore) {
  CarmenLog log;
  LaserReading reading;
  reading.scan.angles_radians = {0.0, 0.1, 0.2};  // does not start at -fov/2 < 0
  reading.scan.ranges_meters = {1, 2, 3};
  log.lasers.push_back(reading);
  Status status = WriteCarmenLog(TempPath("reject.clf"), log, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("cannot be written as FLASER"));

  log.lasers[0].scan.angles_radians = {-0.1, 0.0, 0.3};  // uneven
  status = WriteCarmenLog(TempPath("reject.clf"), log, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("laser reading 0 (t=0) beam 1"));
  EXPECT_THAT(status.message(), HasSubstr("evenly spaced beams"));

  log.lasers[0].scan.angles_radians = {-0.1, 0.0};  // size mismatch
  status = WriteCarmenLog(TempPath("reject.clf"), log, {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("2 angles but 3 ranges"));

  status = WriteCarmenLog(TempPath("no_such_dir/out.clf"), CarmenLog(), {});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("no_such_dir/out.clf"));
}

// The shared real logs load strictly with the counts their README gives.
struct RealLog {
  const char* file;
  size_t scans;
  size_t odometry;
  size_t beams;
  int laser_backwards;  // -1: not checked
  int odometry_backwards;
};

TEST(CarmenLogTest, SharedRealLogsLoad) {
  const RealLog logs[] = {{"intel/intel.clf", 910, 13631, 180, 4, 629},
                          {"fr079/fr079.clf", 4791, 4934, 360, -1, -1},
                          {"aces/aces.clf", 440, 7374, 180, -1, -1},
                          {"mit-csail/mit-csail.clf", 406, 1987, 361, -1, -1}};
  int found = 0;
  for (const RealLog& real : logs) {
    const std::string path = SharedDatasetPath(real.file);
    if (path.empty()) continue;
    ++found;
    CarmenLog log;
    const Status status = Read(path, &log);
    ASSERT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(real.scans, log.lasers.size()) << real.file;
    EXPECT_EQ(real.odometry, log.odometry.size()) << real.file;
    EXPECT_EQ(0, log.stats.unknown_messages_skipped) << real.file;
    EXPECT_EQ(real.beams, log.lasers[0].scan.ranges_meters.size()) << real.file;
    if (real.laser_backwards >= 0) {
      EXPECT_EQ(real.laser_backwards, log.stats.laser_timestamps_backwards) << real.file;
      EXPECT_EQ(real.odometry_backwards, log.stats.odometry_timestamps_backwards) << real.file;
    }
    // "No return" readings (81.83 / 81.91) are beyond the default 81 m limit.
    for (const LaserReading& reading : log.lasers) {
      for (double r : reading.scan.ranges_meters) {
        if (r > 81.0) {
          ASSERT_FALSE(reading.scan.IsValidRange(r)) << real.file;
        }
      }
    }
  }
  if (found == 0) {
    GTEST_SKIP() << "shared datasets not found at '" << SharedDatasetDir()
                 << "' (set HETSLAM_DATA_DIR)";
  }
}

}  // namespace
}  // namespace hetslam
