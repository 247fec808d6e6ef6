#include "core/relations.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "core/carmen_log.h"
#include "core/trajectory_io.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/test_data.h"

namespace hetslam {
namespace {

using ::testing::HasSubstr;

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/relations_test_" + name;
}

std::string WriteText(const std::string& name, const std::string& text) {
  const std::string path = TempPath(name);
  std::ofstream(path) << text;
  return path;
}

TEST(ReadRelationsTest, ReadsXYAndYawIgnoringCommentsAndBlankLines) {
  const std::string path = WriteText(
      "good.relations",
      "# a comment\n"
      "\n"
      "10.5 12.25 1.0 -2.0 0.0 0.0 0.0 0.5\n"
      "  20 21 0.1 0.2 0.3 0.01 0.02 -3.0  \r\n");
  std::vector<Relation> relations;
  const Status status = ReadRelations(path, &relations);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(2u, relations.size());
  EXPECT_DOUBLE_EQ(10.5, relations[0].t1_seconds);
  EXPECT_DOUBLE_EQ(12.25, relations[0].t2_seconds);
  EXPECT_DOUBLE_EQ(1.0, relations[0].delta.x());
  EXPECT_DOUBLE_EQ(-2.0, relations[0].delta.y());
  EXPECT_DOUBLE_EQ(0.5, relations[0].delta.theta());
  EXPECT_EQ(3, relations[0].line_number);
  EXPECT_DOUBLE_EQ(-3.0, relations[1].delta.theta());  // yaw is the 8th field
  EXPECT_EQ(4, relations[1].line_number);
}

TEST(ReadRelationsTest, MissingFileNamesIt) {
  std::vector<Relation> relations;
  const Status status = ReadRelations(TempPath("does_not_exist.relations"), &relations);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("does_not_exist.relations"));
  EXPECT_THAT(status.message(), HasSubstr("No such file or directory"));
}

TEST(ReadRelationsTest, WrongFieldCountIsAnErrorWithLine) {
  const std::string path = WriteText("short.relations",
                                     "1 2 0 0 0 0 0 0\n"
                                     "1 2 0 0 0 0 0\n");
  std::vector<Relation> relations;
  const Status status = ReadRelations(path, &relations);
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("short.relations:2:"));
  EXPECT_THAT(status.message(), HasSubstr("expected 8 fields"));
  EXPECT_TRUE(relations.empty());
}

TEST(ReadRelationsTest, NonNumericAndNonFiniteFieldsAreErrors) {
  for (const std::string bad : {"abc", "nan", "inf", "1.0x", "1e999", "--1"}) {
    const std::string path =
        WriteText("bad.relations", "1 2 0 0 0 0 0 0\n\n1 2 0 " + bad + " 0 0 0 0\n");
    std::vector<Relation> relations;
    const Status status = ReadRelations(path, &relations);
    ASSERT_FALSE(status.ok()) << bad;
    EXPECT_THAT(status.message(), HasSubstr("bad.relations:3: y ('" + bad + "')")) << bad;
  }
}

TEST(RelationsMetricOptionsTest, RejectsNegativeOrNonFiniteValues) {
  RelationsMetricOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.match_tolerance_seconds = -1.0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("match_tolerance_seconds"));
  options.match_tolerance_seconds = 0.1;
  options.clock_offset_seconds = NAN;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("clock_offset_seconds"));
}

// A trajectory along x with one pose per second: pose k = (k, 0, 0.1 k).
std::vector<StampedPose2> StraightTrajectory(int n) {
  std::vector<StampedPose2> trajectory;
  for (int k = 0; k < n; ++k) trajectory.push_back({static_cast<double>(k), Pose2(k, 0.0, 0.1 * k)});
  return trajectory;
}

