// Helpers shared by the tests of the robot log reader, its writer and the team manifest
// (tests/core/robot_log_test.cc, robot_log_writer_test.cc, team_manifest_test.cc): text files
// in the test's temporary directory, poses from "x y z roll pitch yaw" and their comparison
// after a write and read.
#ifndef HETSLAM_TESTS_CORE_ROBOT_LOG_TEST_UTIL_H_
#define HETSLAM_TESTS_CORE_ROBOT_LOG_TEST_UTIL_H_

#include <fstream>
#include <sstream>
#include <string>

#include "Eigen/Geometry"
#include "core/euler.h"
#include "gtest/gtest.h"

namespace hetslam {

// `name` in gtest's temporary directory, prefixed with the running test's suite and name so
// that tests run at the same time (ctest -j) never share a file.
inline std::string TempPath(const std::string& name) {
  const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string prefix =
      test == nullptr ? "robot_log" : std::string(test->test_suite_name()) + "." + test->name();
  return ::testing::TempDir() + "/" + prefix + "_" + name;
}

// Writes `text` to TempPath(name) and returns that path.
inline std::string WriteText(const std::string& name, const std::string& text) {
  const std::string path = TempPath(name);
  std::ofstream(path) << text;
  return path;
}

// The whole file at `path` ("" when it cannot be read).
inline std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The pose with translation (x, y, z) and Z-Y-X Euler angles (core/euler.h).
inline Eigen::Isometry3d MakePose(double x, double y, double z, double roll, double pitch,
                                  double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(x, y, z);
  pose.linear() = RotationFromRollPitchYaw(roll, pitch, yaw);
  return pose;
}

// A pose written and read back: translations are stored as numbers (exact), rotations pass
// through roll/pitch/yaw and back (equal to a few ulps: the largest entry of R_a - R_b).
inline void ExpectSamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  EXPECT_EQ(a.translation(), b.translation());
  EXPECT_LT((a.linear() - b.linear()).cwiseAbs().maxCoeff(), 4e-16 * 4);
}

}  // namespace hetslam

#endif  // HETSLAM_TESTS_CORE_ROBOT_LOG_TEST_UTIL_H_
