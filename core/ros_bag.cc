// The ROS-free half of core/ros_bag.h: the options' checks and the loader of the ROS bag plugin
// (core/ros_bag_plugin.h says why it is one, how it is found and checked). Everything that
// touches a ROS type or library is in core/ros_bag_plugin.cc; hetslam_core links libdl only.
#include "core/ros_bag.h"

#include <atomic>
#include <cstdlib>
#include <sstream>

#include "core/plugin_loader.h"
#include "core/ros_bag_plugin.h"
#include "glog/logging.h"

namespace hetslam {

bool RosBagReadOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (base_frame.empty()) {
    why << "base_frame must not be empty";
  } else if (max_warnings_kept < 0) {
    why << "max_warnings_kept must be >= 0, got " << max_warnings_kept;
  } else if (robot_T_laser.has_value() && !robot_T_laser->matrix().allFinite()) {
    why << "robot_T_laser must be finite";
  } else if (!image_topic.empty() && image_topic != "none" && image_directory.empty()) {
    why << "image_topic '" << image_topic << "' needs an image_directory to write the images to";
  }
  if (error != nullptr) *error = why.str();
  return why.str().empty();
}

bool TrajectoryBagOptions::IsValid(std::string* error) const {
  std::ostringstream why;
  if (pose_topic.empty() || path_topic.empty()) {
    why << "pose_topic and path_topic must not be empty";
  } else if (pose_topic == path_topic) {
    why << "pose_topic and path_topic must differ (both '" << pose_topic << "')";
  } else if (frame_id.empty()) {
    why << "frame_id must not be empty";
  }
  if (error != nullptr) *error = why.str();
  return why.str().empty();
}

namespace ros_bag_plugin {
namespace {

// The table handed over by UseLinkedPlugin, and whether ProcessPlugin has been asked (after
// which the answer is fixed).
std::atomic<const RosBagPluginApi*> linked_api{nullptr};
std::atomic<bool> process_plugin_asked{false};

// "" when `api` comes from this very build (ros_bag_plugin.h: same ABI version, same layouts
// of the types exchanged, same compiler), else why not.
std::string Mismatch(const RosBagPluginApi& api) {
  return PluginBuildMismatch(api.abi_version, kAbiVersion, api.layout_fingerprint, LayoutFingerprint(), api.compiler);
}

}  // namespace

std::vector<std::string> PluginCandidates() {
#ifndef HETSLAM_HAVE_ROSBAG
  return {};
#else
  return PluginCandidatePaths(kPathVariable, {HETSLAM_ROSBAG_PLUGIN_BUILD_PATH, HETSLAM_ROSBAG_PLUGIN_INSTALL_PATH});
#endif
}

LoadedPlugin LoadPlugin(const std::vector<std::string>& candidates) {
  const LoadedPluginTable table =
      LoadPluginTable(candidates, kEntryPointName, &CallPluginEntryPoint<RosBagPluginApi>, "hetslam ROS bag plugin",
                      [](const void* api) { return Mismatch(*static_cast<const RosBagPluginApi*>(api)); });
  LoadedPlugin loaded;
  loaded.api = static_cast<const RosBagPluginApi*>(table.table);
  loaded.path = table.path;
  loaded.tried = table.tried;
  return loaded;
}

const LoadedPlugin& ProcessPlugin() {
  process_plugin_asked = true;
  // A function-local static: initialised once, by the first caller, while others wait.
  static const LoadedPlugin plugin = [] {
    if (const RosBagPluginApi* api = linked_api.load()) {
      // Compiled by the same build as this file, so a mismatch is a build error.
      const std::string mismatch = Mismatch(*api);
      CHECK(mismatch.empty()) << "the linked ROS bag plugin: " << mismatch;
      LoadedPlugin linked;
      linked.api = api;
      linked.path = "(linked into the program)";
      return linked;
    }
    return LoadPlugin(PluginCandidates());
  }();
  return plugin;
}

void UseLinkedPlugin(const RosBagPluginApi* api) {
  CHECK(api != nullptr);
  CHECK(!process_plugin_asked) << "UseLinkedPlugin must come before the first bag is read or written";
  linked_api = api;
}

}  // namespace ros_bag_plugin

Status CheckRosBagSupport() {
#ifndef HETSLAM_HAVE_ROSBAG
  return Status::Error(
      "this hetslam was built without ROS bag support (install librosbag-storage-dev, libsensor-msgs-dev, "
      "libnav-msgs-dev, libgeometry-msgs-dev and libtf2-msgs-dev, e.g. with scripts/install_deps.sh, then "
      "configure the build again)");
#else
  const ros_bag_plugin::LoadedPlugin& plugin = ros_bag_plugin::ProcessPlugin();
  if (plugin.api != nullptr) return Status::Ok();
  const char* variable = std::getenv(ros_bag_plugin::kPathVariable);
  const bool variable_set = variable != nullptr && variable[0] != '\0';
  return Status::Error(std::string("ROS bag support was built but its plugin could not be loaded: tried ") +
                       plugin.tried + "; " +
                       (variable_set ? std::string("HETSLAM_ROSBAG_PLUGIN must name the plugin's full path (unset, "
                                                   "the built and the installed plugin are tried)")
                                     : std::string("set HETSLAM_ROSBAG_PLUGIN to the full path of "
                                                   "libhetslam_rosbag_plugin.so")));
#endif
}

bool RosBagSupported() { return CheckRosBagSupport().ok(); }

Status ReadRosBag(const std::string& path, const RosBagReadOptions& options, RosBagContents* contents) {
#ifndef HETSLAM_HAVE_ROSBAG
  (void)options, (void)contents;
  return Status::Error("'" + path + "': " + CheckRosBagSupport().message());
#else
  CHECK(contents != nullptr);
  *contents = RosBagContents();
  std::string invalid;
  if (!options.IsValid(&invalid)) return Status::Error("invalid RosBagReadOptions: " + invalid);
  const Status support = CheckRosBagSupport();
  if (!support.ok()) return Status::Error("'" + path + "': " + support.message());
  return ros_bag_plugin::ProcessPlugin().api->read_bag(path, options, contents);
#endif
}

Status WriteTrajectoryBag(const std::string& path, const std::vector<StampedPose2>& trajectory,
                          const TrajectoryBagOptions& options) {
#ifndef HETSLAM_HAVE_ROSBAG
  (void)trajectory, (void)options;
  return Status::Error("'" + path + "': " + CheckRosBagSupport().message());
#else
  std::string invalid;
  if (!options.IsValid(&invalid)) return Status::Error("invalid TrajectoryBagOptions: " + invalid);
  const Status support = CheckRosBagSupport();
  if (!support.ok()) return Status::Error("'" + path + "': " + support.message());
  return ros_bag_plugin::ProcessPlugin().api->write_trajectory_bag(path, trajectory, options);
#endif
}

}  // namespace hetslam
