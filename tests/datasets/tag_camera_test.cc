#include "datasets/sim/tag_camera.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "apriltag/apriltag.h"
#include "apriltag/tag36h11.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace sim {
namespace {

using ::testing::HasSubstr;

// The camera is the world frame (optical: x right, y down, z forward).
const Eigen::Isometry3d kWorldTCamera = Eigen::Isometry3d::Identity();

// A tag facing the camera upright at `position` (camera frame).
SimulatedTag FrontalTag(int id, double size_meters, const Eigen::Vector3d& position) {
  SimulatedTag tag;
  tag.id = id;
  tag.size_meters = size_meters;
  tag.world_T_tag.translation() = position;
  tag.world_T_tag.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  return tag;
}

// The apriltag library's own 10 x 10 bitmap of a tag36h11 code (0 or 255, row 0 on top).
std::vector<int> LibraryBitmap(int id) {
  apriltag_family_t* family = tag36h11_create();
  image_u8_t* image = apriltag_to_image(family, id);
  std::vector<int> bitmap;
  for (int row = 0; row < image->height; ++row) {
    for (int col = 0; col < image->width; ++col) {
      bitmap.push_back(image->buf[row * image->stride + col]);
    }
  }
  std::free(image->buf);  // image_u8_destroy is not exported by the Debian library
  std::free(image);
  tag36h11_destroy(family);
  return bitmap;
}

TagCameraOptions Sharp() {
  TagCameraOptions options;
  options.blur_sigma_pixels = 0.0;
  options.noise_std_gray = 0.0;
  return options;
}

TEST(TagCameraTest, CellCentresShowTheLibraryBitmap) {
  // 1 m away a 0.16 m tag has 0.02 m cells = 10.5 px: each cell centre pixel is fully inside.
  const int id = 23;
  const std::vector<int> bitmap = LibraryBitmap(id);
  ASSERT_EQ(100u, bitmap.size());
  int black = 0, white = 0;
  for (int v : bitmap) (v == 0 ? black : white) += 1;
  EXPECT_GT(black, 20);
  EXPECT_GT(white, 36);  // the white border alone has 36 cells
  for (bool noisy : {false, true}) {
    TagCameraOptions options = noisy ? TagCameraOptions() : Sharp();
    TagCamera camera(options);
    const SimulatedTag tag = FrontalTag(id, 0.16, {0.0, 0.0, 1.0});
    std::mt19937_64 rng(1);
    const cv::Mat image = camera.Render({tag}, kWorldTCamera, &rng);
    ASSERT_EQ(CV_8UC1, image.type());
    ASSERT_EQ(480, image.rows);
    ASSERT_EQ(640, image.cols);
    const CameraIntrinsics& k = options.intrinsics;
    for (int row = 0; row < 10; ++row) {
      for (int col = 0; col < 10; ++col) {
        // Cell centre in the tag frame (x right, y up), then in pixels.
        const double x = (col - 4.5) * 0.02, y = (4.5 - row) * 0.02;
        const Eigen::Vector3d p = tag.world_T_tag * Eigen::Vector3d(x, y, 0.0);
        const Eigen::Vector2d uv = k.Project(p);
        const int u = static_cast<int>(std::lround(uv.x()));
        const int v = static_cast<int>(std::lround(uv.y()));
        const int expected = bitmap[row * 10 + col];
        const int got = image.at<uint8_t>(v, u);
        if (noisy) {
          EXPECT_NEAR(expected, got, 12) << "cell " << row << "," << col;
        } else {
          EXPECT_EQ(expected, got) << "cell " << row << "," << col;
        }
      }
    }
  }
}

TEST(TagCameraTest, EdgePixelsHoldTheExactCoveredArea) {
  // 2 m away the pattern (0.2 m with its white border) spans u in 319.5 -+ 26.25 px: the left
  // edge at u = 293.25 covers a quarter of pixel 293 ([292.5, 293.5]).
  TagCamera camera(Sharp());
  std::mt19937_64 rng(1);
  const cv::Mat image = camera.Render({FrontalTag(0, 0.16, {0.0, 0.0, 2.0})}, kWorldTCamera, &rng);
  EXPECT_EQ(150, image.at<uint8_t>(240, 292));
  EXPECT_EQ(std::lround(0.75 * 150 + 0.25 * 255), image.at<uint8_t>(240, 293));
  EXPECT_EQ(255, image.at<uint8_t>(240, 294));
  // Right edge at 345.75: pixel 345 ([344.5, 345.5]) is inside, a quarter of 346 covered
  // (the mirror image of the left edge about cx = 319.5).
  EXPECT_EQ(255, image.at<uint8_t>(240, 345));
  EXPECT_EQ(std::lround(0.75 * 150 + 0.25 * 255), image.at<uint8_t>(240, 346));
  EXPECT_EQ(150, image.at<uint8_t>(240, 347));
  // Top-left corner pixel: a quarter of a quarter (0.25 x 0.25 of pixel (213, 293)).
  EXPECT_EQ(std::lround((1 - 0.0625) * 150 + 0.0625 * 255), image.at<uint8_t>(213, 293));
}

TEST(TagCameraTest, BackgroundAwayFromTagsHasTheConfiguredMeanAndNoise) {
  TagCameraOptions options;
  options.background_gray = 90.0;
  options.noise_std_gray = 3.0;
  TagCamera camera(options);
  std::mt19937_64 rng(5);
  const cv::Mat image = camera.Render({FrontalTag(1, 0.16, {0.0, 0.0, 2.0})}, kWorldTCamera,
                                      &rng);
  // The tag covers u in [293, 346]: the left 250 columns are background only.
  cv::Scalar mean, stddev;
  cv::meanStdDev(image(cv::Rect(0, 0, 250, 480)), mean, stddev);
  // 120000 pixels: the mean's own std is 3 / sqrt(120000) < 0.01 (plus rounding, zero mean).
  EXPECT_NEAR(90.0, mean[0], 0.05);
  // Rounding to integers adds 1/12 to the variance.
  EXPECT_NEAR(std::sqrt(9.0 + 1.0 / 12.0), stddev[0], 0.05);
}

TEST(TagCameraTest, SameSeedSameBytesAndNoNoiseDrawsNothing) {
  TagCamera camera{TagCameraOptions()};
  const std::vector<SimulatedTag> tags = {FrontalTag(2, 0.16, {-0.3, 0.0, 2.0}),
                                          FrontalTag(3, 0.2, {0.3, 0.1, 2.5})};
  std::mt19937_64 a(11), b(11), c(12);
  const cv::Mat first = camera.Render(tags, kWorldTCamera, &a);
  const cv::Mat second = camera.Render(tags, kWorldTCamera, &b);
  const cv::Mat other = camera.Render(tags, kWorldTCamera, &c);
  ASSERT_TRUE(first.isContinuous() && second.isContinuous());
  EXPECT_EQ(0, std::memcmp(first.data, second.data, first.total()));
  EXPECT_GT(cv::norm(first, other, cv::NORM_L1), 0.0);

  TagCamera quiet(Sharp());
  std::mt19937_64 used(3), fresh(3);
  quiet.Render(tags, kWorldTCamera, &used);
  EXPECT_EQ(fresh(), used());
}

TEST(TagCameraTest, NearerTagIsDrawnOverAFartherOneWhateverTheOrder) {
  TagCamera camera(Sharp());
  const SimulatedTag far_tag = FrontalTag(4, 0.3, {0.0, 0.0, 3.0});
  const SimulatedTag near_tag = FrontalTag(5, 0.1, {0.02, 0.0, 1.5});
  std::mt19937_64 rng(1);
  const cv::Mat a = camera.Render({far_tag, near_tag}, kWorldTCamera, &rng);
  const cv::Mat b = camera.Render({near_tag, far_tag}, kWorldTCamera, &rng);
  const cv::Mat near_only = camera.Render({near_tag}, kWorldTCamera, &rng);
  EXPECT_EQ(0, cv::norm(a, b, cv::NORM_INF));
  // Inside the near tag's pattern, the far tag does not show through.
  const cv::Rect inside(319 + 7 - 10, 239 - 10, 20, 20);
  EXPECT_EQ(0, cv::norm(a(inside), near_only(inside), cv::NORM_INF));
}

TEST(TagCameraTest, TagPartlyOutsideTheImageIsClipped) {
  TagCamera camera(Sharp());
  std::mt19937_64 rng(1);
  // Centre 0.4 m right of the axis at 0.7 m: u = 319.5 + 300 = 619.5, the pattern 150 px wide.
  const cv::Mat image = camera.Render({FrontalTag(6, 0.16, {0.4, 0.0, 0.7})}, kWorldTCamera,
                                      &rng);
  double lowest = 0, highest = 0;
  cv::minMaxLoc(image(cv::Rect(560, 150, 80, 180)), &lowest, &highest);
  EXPECT_EQ(0.0, lowest);
  EXPECT_EQ(255.0, highest);
  cv::minMaxLoc(image(cv::Rect(0, 0, 500, 480)), &lowest, &highest);
  EXPECT_EQ(150.0, lowest);
  EXPECT_EQ(150.0, highest);
}

TEST(TagCameraTest, OptionsValidation) {
  std::string error;
  EXPECT_TRUE(TagCameraOptions().IsValid(&error));
  TagCameraOptions options;
  options.intrinsics.fx = 0.0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("focal"));
  options = TagCameraOptions();
  options.intrinsics.width = 0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("image size"));
  options = TagCameraOptions();
  options.background_gray = 300.0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("background"));
  options = TagCameraOptions();
  options.blur_sigma_pixels = -1.0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("blur"));
  options = TagCameraOptions();
  options.noise_std_gray = std::nan("");
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("noise"));
}

TEST(TagCameraDeathTest, UnknownTagIdIsAProgrammerError) {
  TagCamera camera{TagCameraOptions()};
  std::mt19937_64 rng(1);
  EXPECT_DEATH(camera.Render({FrontalTag(587, 0.16, {0, 0, 2})}, kWorldTCamera, &rng),
               "tag id 587");
}

}  // namespace
}  // namespace sim
}  // namespace hetslam