TEST(EvaluateRelationsTest, ExactRelationsScoreZero) {
  const std::vector<StampedPose2> trajectory = StraightTrajectory(10);
  std::vector<Relation> relations;
  for (int k = 0; k + 3 < 10; ++k) {
    Relation r;
    r.t1_seconds = 100.0 + k;  // relation clock = trajectory clock + 100 s
    r.t2_seconds = 100.0 + k + 3;
    r.delta = Between(trajectory[k].pose, trajectory[k + 3].pose);
    relations.push_back(r);
  }
  RelationsMetricOptions options;
  options.clock_offset_seconds = 100.0;
  const RelationsMetricResult result = EvaluateRelations(trajectory, relations, options);
  EXPECT_EQ(7, result.total);
  EXPECT_EQ(7, result.matched);
  EXPECT_NEAR(0.0, result.trans_mean_m, 1e-12);
  EXPECT_NEAR(0.0, result.rot_mean_deg, 1e-9);
  EXPECT_NEAR(0.0, result.trans_max_m, 1e-12);
}

TEST(EvaluateRelationsTest, KnownErrorsGiveKnownStatistics) {
  // Two poses at t = 0 and t = 1; the relation (1, 0, 0) is exact for the estimate
  // (0,0,0) -> (1,0,0). Relation A claims (1, 0.3, 0): error 0.3 m, 0 deg. Relation B claims
  // (1, 0, -10 deg): 0 m, 10 deg. Relation C claims (1.1, 0, +2 deg): 0.1 m, 2 deg.
  const std::vector<StampedPose2> trajectory = {{0.0, Pose2(0, 0, 0)}, {1.0, Pose2(1, 0, 0)}};
  const double deg = M_PI / 180.0;
  std::vector<Relation> relations(3);
  for (Relation& r : relations) {
    r.t1_seconds = 0.0;
    r.t2_seconds = 1.0;
  }
  relations[0].delta = Pose2(1.0, 0.3, 0.0);
  relations[1].delta = Pose2(1.0, 0.0, -10 * deg);
  relations[2].delta = Pose2(1.1, 0.0, 2 * deg);
  const RelationsMetricResult result =
      EvaluateRelations(trajectory, relations, RelationsMetricOptions());
  ASSERT_EQ(3, result.matched);
  const double trans_mean = (0.3 + 0.0 + 0.1) / 3;
  const double trans_std = std::sqrt((std::pow(0.3 - trans_mean, 2) + std::pow(trans_mean, 2) +
                                      std::pow(0.1 - trans_mean, 2)) / 2);  // sample: N - 1
  EXPECT_NEAR(trans_mean, result.trans_mean_m, 1e-12);
  EXPECT_NEAR(trans_std, result.trans_std_m, 1e-12);
  EXPECT_NEAR(4.0, result.rot_mean_deg, 1e-9);
  EXPECT_NEAR(std::sqrt((16.0 + 36.0 + 4.0) / 2), result.rot_std_deg, 1e-9);
  EXPECT_NEAR((0.09 + 0.0 + 0.01) / 3, result.trans_sq_mean_m2, 1e-12);
  EXPECT_NEAR((0.0 + 100.0 + 4.0) / 3, result.rot_sq_mean_deg2, 1e-9);
  const double sq_mean = 104.0 / 3;
  EXPECT_NEAR(std::sqrt((std::pow(sq_mean, 2) + std::pow(100 - sq_mean, 2) +
                         std::pow(4 - sq_mean, 2)) / 2),
              result.rot_sq_std_deg2, 1e-9);
  EXPECT_NEAR(0.1, result.trans_median_m, 1e-12);
  EXPECT_NEAR(2.0, result.rot_median_deg, 1e-9);
  EXPECT_NEAR(0.3, result.trans_max_m, 1e-12);
  EXPECT_NEAR(10.0, result.rot_max_deg, 1e-9);
  EXPECT_EQ(1, result.errors[1].relation_index);
  EXPECT_EQ(0, result.errors[1].trajectory_index_1);
  EXPECT_EQ(1, result.errors[1].trajectory_index_2);
}

