#include "core/measurement_log.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/test_data.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

std::string WriteText(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/measurement_log_test_" + name;
  std::ofstream(path) << text;
  return path;
}

std::vector<std::string> Kinds(const MeasurementLog& log) {
  std::vector<std::string> kinds;
  for (const Measurement& m : log.measurements) kinds.push_back(MeasurementKindName(m));
  return kinds;
}

// A robot log whose messages are out of stamp order in the file, with ties: the stream is
// merged by stamp, ties in the documented order (odometry, command, MARG, attitude, altitude,
// laser, image), each kind in file order.
TEST(MeasurementLogTest, RobotLogIsMergedByStampWithTheDocumentedTieOrder) {
  const std::string path = WriteText("robot.txt",
                                     "# comment\n"
                                     "HSLOG 1\n"
                                     "PARAM robot_name nao\n"
                                     "LASER 0.1 3 -0.1 0.1 0.05 5 1 2 3\n"
                                     "MARG 0.1 0 0 0 0 0 9.81 20 0 -40\n"
                                     "COMMAND 0.1 0.2 0 0.1\n"
                                     "MARG 0.0 0 0 0 0 0 9.81 20 0 -40\n"
                                     "ATTITUDE 0.1 0.01 0.02 0.3\n"
                                     "ALTITUDE 0.05 1.5\n"
                                     "IMAGE 0.1 images/000001.png\n"
                                     "ODOM 0.1 1 2 0.5\n"
                                     "TRUTH 0.1 1 2 0 0 0 0.5\n");
  MeasurementLog log;
  const Status status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(LogFormat::kRobotLog, log.format);
  EXPECT_EQ(1, log.num_scans);
  EXPECT_EQ("nao", log.params.at("robot_name"));
  // The MARG at 0.0 comes after the one at 0.1 in the file: a kind keeps its file order, so it
  // follows its predecessor (the reader reports the backwards stamp).
  EXPECT_EQ((std::vector<std::string>{"altitude", "odometry", "command", "marg", "marg", "attitude", "laser", "image"}),
            Kinds(log));
  const auto& image = std::get<CameraImage>(log.measurements.back());
  EXPECT_THAT(image.path, HasSubstr("images/000001.png"));
  EXPECT_FALSE(log.warnings.empty());  // MARG stamps going backwards
  EXPECT_NE(std::string::npos, image.path.find(::testing::TempDir()));  // relative to the log's folder
  const auto& command = std::get<VelocityCommand>(log.measurements[2]);
  EXPECT_EQ(0.2, command.forward_mps);
  EXPECT_EQ(0.1, command.yaw_rate_radps);
  EXPECT_EQ(6, command.line_number);
  ASSERT_EQ(1u, log.truth.size());
  EXPECT_NEAR(0.5, log.truth[0].pose.theta(), 1e-12);
  EXPECT_NEAR(0.0, log.ScanDurationSeconds(), 0.0);
}

// A CARMEN log: FLASER scans keep their odometry pose, ODOM lines become odometry readings,
// and a backwards stamp keeps file order within its kind.
TEST(MeasurementLogTest, CarmenLogKeepsScanOdometryAndFileOrderWithinAKind) {
  const std::string path = WriteText("carmen.clf",
                                     "ODOM 0 0 0 0 0 0 1.0 host 1.0\n"
                                     "FLASER 3 1 2 3 0.5 0.25 0.1 0.5 0.25 0.1 1.0 host 1.0\n"
                                     "ODOM 1 0 0 0 0 0 2.0 host 2.0\n"
                                     "FLASER 3 1 2 3 1.5 0.25 0.1 1.5 0.25 0.1 3.0 host 3.0\n"
                                     "FLASER 3 1 2 3 2.5 0.25 0.1 2.5 0.25 0.1 2.5 host 2.5\n");
  MeasurementLog log;
  const Status status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(LogFormat::kCarmen, log.format);
  EXPECT_EQ(3, log.num_scans);
  EXPECT_EQ((std::vector<std::string>{"odometry", "laser", "odometry", "laser", "laser"}), Kinds(log));
  const auto& first = std::get<LaserReading>(log.measurements[1]);
  EXPECT_TRUE(first.has_odometry_pose);
  EXPECT_EQ(0.5, first.odometry_pose.x());
  EXPECT_EQ(2.5, std::get<LaserReading>(log.measurements[4]).scan.stamp_seconds);  // file order kept
  EXPECT_EQ(2.0, log.ScanDurationSeconds());
  EXPECT_TRUE(log.truth.empty());
}

