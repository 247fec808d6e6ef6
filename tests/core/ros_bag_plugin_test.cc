// The loader of the ROS bag plugin (core/ros_bag_plugin.h): candidates in order, every failure
// named with its path and reason, the variable alone when set, a missing plugin an error and
// never a crash. This binary links no ROS library: the plugin brings them.
#include "core/ros_bag_plugin.h"

#include <dlfcn.h>
#include <stdlib.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "core/ros_bag.h"
#include "tests/core/mapped_libraries_test_util.h"
#include "glog/logging.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace hetslam {
namespace ros_bag_plugin {
namespace {

using ::testing::HasSubstr;

const std::string kBuiltPlugin = HETSLAM_ROSBAG_PLUGIN_BUILD_PATH;

// Checked in a fresh process (the "threadsafe" death-test style runs the test binary again), so
// that the other tests' loads do not count, whatever their order.
TEST(RosBagPluginTest, NothingOfRosIsMappedBeforeABagIsTouched) {
  ::testing::GTEST_FLAG(death_test_style) = "threadsafe";
  EXPECT_EXIT(std::exit(LibraryMapped("librosbag_storage") ? 1 : LibraryMapped("libpython") ? 2 : 0), ::testing::ExitedWithCode(0),
              "");
}

TEST(RosBagPluginTest, TheBuiltPluginLoadsAndPassesItsChecks) {
  const LoadedPlugin plugin = LoadPlugin({kBuiltPlugin});
  ASSERT_NE(nullptr, plugin.api) << plugin.tried;
  EXPECT_EQ(kBuiltPlugin, plugin.path);
  EXPECT_EQ(kAbiVersion, plugin.api->abi_version);
  EXPECT_EQ(LayoutFingerprint(), plugin.api->layout_fingerprint);
  EXPECT_TRUE(LibraryMapped("librosbag_storage"));  // brought in by the plugin
}

TEST(RosBagPluginTest, CandidatesAreTriedInOrderAndEachFailureIsNamed) {
  const std::string missing = "/nonexistent/libhetslam_rosbag_plugin.so";
  LoadedPlugin plugin = LoadPlugin({missing, kBuiltPlugin});
  ASSERT_NE(nullptr, plugin.api) << plugin.tried;
  EXPECT_EQ(kBuiltPlugin, plugin.path);

  plugin = LoadPlugin({missing, "/nonexistent/other.so"});
  EXPECT_EQ(nullptr, plugin.api);
  EXPECT_THAT(plugin.tried, HasSubstr(missing + " (cannot open shared object file: No such file or directory)"));
  EXPECT_THAT(plugin.tried, HasSubstr(", /nonexistent/other.so ("));
  EXPECT_EQ("no candidate", LoadPlugin({}).tried);
}

// A file that is no library, or a library without the entry point: PluginLoaderTest (the loader
// is shared); here, that the refusal names this plugin.
TEST(RosBagPluginTest, ALibraryWithoutTheEntryPointIsRefusedAsNoRosBagPlugin) {
  Dl_info info;  // glog's shared library: loads, but is no plugin
  bool (*glog_function)() = &google::IsGoogleLoggingInitialized;
  ASSERT_NE(0, dladdr(reinterpret_cast<void*>(glog_function), &info));
  EXPECT_THAT(LoadPlugin({info.dli_fname}).tried, HasSubstr("(no symbol hetslam_rosbag_plugin_api: not a hetslam ROS bag plugin)"));
}

TEST(RosBagPluginTest, TheVariableIsTheOnlyCandidateWhenSet) {
  ASSERT_EQ(0, setenv(kPathVariable, "/elsewhere/plugin.so", 1));
  EXPECT_EQ(std::vector<std::string>{"/elsewhere/plugin.so"}, PluginCandidates());
  ASSERT_EQ(0, unsetenv(kPathVariable));
  const std::vector<std::string> candidates = PluginCandidates();
  ASSERT_EQ(2u, candidates.size());
  EXPECT_EQ(kBuiltPlugin, candidates[0]);
  EXPECT_EQ(HETSLAM_ROSBAG_PLUGIN_INSTALL_PATH, candidates[1]);
}

// The one test of this binary that asks for the process's plugin (loaded once per process).
TEST(RosBagPluginTest, AMissingPluginMakesEveryBagFunctionReturnAnError) {
  ASSERT_EQ(0, setenv(kPathVariable, "/nonexistent.so", 1));
  EXPECT_FALSE(RosBagSupported());
  const Status support = CheckRosBagSupport();
  EXPECT_THAT(support.message(), HasSubstr("ROS bag support was built but its plugin could not be loaded: tried "
                                           "/nonexistent.so (cannot open shared object file"));
  EXPECT_THAT(support.message(), HasSubstr("HETSLAM_ROSBAG_PLUGIN"));
  RosBagContents contents;
  const Status read = ReadRosBag("some.bag", RosBagReadOptions(), &contents);
  EXPECT_THAT(read.message(), HasSubstr("'some.bag': ROS bag support was built but its plugin could not be loaded"));
  const Status write = WriteTrajectoryBag("out.bag", {}, TrajectoryBagOptions());
  EXPECT_THAT(write.message(), HasSubstr("'out.bag': ROS bag support was built but its plugin could not be loaded"));
  ASSERT_EQ(0, unsetenv(kPathVariable));
}

}  // namespace
}  // namespace ros_bag_plugin
}  // namespace hetslam