TEST(EvaluateRelationsTest, RotationErrorWrapsAcrossPi) {
  // Estimated yaw change +179 deg, relation says -179 deg: the error is 2 deg, not 358.
  const double deg = M_PI / 180.0;
  const std::vector<StampedPose2> trajectory = {{0.0, Pose2(0, 0, 0)},
                                                {1.0, Pose2(0, 0, 179 * deg)}};
  std::vector<Relation> relations(1);
  relations[0].t1_seconds = 0.0;
  relations[0].t2_seconds = 1.0;
  relations[0].delta = Pose2(0, 0, -179 * deg);
  const RelationsMetricResult result =
      EvaluateRelations(trajectory, relations, RelationsMetricOptions());
  ASSERT_EQ(1, result.matched);
  EXPECT_NEAR(2.0, result.rot_mean_deg, 1e-9);
}

TEST(EvaluateRelationsTest, RelativePoseIsInTheFrameOfTheFirstPose) {
  // Robot at (1, 1) facing +y, then at (1, 3) facing +y: in the first frame the second pose
  // is 2 m straight ahead, (2, 0, 0). A world-frame difference (0, 2) would score 2.83 m.
  const std::vector<StampedPose2> trajectory = {{0.0, Pose2(1, 1, M_PI / 2)},
                                                {1.0, Pose2(1, 3, M_PI / 2)}};
  std::vector<Relation> relations(1);
  relations[0].t1_seconds = 0.0;
  relations[0].t2_seconds = 1.0;
  relations[0].delta = Pose2(2, 0, 0);
  const RelationsMetricResult result =
      EvaluateRelations(trajectory, relations, RelationsMetricOptions());
  ASSERT_EQ(1, result.matched);
  EXPECT_NEAR(0.0, result.trans_mean_m, 1e-12);
  EXPECT_NEAR(0.0, result.rot_mean_deg, 1e-9);
}

TEST(EvaluateRelationsTest, MatchesNearestPoseWithinToleranceOnly) {
  // Poses at 0, 1, 2, 3 s listed out of order; relation ends at 0.004 s and 2.997 s match
  // poses 0 and 3 with the 6 ms tolerance; ends 0.01 s away do not.
  std::vector<StampedPose2> trajectory = {{2.0, Pose2(2, 0, 0)},
                                          {0.0, Pose2(0, 0, 0)},
                                          {3.0, Pose2(3, 0, 0)},
                                          {1.0, Pose2(1, 0, 0)}};
  std::vector<Relation> relations(3);
  relations[0].t1_seconds = 0.004;
  relations[0].t2_seconds = 2.997;
  relations[0].delta = Pose2(3, 0, 0);
  relations[1].t1_seconds = 1.01;  // 10 ms off: unmatched
  relations[1].t2_seconds = 2.0;
  relations[2].t1_seconds = 1.0;
  relations[2].t2_seconds = 2.5;  // halfway between two poses: unmatched
  const RelationsMetricResult result =
      EvaluateRelations(trajectory, relations, RelationsMetricOptions());
  EXPECT_EQ(3, result.total);
  ASSERT_EQ(1, result.matched);
  EXPECT_EQ(0, result.errors[0].relation_index);
  EXPECT_EQ(1, result.errors[0].trajectory_index_1);
  EXPECT_EQ(2, result.errors[0].trajectory_index_2);
  EXPECT_NEAR(0.0, result.trans_mean_m, 1e-12);
}

