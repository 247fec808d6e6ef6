// The map picture's drawing plugin (merger/map_picture_plugin.h): OpenCV is mapped into a
// process only once a picture is drawn, and a plugin that cannot be loaded makes
// WriteMapPicture return an error naming what was tried. This binary links no OpenCV library.
// Each test runs in a fresh process (the "threadsafe" death-test style runs the binary again):
// the process's plugin is loaded once.
#include <stdlib.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "merger/map_picture.h"
#include "merger/map_picture_plugin.h"
#include "tests/core/mapped_libraries_test_util.h"

namespace hetslam {
namespace {

OccupancyGrid SmallGrid() {
  OccupancyGrid grid{OccupancyGridOptions()};
  grid.InsertScan(Eigen::Vector2d(0.02, 0.02), {Eigen::Vector2d(1.01, 0.01), Eigen::Vector2d(1.01, 0.06)}, nullptr);
  return grid;
}

// 0 when the check held, else a code naming the first that failed.
int DrawAndCheck(const std::string& path) {
  if (LibraryMapped("libopencv_core")) return 1;
  const Status status = WriteMapPicture(path, SmallGrid(), nullptr, {{"t", {Pose2(0.0, 0.0, 0.0)}}}, {},
                                        MapPictureOptions());
  if (!status.ok()) {
    std::fprintf(stderr, "%s\n", status.message().c_str());
    return 2;
  }
  std::remove(path.c_str());
  return LibraryMapped("libopencv_core") && LibraryMapped("libhetslam_picture_plugin") ? 0 : 3;
}

TEST(MapPicturePluginTest, OpenCvIsMappedOnlyOnceAPictureIsDrawn) {
  ::testing::GTEST_FLAG(death_test_style) = "threadsafe";
  const std::string path = ::testing::TempDir() + "/map_picture_plugin_test.png";
  EXPECT_EXIT(std::exit(DrawAndCheck(path)), ::testing::ExitedWithCode(0), "");
}

TEST(MapPicturePluginTest, AMissingPluginIsAnErrorNamingWhatWasTried) {
  ::testing::GTEST_FLAG(death_test_style) = "threadsafe";
  auto draw = [] {
    setenv(map_picture_plugin::kPathVariable, "/nonexistent/libhetslam_picture_plugin.so", 1);
    const Status status =
        WriteMapPicture("out.png", SmallGrid(), nullptr, {{"t", {Pose2(0.0, 0.0, 0.0)}}}, {}, MapPictureOptions());
    std::fprintf(stderr, "%s\n", status.message().c_str());
    std::exit(status.ok() ? 1 : 0);
  };
  EXPECT_EXIT(draw(), ::testing::ExitedWithCode(0),
              "cannot write map picture 'out.png': its drawing plugin could not be loaded: tried "
              "/nonexistent/libhetslam_picture_plugin.so \\(cannot open shared object file");
}

}  // namespace
}  // namespace hetslam