TEST(MeasurementLogTest, ErrorsNameTheFile) {
  MeasurementLog log;
  Status status = ReadMeasurementLog(::testing::TempDir() + "/no_such_log.clf", MeasurementLogOptions(), &log);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("no_such_log.clf"));
  const std::string bad = WriteText("bad.txt", "HSLOG 1\nMARG 0.1 1 2\n");
  status = ReadMeasurementLog(bad, MeasurementLogOptions(), &log);
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("bad.txt:2"));
  MeasurementLogOptions lenient;
  lenient.lenient = true;
  ASSERT_TRUE(ReadMeasurementLog(bad, lenient, &log).ok());
  EXPECT_EQ(1, log.malformed_lines_skipped);
  MeasurementLogOptions invalid;
  invalid.flaser_fov_radians = -1;
  EXPECT_THAT(ReadMeasurementLog(bad, invalid, &log).message(), HasSubstr("flaser_fov_radians"));
}

// Bags are told by their magic bytes (the CARMEN / robot log check would skip `#ROSBAG V2.0`
// as a comment). A ROS 2 bag, its SQLite file or its folder, is refused with a message.
TEST(MeasurementLogTest, DetectsRosBagsAndRefusesRos2Bags) {
  const std::string bag = WriteText("magic.bag", std::string("#ROSBAG V2.0\n") + std::string(4, '\0'));
  LogFormat format;
  ASSERT_TRUE(DetectLogFormat(bag, &format).ok());
  EXPECT_EQ(LogFormat::kRosBag, format);
  EXPECT_STREQ("ROS 1 bag", LogFormatName(format));
  MeasurementLog log;
  const Status status = ReadMeasurementLog(bag, MeasurementLogOptions(), &log);
  ASSERT_FALSE(status.ok());  // a header and nothing else: truncated, or no ROS support here
  EXPECT_THAT(status.message(), HasSubstr("magic.bag"));
  const Status support = CheckRosBagSupport();  // built without it, or its plugin not loaded
  if (!support.ok()) {
    EXPECT_THAT(status.message(), HasSubstr(support.message()));
  }

  const std::string db3 = WriteText("ros2.db3", std::string("SQLite format 3\0", 16) + "rest");
  Status ros2 = DetectLogFormat(db3, &format);
  ASSERT_FALSE(ros2.ok());
  EXPECT_THAT(ros2.message(), HasSubstr("ros2.db3"));
  EXPECT_THAT(ros2.message(), HasSubstr("ROS 2 bag"));
  const std::string folder = ::testing::TempDir() + "/measurement_log_test_ros2_bag";
  std::filesystem::create_directories(folder);
  std::ofstream(folder + "/metadata.yaml") << "rosbag2_bagfile_information:\n";
  ros2 = ReadMeasurementLog(folder, MeasurementLogOptions(), &log);
  ASSERT_FALSE(ros2.ok());
  EXPECT_THAT(ros2.message(), HasSubstr("ROS 2 bag"));
}

TEST(ReadTruthTrajectoryTest, ReadsARobotLogsTruthOrATrajectoryFile) {
  std::vector<StampedPose2> truth;
  const std::string log = WriteText("truth_log.txt",
                                    "HSLOG 1\n"
                                    "TRUTH 0.1 1 2 0.3 0.01 0.02 0.5\n"
                                    "TRUTH 0.2 1.5 2 0.3 0 0 0.6\n");
  Status status = ReadTruthTrajectory(log, &truth);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(2u, truth.size());
  EXPECT_EQ(0.2, truth[1].stamp_seconds);
  EXPECT_EQ(1.5, truth[1].pose.x());
  EXPECT_NEAR(0.6, truth[1].pose.theta(), 1e-12);

  const std::string file = WriteText("truth.txt", "# timestamp x y theta\n0.5 3 4 0.25\n");
  status = ReadTruthTrajectory(file, &truth);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(1u, truth.size());
  EXPECT_EQ(4.0, truth[0].pose.y());

  const std::string no_truth = WriteText("no_truth.txt", "HSLOG 1\nCOMMAND 0.1 0.2 0 0.1\n");
  EXPECT_THAT(ReadTruthTrajectory(no_truth, &truth).message(),
              HasSubstr("no_truth.txt' has no TRUTH lines"));
  EXPECT_THAT(ReadTruthTrajectory(::testing::TempDir() + "/no_such_truth.txt", &truth).message(),
              HasSubstr("no_such_truth.txt"));
}

