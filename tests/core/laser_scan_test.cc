#include "core/laser_scan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "gtest/gtest.h"

namespace hetslam {
namespace {

// The 2.5D projection (paper §III-D) of hand-computed beams: a laser mounted 0.1 m ahead of and
// 0.5 m above the body origin, the body rolled 20° and pitched 30° (nose down), its origin 0.3 m
// above the floor: p = R_y(30°) R_x(20°) (mount + range · beam) + (0, 0, 0.3). The values below
// were worked out by hand (cos 20° = 0.93969262, sin 20° = 0.34202014, cos 30° = 0.86602540),
// e.g. the 90° beam of 1 m: (0.1, 1, 0.5) -> R_x: (0.1, 0.76868255, 0.81186645) -> R_y:
// (0.49253577, 0.76868255, 0.65309697) -> +0.3 m: z = 0.95309697. The NaN beam is left out.
TEST(ProjectScanTest, HandComputedBeamsAtAKnownRollPitchAndHeight) {
  LaserScan scan;
  scan.angles_radians = {0.0, M_PI / 2, M_PI / 4, -M_PI / 2};
  scan.ranges_meters = {2.0, 1.0, std::numeric_limits<double>::quiet_NaN(), 1.0};
  scan.range_max_meters = 10.0;
  scan.robot_T_sensor = Eigen::Isometry3d(Eigen::Translation3d(0.1, 0.0, 0.5));
  BodyAttitude attitude;
  attitude.roll_radians = 20.0 * M_PI / 180.0;
  attitude.pitch_radians = 30.0 * M_PI / 180.0;
  attitude.base_height_meters = 0.3;
  const std::vector<ProjectedPoint> points = ProjectScan(scan, attitude);
  ASSERT_EQ(3u, points.size());
  const struct {
    int beam;
    double x, y, z;
  } expected[] = {
      {0, 2.05357651, -0.17101007, -0.34310115},  // below the floor: this beam met the floor first
      {1, 0.49253577, 0.76868255, 0.95309697},   // the raised (+y) side
      {3, 0.15051563, -1.11070269, 0.36070071},  // the lowered (-y) side
  };
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(expected[k].beam, points[k].beam_index);
    EXPECT_NEAR(expected[k].x, points[k].p_robot.x(), 1e-6) << "beam " << expected[k].beam;
    EXPECT_NEAR(expected[k].y, points[k].p_robot.y(), 1e-6) << "beam " << expected[k].beam;
    EXPECT_NEAR(expected[k].z, points[k].z_meters, 1e-6) << "beam " << expected[k].beam;
  }
  // Level and at rest: the plain 2D end points of the mounted laser, at its height.
  const std::vector<ProjectedPoint> level = ProjectScan(scan, BodyAttitude());
  ASSERT_EQ(3u, level.size());
  EXPECT_NEAR(2.1, level[0].p_robot.x(), 1e-6);
  EXPECT_NEAR(0.0, level[0].p_robot.y(), 1e-6);
  EXPECT_NEAR(0.5, level[0].z_meters, 1e-6);
  EXPECT_NEAR(0.1, level[1].p_robot.x(), 1e-6);
  EXPECT_NEAR(1.0, level[1].p_robot.y(), 1e-6);
}

// Points every `spacing` metres along y = 0.1 from x = spacing / 2 to 1 - spacing / 2 (five 0.2 m
// voxels), in increasing x, or in decreasing x (the other direction of the scan's beams).
std::vector<Eigen::Vector2f> PointsAlongASegment(bool increasing, float spacing = 0.01f) {
  const int n = static_cast<int>(std::lround(1.f / spacing));
  std::vector<Eigen::Vector2f> points;
  for (int i = 0; i < n; ++i) points.emplace_back(spacing * (0.5f + static_cast<float>(increasing ? i : n - 1 - i)), 0.1f);
  return points;
}

float MeanX(const std::vector<Eigen::Vector2f>& points) {
  float sum = 0.f;
  for (const Eigen::Vector2f& p : points) sum += p.x();
  return sum / static_cast<float>(points.size());
}

TEST(VoxelFilterTest, KeepsTheFirstOrTheMiddlePointOfEachVoxelInTheOrderOfTheVoxels) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Voxel (0, 0): four points; voxel (2, 0): one; voxel (-1, -1): three; a NaN point between.
  const std::vector<Eigen::Vector2f> points = {{0.01f, 0.01f}, {0.45f, 0.05f}, {0.02f, 0.02f}, {0.03f, 0.03f},
                                               {nan, 0.0f},    {0.04f, 0.04f}, {-0.05f, -0.1f}, {-0.1f, -0.1f},
                                               {-0.15f, -0.1f}};
  const std::vector<Eigen::Vector2f> first = VoxelFilter(points, 0.2f);
  ASSERT_EQ(3u, first.size());
  EXPECT_EQ(points[0], first[0]);
  EXPECT_EQ(points[1], first[1]);
  EXPECT_EQ(points[6], first[2]);
  const std::vector<Eigen::Vector2f> middle = VoxelFilter(points, 0.2f, VoxelPoint::kMiddle);
  ASSERT_EQ(3u, middle.size());
  const Eigen::Vector2f midpoint = 0.5f * points[2] + 0.5f * points[3];  // of the second and third of four
  EXPECT_EQ(midpoint, middle[0]);
  EXPECT_NEAR(0.025f, middle[0].x(), 1e-7f);
  EXPECT_EQ(points[1], middle[1]);
  EXPECT_EQ(points[7], middle[2]);  // the second of three
  EXPECT_TRUE(VoxelFilter({}, 0.2f, VoxelPoint::kMiddle).empty());
  EXPECT_TRUE(VoxelFilter({{nan, nan}}, 0.2f, VoxelPoint::kMiddle).empty());
}