TEST(EvaluateRelationsTest, RelationsWithAnAmbiguousEndAreCountedNotScored) {
  // Ends 5 ms apart both match the pose at 1 s: the estimate would be the identity whatever
  // the trajectory, so the relation is not scored (the shared Intel log has such pairs), and
  // neither is any other relation ending on that pose.
  std::vector<Relation> relations(2);
  relations[0].t1_seconds = 0.998;
  relations[0].t2_seconds = 1.003;
  relations[0].delta = Pose2(0.35, 0, 0);
  relations.resize(4);
  relations[1].t1_seconds = 0.0;   // ends on the ambiguous pose: not scored
  relations[1].t2_seconds = 1.003;
  relations[2].t1_seconds = 0.0;
  relations[2].t2_seconds = 2.0;
  relations[2].delta = Pose2(2, 0, 0.2);
  relations[3].t1_seconds = 2.0;   // the same stamp twice does not make a pose ambiguous
  relations[3].t2_seconds = 2.0;
  const RelationsMetricResult result =
      EvaluateRelations(StraightTrajectory(3), relations, RelationsMetricOptions());
  EXPECT_EQ(4, result.total);
  EXPECT_EQ(2, result.ambiguous);
  ASSERT_EQ(2, result.matched);
  EXPECT_EQ(2, result.errors[0].relation_index);
  EXPECT_EQ(3, result.errors[1].relation_index);
  EXPECT_NEAR(0.0, result.trans_mean_m, 1e-12);
}

TEST(EvaluateRelationsTest, ExactAssociationThroughReadings) {
  // The log keeps the scans at 0, 1, 2 s; the recording also had a reading at 1.01 s (another
  // pose, not kept) and two readings printed 2 s (different poses).
  RelationsMetricOptions options;
  options.readings = {{0.0, Pose2(0, 0, 0)},    {1.0, Pose2(1, 0, 0.1)},   {1.01, Pose2(1.1, 0, 0.2)},
                      {2.0, Pose2(2, 0, 0.2)},  {2.0, Pose2(2.1, 0, 0.3)}, {3.0, Pose2(3, 0, 0.3)}};
  std::vector<Relation> relations(5);
  relations[0].t1_seconds = 0.0;     // nearest reading 0 s, a scan: scored
  relations[0].t2_seconds = 0.999;   // nearest reading 1 s: scored
  relations[0].delta = Pose2(1, 0, 0.1);
  relations[1].t1_seconds = 0.0;
  relations[1].t2_seconds = 1.0054;  // within 6 ms of the scan at 1 s, but the 1.01 s reading is nearer
  relations[2].t1_seconds = 0.0;
  relations[2].t2_seconds = 2.003;   // two readings of different poses printed 2 s: ambiguous
  relations[3].t1_seconds = 0.0;
  relations[3].t2_seconds = 1.5;     // no reading within 6 ms: unmatched
  relations[4].t1_seconds = 0.0;
  relations[4].t2_seconds = 3.0;     // a reading, but no scan of the trajectory (it has 3 poses)
  const RelationsMetricResult exact = EvaluateRelations(StraightTrajectory(3), relations, options);
  EXPECT_EQ(5, exact.total);
  EXPECT_EQ(1, exact.matched);
  EXPECT_EQ(2, exact.on_other_reading);
  EXPECT_EQ(1, exact.ambiguous);
  ASSERT_EQ(1u, exact.errors.size());
  EXPECT_EQ(0, exact.errors[0].relation_index);
  EXPECT_NEAR(0.0, exact.trans_mean_m, 1e-12);

  // Nearest-pose association scores relation 2 against one of the two readings printed 2 s
  // and, with 0.999 s and 1.0054 s both nearest to the pose at 1 s, drops relations 0 and 1
  // as ambiguous.
  const RelationsMetricResult nearest =
      EvaluateRelations(StraightTrajectory(3), relations, RelationsMetricOptions());
  ASSERT_EQ(1, nearest.matched);
  EXPECT_EQ(2, nearest.errors[0].relation_index);
  EXPECT_EQ(2, nearest.ambiguous);
  EXPECT_EQ(0, nearest.on_other_reading);

  // Readings printed with one stamp but the same pose (a robot standing still) are no tie.
  options.readings[4].pose = options.readings[3].pose;
  EXPECT_EQ(2, EvaluateRelations(StraightTrajectory(3), relations, options).matched);
}