// Issue #16: a LASER stamped 1e20 s after the first COMMAND used to be integrated step by step
// (a hang); a time gap over max_time_gap_seconds is an error naming file:line, or with lenient
// the measurement alone is dropped and counted.
TEST(MeasurementLogTest, TimeGapsOverTheBoundAreErrorsOrDroppedWhenLenient) {
  const std::string path = WriteText("gap.txt",
                                     "HSLOG 1\n"
                                     "COMMAND 0 0 0 0\n"
                                     "LASER 0.1 3 -0.1 0.1 0.05 5 1 2 3\n"
                                     "LASER 1e11 3 -0.1 0.1 0.05 5 1 2 3\n"
                                     "LASER 0.2 3 -0.1 0.1 0.05 5 1 2 3\n");
  MeasurementLog log;
  const Status status = ReadMeasurementLog(path, MeasurementLogOptions(), &log);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr(path + ":4: laser stamp 100000000000 is"));
  EXPECT_THAT(status.message(), HasSubstr("after the newest earlier stamp 0.1 (line 3)"));

  MeasurementLogOptions lenient;
  lenient.lenient = true;
  ASSERT_TRUE(ReadMeasurementLog(path, lenient, &log).ok());
  EXPECT_EQ(1, log.time_gaps_dropped);
  EXPECT_EQ(2, log.num_scans);
  // The robot log reader also warns of the 0.2 s stamp going backwards; the drop comes last.
  ASSERT_FALSE(log.warnings.empty());
  EXPECT_THAT(log.warnings.back(), HasSubstr(path + ":4: laser stamp"));
  EXPECT_THAT(log.warnings.back(), HasSubstr("(measurement dropped)"));

  MeasurementLogOptions unbounded;
  unbounded.max_time_gap_seconds = 0.0;
  ASSERT_TRUE(ReadMeasurementLog(path, unbounded, &log).ok());
  EXPECT_EQ(3, log.num_scans);

  MeasurementLogOptions invalid;
  invalid.max_time_gap_seconds = -1.0;
  EXPECT_FALSE(invalid.IsValid(nullptr));
}

TEST(MeasurementLogTest, ADirectoryIsRefusedByName) {
  MeasurementLog log;
  const Status status = ReadMeasurementLog(::testing::TempDir(), MeasurementLogOptions(), &log);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("is a folder, not a log file"));
}

// ---- MeasurementStream: the same measurements, errors and reports without holding the log ----

// Equal, NaN equal to NaN (a malformed log's ranges may be NaN).
bool SameValues(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](double x, double y) {
           return x == y || (std::isnan(x) && std::isnan(y));
         });
}

// What ReadMeasurementLog gives and what the stream gives for `path` with `options` must be
// the same: the error message, or every report and every measurement, field by field.
void ExpectStreamMatchesRead(const std::string& path, const MeasurementLogOptions& options) {
  SCOPED_TRACE(path + (options.lenient ? " (lenient)" : ""));
  MeasurementLog log;
  const Status read = ReadMeasurementLog(path, options, &log);
  std::unique_ptr<MeasurementStream> stream;
  const Status opened = MeasurementStream::Open(path, options, &stream);
  ASSERT_EQ(read.ok(), opened.ok()) << read.message() << " | " << opened.message();
  if (!read.ok()) {
    EXPECT_EQ(read.message(), opened.message());
    return;
  }
  const MeasurementLog& info = stream->info();
  EXPECT_EQ(log.format, info.format);
  EXPECT_EQ(log.params, info.params);
  EXPECT_EQ(log.warnings, info.warnings);
  EXPECT_EQ(log.malformed_lines_skipped, info.malformed_lines_skipped);
  EXPECT_EQ(log.time_gaps_dropped, info.time_gaps_dropped);
  EXPECT_EQ(log.num_scans, info.num_scans);
  EXPECT_EQ(log.truth.size(), info.truth.size());
  EXPECT_TRUE(info.measurements.empty());
  EXPECT_EQ(log.measurements.size(), stream->num_measurements());
  EXPECT_EQ(log.ScanDurationSeconds(), stream->ScanDurationSeconds());
  size_t n = 0;
  Measurement m;
  bool got = false;
  while (true) {
    const Status next = stream->Next(&m, &got);
    ASSERT_TRUE(next.ok()) << next.message();
    if (!got) break;
    ASSERT_LT(n, log.measurements.size());
    const Measurement& expected = log.measurements[n++];
    ASSERT_EQ(expected.index(), m.index()) << "measurement " << n;
    EXPECT_EQ(StampOf(expected), StampOf(m)) << "measurement " << n;
    EXPECT_EQ(LineOf(expected), LineOf(m)) << "measurement " << n;
    if (const auto* laser = std::get_if<LaserReading>(&expected)) {
      const auto& got_laser = std::get<LaserReading>(m);
      EXPECT_TRUE(SameValues(laser->scan.ranges_meters, got_laser.scan.ranges_meters)) << "measurement " << n;
      EXPECT_TRUE(SameValues(laser->scan.angles_radians, got_laser.scan.angles_radians)) << "measurement " << n;
      EXPECT_EQ(laser->scan.range_max_meters, got_laser.scan.range_max_meters) << "measurement " << n;
      EXPECT_TRUE(laser->scan.robot_T_sensor.isApprox(got_laser.scan.robot_T_sensor, 0.0)) << "measurement " << n;
      EXPECT_EQ(laser->has_odometry_pose, got_laser.has_odometry_pose);
      EXPECT_EQ(laser->odometry_pose.ToVector(), got_laser.odometry_pose.ToVector());
    } else if (const auto* odometry = std::get_if<OdometryReading>(&expected)) {
      EXPECT_EQ(odometry->pose.ToVector(), std::get<OdometryReading>(m).pose.ToVector()) << "measurement " << n;
    }
  }
  EXPECT_EQ(log.measurements.size(), n);
}