// The reason for the middle point: along a surface, the first point of each voxel lies at the
// voxel's side the beams come from, so the kept points shift with the beams' direction; the
// middle points do not.
TEST(VoxelFilterTest, TheMiddlePointsDoNotShiftWithTheDirectionOfTheBeams) {
  const float first_up = MeanX(VoxelFilter(PointsAlongASegment(true), 0.2f));
  const float first_down = MeanX(VoxelFilter(PointsAlongASegment(false), 0.2f));
  EXPECT_NEAR(0.405f, first_up, 1e-4f);    // 0.005, 0.205, ... 0.805
  EXPECT_NEAR(0.595f, first_down, 1e-4f);  // 0.195, 0.395, ... 0.995
  const float middle_up = MeanX(VoxelFilter(PointsAlongASegment(true), 0.2f, VoxelPoint::kMiddle));
  const float middle_down = MeanX(VoxelFilter(PointsAlongASegment(false), 0.2f, VoxelPoint::kMiddle));
  EXPECT_NEAR(0.5f, middle_up, 1e-4f);  // 20 points a voxel: between the 10th and the 11th either way
  EXPECT_NEAR(0.5f, middle_down, 1e-4f);
}

// Where beams are sparse, a voxel holds two points: the second of two would be as one-sided as
// the first (10 cm either way here); their midpoint is not.
TEST(VoxelFilterTest, TheMiddleOfTwoPointsIsTheirMidpoint) {
  EXPECT_NEAR(0.45f, MeanX(VoxelFilter(PointsAlongASegment(true, 0.1f), 0.2f)), 1e-4f);   // 0.05, 0.25, ...
  EXPECT_NEAR(0.55f, MeanX(VoxelFilter(PointsAlongASegment(false, 0.1f), 0.2f)), 1e-4f);  // 0.15, 0.35, ...
  EXPECT_NEAR(0.5f, MeanX(VoxelFilter(PointsAlongASegment(true, 0.1f), 0.2f, VoxelPoint::kMiddle)), 1e-4f);
  EXPECT_NEAR(0.5f, MeanX(VoxelFilter(PointsAlongASegment(false, 0.1f), 0.2f, VoxelPoint::kMiddle)), 1e-4f);
}

// Each voxel's first and last point, the voxels in the order of their first point; a voxel of
// one point gives it once.
TEST(VoxelFilterTest, TheFirstAndLastPointOfEachVoxel) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Voxel (0, 0): four points; voxel (2, 0): one; voxel (-1, -1): three; a NaN point between.
  const std::vector<Eigen::Vector2f> points = {{0.01f, 0.01f}, {0.45f, 0.05f}, {0.02f, 0.02f}, {0.03f, 0.03f},
                                               {nan, 0.0f},    {0.04f, 0.04f}, {-0.05f, -0.1f}, {-0.1f, -0.1f},
                                               {-0.15f, -0.1f}};
  const std::vector<Eigen::Vector2f> ends = VoxelFilter(points, 0.2f, VoxelPoint::kFirstAndLast);
  ASSERT_EQ(5u, ends.size());
  EXPECT_EQ(points[0], ends[0]);
  EXPECT_EQ(points[5], ends[1]);
  EXPECT_EQ(points[1], ends[2]);
  EXPECT_EQ(points[6], ends[3]);
  EXPECT_EQ(points[8], ends[4]);
  EXPECT_TRUE(VoxelFilter({}, 0.2f, VoxelPoint::kFirstAndLast).empty());
  EXPECT_TRUE(VoxelFilter({{nan, nan}}, 0.2f, VoxelPoint::kFirstAndLast).empty());
}

// Along a surface the first and the last points of the voxels are the same set whichever way
// the beams run: both ends of every voxel's stretch, dense or sparse.
TEST(VoxelFilterTest, TheFirstAndLastPointsDoNotShiftWithTheDirectionOfTheBeams) {
  for (const float spacing : {0.01f, 0.1f}) {
    std::vector<Eigen::Vector2f> up = VoxelFilter(PointsAlongASegment(true, spacing), 0.2f, VoxelPoint::kFirstAndLast);
    std::vector<Eigen::Vector2f> down =
        VoxelFilter(PointsAlongASegment(false, spacing), 0.2f, VoxelPoint::kFirstAndLast);
    ASSERT_EQ(10u, up.size()) << "spacing " << spacing;
    ASSERT_EQ(up.size(), down.size()) << "spacing " << spacing;
    const auto by_x = [](const Eigen::Vector2f& a, const Eigen::Vector2f& b) { return a.x() < b.x(); };
    std::sort(up.begin(), up.end(), by_x);
    std::sort(down.begin(), down.end(), by_x);
    for (size_t k = 0; k < up.size(); ++k) EXPECT_EQ(up[k], down[k]) << "spacing " << spacing << ", point " << k;
    EXPECT_NEAR(0.5f, MeanX(up), 1e-4f) << "spacing " << spacing;
  }
}

}  // namespace
}  // namespace hetslam
