#include "core/trajectory_io.h"

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

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/trajectory_io_test_" + name;
}

std::string WriteText(const std::string& name, const std::string& text) {
  const std::string path = TempPath(name);
  std::ofstream(path) << text;
  return path;
}

TEST(TrajectoryIoTest, WriteThenReadRoundTripsToStatedPrecision) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> xy(-100.0, 100.0), th(-M_PI, M_PI);
  std::vector<StampedPose2> trajectory;
  for (int k = 0; k < 50; ++k) {
    trajectory.push_back({1134864642.914123 + 0.25 * k, Pose2(xy(rng), xy(rng), th(rng))});
  }
  const std::string path = TempPath("roundtrip.txt");
  Status status = WriteTrajectory(path, trajectory);
  ASSERT_TRUE(status.ok()) << status.message();

  std::ifstream in(path);
  std::string first_line;
  std::getline(in, first_line);
  EXPECT_EQ("# timestamp x y theta", first_line);

  std::vector<StampedPose2> read;
  status = ReadTrajectory(path, &read);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(trajectory.size(), read.size());
  for (size_t k = 0; k < read.size(); ++k) {
    EXPECT_NEAR(trajectory[k].stamp_seconds, read[k].stamp_seconds, 1e-6);  // microseconds
    EXPECT_NEAR(trajectory[k].pose.x(), read[k].pose.x(), 1e-9);
    EXPECT_NEAR(trajectory[k].pose.y(), read[k].pose.y(), 1e-9);
    EXPECT_NEAR(0.0, WrapAngle(trajectory[k].pose.theta() - read[k].pose.theta()), 1e-9);
  }
}

TEST(TrajectoryIoTest, ReadsCommentsBlankLinesTabsAndCrlf) {
  const std::string path = WriteText("mixed.txt",
                                     "# header\n"
                                     "\n"
                                     "1.5\t2 3   0.5\r\n"
                                     "   # indented comment\n"
                                     "2.5 -1e-3 4e2 -3.0\n");
  std::vector<StampedPose2> trajectory;
  const Status status = ReadTrajectory(path, &trajectory);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(2u, trajectory.size());
  EXPECT_DOUBLE_EQ(1.5, trajectory[0].stamp_seconds);
  EXPECT_DOUBLE_EQ(2.0, trajectory[0].pose.x());
  EXPECT_DOUBLE_EQ(3.0, trajectory[0].pose.y());
  EXPECT_DOUBLE_EQ(0.5, trajectory[0].pose.theta());
  EXPECT_DOUBLE_EQ(-1e-3, trajectory[1].pose.x());
  EXPECT_DOUBLE_EQ(400.0, trajectory[1].pose.y());
}

TEST(TrajectoryIoTest, MalformedLinesAreErrorsNamingFileAndLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"1 2 3", "expected 4 fields 'timestamp x y theta', found 3"},
      {"1 2 3 4 5", "expected 4 fields 'timestamp x y theta', found 5"},
      {"1 2 abc 4", "y ('abc') is not a finite number"},
      {"nan 2 3 4", "timestamp ('nan') is not a finite number"},
      {"1 2 3 inf", "theta ('inf') is not a finite number"},
      {"1 1e400 3 4", "x ('1e400')"},
      {"1 2 3 4x", "theta ('4x')"},
  };
  for (const auto& [line, reason] : cases) {
    const std::string path = WriteText("bad.txt", "# ok\n0 0 0 0\n" + line + "\n1 1 1 1\n");
    std::vector<StampedPose2> trajectory;
    const Status status = ReadTrajectory(path, &trajectory);
    ASSERT_FALSE(status.ok()) << line;
    EXPECT_THAT(status.message(), HasSubstr("bad.txt:3: " + reason)) << line;
    EXPECT_TRUE(trajectory.empty()) << line;
  }
}

TEST(TrajectoryIoTest, MissingFileAndUnwritablePathAreErrors) {
  std::vector<StampedPose2> trajectory;
  Status status = ReadTrajectory(TempPath("missing.txt"), &trajectory);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ("cannot open '" + TempPath("missing.txt") + "': No such file or directory",
            status.message());
  status = WriteTrajectory(TempPath("no_such_dir/out.txt"), {{0.0, Pose2()}});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("no_such_dir/out.txt"));
  status = WriteTrajectory(TempPath("nan.txt"), {{0.0, Pose2(NAN, 0, 0)}});
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("pose 0 has a non-finite"));
}

TEST(TrajectoryIoTest, EmptyFileGivesEmptyTrajectory) {
  std::vector<StampedPose2> trajectory = {{1.0, Pose2()}};
  const Status status = ReadTrajectory(WriteText("empty.txt", ""), &trajectory);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(trajectory.empty());
}

TEST(TrajectoryIoTest, ReadsSharedGmappingReferences) {
  const std::pair<const char*, size_t> files[] = {{"intel/intel.gmapping.txt", 910},
                                                  {"fr079/fr079.gmapping.txt", 4791},
                                                  {"aces/aces.gmapping.txt", 440},
                                                  {"mit-csail/mit-csail.gmapping.txt", 406}};
  int found = 0;
  for (const auto& [file, count] : files) {
    const std::string path = SharedDatasetPath(file);
    if (path.empty()) continue;
    ++found;
    std::vector<StampedPose2> trajectory;
    const Status status = ReadTrajectory(path, &trajectory);
    ASSERT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(count, trajectory.size()) << file;
  }
  if (found == 0) {
    GTEST_SKIP() << "shared datasets not found at '" << SharedDatasetDir()
                 << "' (set HETSLAM_DATA_DIR)";
  }
}


// Issue #16: a duplicated row changed the Intel score (the ambiguity rule keys on poses); an
// exact repeat is dropped, repeated and backwards stamps are counted with file:line.
TEST(TrajectoryIoTest, CheckedReadDropsExactRepeatsAndReportsStampDisorder) {
  const std::string path = WriteText("disorder.txt",
                                     "# t x y theta\n"
                                     "1 0 0 0\n"
                                     "1 0 0 0\n"
                                     "2 1 0 0\n"
                                     "2 1.5 0 0\n"
                                     "1.5 2 0 0\n"
                                     "3 3 0 0\n");
  std::vector<StampedPose2> trajectory;
  TrajectoryStampReport report;
  const Status status = ReadTrajectoryChecked(path, &trajectory, &report);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(5u, trajectory.size());
  EXPECT_EQ(1, report.duplicate_rows_dropped);
  EXPECT_EQ(1, report.repeated_stamps);
  EXPECT_EQ(1, report.stamps_backwards);
  ASSERT_EQ(3u, report.warnings.size());
  EXPECT_THAT(report.warnings[0], ::testing::HasSubstr(path + ":3: repeats line 2 exactly (dropped)"));
  EXPECT_THAT(report.warnings[1], ::testing::HasSubstr(path + ":5: has the stamp of line 4"));
  EXPECT_THAT(report.warnings[2], ::testing::HasSubstr(path + ":6: stamp is earlier than line 5's"));
}

}  // namespace
}  // namespace hetslam