TEST(EvaluateRelationsTest, NothingMatchedGivesZeroStatistics) {
  std::vector<Relation> relations(2);
  relations[0].t1_seconds = 50;  // no pose there
  relations[0].t2_seconds = 60;
  relations[1].t1_seconds = 0;   // first end matches, second does not
  relations[1].t2_seconds = 1.5;
  const RelationsMetricResult result =
      EvaluateRelations(StraightTrajectory(3), relations, RelationsMetricOptions());
  EXPECT_EQ(2, result.total);
  EXPECT_EQ(0, result.matched);
  EXPECT_EQ(0.0, result.trans_mean_m);
  EXPECT_EQ(0.0, result.rot_std_deg);
  EXPECT_TRUE(result.errors.empty());
  EXPECT_EQ(0, EvaluateRelations({}, relations, RelationsMetricOptions()).matched);
}

// The sanity figure of shared/datasets/README.md: GMapping's trajectory on the Intel
// relations, offset 976052857.337284 s, 6 ms tolerance: 129 relations with both ends matched,
// 0.074 +- 0.100 m, 1.55 +- 4.61 deg (sample standard deviations). 21 of them have an ambiguous
// end (two readings of the original recording 5 ms apart fall on one scan of the shared log);
// the 108 scored ones give the figures below.
TEST(EvaluateRelationsTest, ReproducesGmappingFigureOnIntel) {
  const std::string trajectory_path = SharedDatasetPath("intel/intel.gmapping.txt");
  const std::string relations_path = SharedDatasetPath("intel/intel.relations");
  if (trajectory_path.empty() || relations_path.empty()) {
    GTEST_SKIP() << "shared datasets not found at '" << SharedDatasetDir()
                 << "' (set HETSLAM_DATA_DIR)";
  }
  std::vector<StampedPose2> trajectory;
  Status status = ReadTrajectory(trajectory_path, &trajectory);
  ASSERT_TRUE(status.ok()) << status.message();
  std::vector<Relation> relations;
  status = ReadRelations(relations_path, &relations);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(910u, trajectory.size());
  EXPECT_EQ(2984u, relations.size());

  RelationsMetricOptions options;
  options.clock_offset_seconds = 976052857.337284;
  options.match_tolerance_seconds = 0.006;
  const RelationsMetricResult result = EvaluateRelations(trajectory, relations, options);
  EXPECT_EQ(2984, result.total);
  EXPECT_EQ(21, result.ambiguous);
  EXPECT_EQ(108, result.matched);
  EXPECT_NEAR(0.0361, result.trans_mean_m, 0.00005);
  EXPECT_NEAR(0.0268, result.trans_std_m, 0.00005);
  EXPECT_NEAR(0.683, result.rot_mean_deg, 0.0005);
  EXPECT_NEAR(0.997, result.rot_std_deg, 0.0005);
  EXPECT_NEAR(0.0299, result.trans_median_m, 0.00005);
  EXPECT_NEAR(0.351, result.rot_median_deg, 0.0005);

  // Exact association through the log's readings (its ODOM lines): 43 relations fall on
  // scans; 2558 end on a reading the log does not keep as a scan.
  const std::string log_path = SharedDatasetPath("intel/intel.clf");
  if (log_path.empty()) return;
  CarmenLog log;
  status = ReadCarmenLog(log_path, CarmenReadOptions(), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  for (const OdometryReading& odometry : log.odometry) options.readings.push_back({odometry.stamp_seconds, odometry.pose});
  const RelationsMetricResult exact = EvaluateRelations(trajectory, relations, options);
  EXPECT_EQ(43, exact.matched);
  EXPECT_EQ(2558, exact.on_other_reading);
  EXPECT_NEAR(0.0396, exact.trans_mean_m, 0.00005);
  EXPECT_NEAR(0.361, exact.rot_mean_deg, 0.0005);
}

}  // namespace
}  // namespace hetslam