// Every CARMEN case: interleaved kinds with stamps backwards, ties, PARAM geometry changes
// between scans, malformed lines (strict: the same error before the first measurement; lenient:
// the same skips and warnings), time gaps, and every file of the malformed corpus.
TEST(MeasurementStreamTest, YieldsWhatReadMeasurementLogReads) {
  std::vector<std::string> paths = {
      WriteText("stream_order.clf",
                "ODOM 0 0 0 0 0 0 1.0 host 1.0\n"
                "FLASER 3 1 2 3 0.5 0.25 0.1 0.5 0.25 0.1 1.0 host 1.0\n"
                "ODOM 1 0 0 0 0 0 2.0 host 2.0\n"
                "PARAM laser_front_laser_fov 90\n"
                "FLASER 3 1 2 3 1.5 0.25 0.1 1.5 0.25 0.1 3.0 host 3.0\n"
                "# a comment\n"
                "ODOM 2 0 0 0 0 0 1.5 host 1.5\n"
                "FLASER 3 1 2 3 2.5 0.25 0.1 2.5 0.25 0.1 2.5 host 2.5\n"
                "ODOM 3 0 0 0 0 0 3.0 host 3.0\n"),
      WriteText("stream_bad.clf",
                "FLASER 3 1 2 3 0.5 0.25 0.1 0.5 0.25 0.1 1.0 host 1.0\n"
                "FLASER 3 1 2\n"
                "ODOM 1 0 nan 0 0 0 2.0 host 2.0\n"
                "FOO bar\n"
                "FLASER 3 1 2 3 1.5 0.25 0.1 1.5 0.25 0.1 3.0 host 3.0\n"),
      WriteText("stream_gap.clf",
                "FLASER 3 1 2 3 0.5 0.25 0.1 0.5 0.25 0.1 1.0 host 1.0\n"
                "FLASER 3 1 2 3 0.5 0.25 0.1 0.5 0.25 0.1 1e9 host 1e9\n"
                "ODOM 1 0 0 0 0 0 2.0 host 2.0\n"
                "FLASER 3 1 2 3 1.5 0.25 0.1 1.5 0.25 0.1 3.0 host 3.0\n"),
      WriteText("stream_empty.clf", ""),
  };
  const std::string corpus = std::string(HETSLAM_SOURCE_DIR) + "/tests/data/malformed";
  for (const auto& entry : std::filesystem::directory_iterator(corpus)) {
    if (entry.path().extension() == ".clf") paths.push_back(entry.path().string());
  }
  std::sort(paths.begin() + 4, paths.end());
  ASSERT_GT(paths.size(), 10u);
  for (const std::string& path : paths) {
    MeasurementLogOptions options;
    ExpectStreamMatchesRead(path, options);
    options.lenient = true;
    ExpectStreamMatchesRead(path, options);
  }
}

// Other formats are read whole and handed out: the same stream (a robot log here).
TEST(MeasurementStreamTest, RobotLogsAreHandedOutInTheSameOrder) {
  const std::string path = WriteText("stream_robot.txt",
                                     "HSLOG 1\n"
                                     "COMMAND 0 0 0 0\n"
                                     "LASER 0.1 3 -0.1 0.1 0.05 5 1 2 3\n"
                                     "COMMAND 0.1 0.2 0 0\n"
                                     "LASER 0.2 3 -0.1 0.1 0.05 5 1 2 3\n");
  ExpectStreamMatchesRead(path, MeasurementLogOptions());
}

// The shared Intel log (skipped when absent): 14541 measurements, the same ones.
TEST(MeasurementStreamTest, IntelIsStreamedAsItIsRead) {
  const std::string clf = SharedDatasetPath("intel/intel.clf");
  if (clf.empty()) GTEST_SKIP() << "shared datasets not found at " << SharedDatasetDir();
  ExpectStreamMatchesRead(clf, MeasurementLogOptions());
}

}  // namespace
}  // namespace hetslam
