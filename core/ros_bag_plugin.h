// The boundary between hetslam_core and its ROS 1 bag plugin (internal; embedders use
// core/ros_bag.h). Debian's librosbag_storage pulls in librospack and with it libpython3.11,
// boost_program_options and more: about 4 MiB resident in every process that links it, bags or
// not (Intel's peak RSS 39.6-39.9 -> 35.4 MiB without them). So the code that uses ROS types and
// libraries lives in a MODULE library, libhetslam_rosbag_plugin.so (core/ros_bag_plugin.cc,
// built when HETSLAM_ROSBAG_ENABLED), which core/ros_bag.cc loads with dlopen the first time a
// bag is read or written (or RosBagSupported() asks). A run that never touches a bag never maps a ROS library.
//
// The plugin exports one C symbol, hetslam_rosbag_plugin_api(), returning a table of function
// pointers. The functions take and return hetslam's own C++ types (std::string, RosBagContents,
// Status): that is safe only because the plugin and core are compiled by the same build, with
// the same compiler, standard library and flags. A plugin of another build (a stale install, a
// wrong HETSLAM_ROSBAG_PLUGIN) is refused before any of its functions is called when its ABI
// version, the layout fingerprint of the types exchanged or its compiler differ from core's.
//
// Where the plugin is looked for (PluginCandidates):
//   1. $HETSLAM_ROSBAG_PLUGIN, the full path of the .so; when set, nothing else is tried;
//   2. the build tree's plugin (its path compiled in), so programs and tests run from the build;
//   3. the installed plugin, <libdir>/hetslam/libhetslam_rosbag_plugin.so under the
//      CMAKE_INSTALL_PREFIX configured (an install to another prefix, `cmake --install
//      --prefix`, needs the variable).
// A program that links the plugin's code itself (the ros_bag fuzzer: libFuzzer instruments what
// is linked in, not what is opened later) hands its table over with UseLinkedPlugin instead.
#ifndef HETSLAM_CORE_ROS_BAG_PLUGIN_H_
#define HETSLAM_CORE_ROS_BAG_PLUGIN_H_

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

#include "core/plugin_loader.h"
#include "core/ros_bag.h"
#include "core/status.h"

namespace hetslam {
namespace ros_bag_plugin {

// Bumped whenever the table below changes or one of its functions changes meaning.
constexpr uint32_t kAbiVersion = 1;

// The layout fingerprint (core/plugin_loader.h) of the types the table's functions exchange.
constexpr uint64_t LayoutFingerprint() {
  return PluginLayoutFingerprint(
      {sizeof(std::string), sizeof(Status), sizeof(RosBagReadOptions), alignof(RosBagReadOptions),
       sizeof(RosBagContents), alignof(RosBagContents), sizeof(LaserReading), alignof(LaserReading),
       sizeof(MargSample), alignof(MargSample), sizeof(AttitudeReading), sizeof(OdometryReading),
       alignof(OdometryReading), sizeof(VelocityCommand), sizeof(CameraImage), sizeof(StampedPose2),
       alignof(StampedPose2), sizeof(TrajectoryBagOptions)});
}

// The name of the one symbol the plugin exports.
constexpr char kEntryPointName[] = "hetslam_rosbag_plugin_api";
// The environment variable that names the plugin's full path.
constexpr char kPathVariable[] = "HETSLAM_ROSBAG_PLUGIN";

}  // namespace ros_bag_plugin

// The plugin's table. The first three fields keep their types and places in every version, so
// that a plugin of any version can be checked before anything else of it is read.
struct RosBagPluginApi {
  uint32_t abi_version;         // ros_bag_plugin::kAbiVersion of the plugin's build
  uint64_t layout_fingerprint;  // ros_bag_plugin::LayoutFingerprint() of the plugin's build
  const char* compiler;         // the plugin's compiler (__VERSION__)
  // ReadRosBag of core/ros_bag.h, called once core has checked the options (IsValid) and
  // cleared *contents; catches every exception of the ROS libraries.
  Status (*read_bag)(const std::string& path, const RosBagReadOptions& options, RosBagContents* contents);
  // WriteTrajectoryBag of core/ros_bag.h, called once core has checked the options.
  Status (*write_trajectory_bag)(const std::string& path, const std::vector<StampedPose2>& trajectory,
                                 const TrajectoryBagOptions& options);
};

namespace ros_bag_plugin {

struct LoadedPlugin {
  const RosBagPluginApi* api = nullptr;  // null when no candidate passed
  std::string path;                      // the file that passed
  // When api is null: "tried A (why), B (why)", every candidate with dlerror()'s text or the
  // check it failed.
  std::string tried;
};

// The candidates in lookup order (see the top of this file). Only the variable when it is set;
// none in a build without the plugin.
std::vector<std::string> PluginCandidates();

// dlopen(RTLD_NOW | RTLD_LOCAL)s each candidate in order and checks its table; the first that
// passes is returned. A file that opened but failed its check stays mapped (never dlclosed: the
// ROS libraries it brought in register exit handlers), unused.
LoadedPlugin LoadPlugin(const std::vector<std::string>& candidates);

// The process's plugin: LoadPlugin(PluginCandidates()) on the first call (thread-safe), the same
// answer afterwards; or the table handed to UseLinkedPlugin before that first call.
const LoadedPlugin& ProcessPlugin();

// For a program that links core/ros_bag_plugin.cc itself (the fuzzer): core uses `api` instead
// of loading anything. Call it before the first bag is read; a later call is a programmer error.
void UseLinkedPlugin(const RosBagPluginApi* api);

}  // namespace ros_bag_plugin
}  // namespace hetslam

// Defined by the plugin (core/ros_bag_plugin.cc), the one symbol it exports (the plugin is
// compiled with hidden visibility); its table lives as long as the plugin.
extern "C" __attribute__((visibility("default"))) const hetslam::RosBagPluginApi* hetslam_rosbag_plugin_api(void);

#endif  // HETSLAM_CORE_ROS_BAG_PLUGIN_H_
